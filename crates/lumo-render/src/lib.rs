//! Path tracer.
