//! The lumo-pipeline integration tests, one test program (each separate program would link the
//! whole renderer again). Each module is one topic.
mod pipelines;
