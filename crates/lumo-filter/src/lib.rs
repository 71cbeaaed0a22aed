//! Screen-space denoising filters (see the crate description).
