//! The lumo-filter integration tests, one test program (each separate program would link the
//! whole crate again: minutes of a fresh build). Each module is one topic; run one with
//! `cargo test -p lumo-filter --test integration TOPIC`.
#![allow(clippy::needless_range_loop)]

mod atrous;
mod auto;
mod bilateral;
mod denoiser;
mod emitters;
mod guided;
mod invariants;
mod jbu;
mod support;
