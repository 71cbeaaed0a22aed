//! The `lumo` command's subcommands as a library: the binary (`main.rs`) parses the command
//! line into them, and lumo's Python package (`python/`) runs `lumo render`'s plan, its chunked
//! rendering and its outputs through the same code ([`chunked`]).
#![forbid(unsafe_code)]

pub mod arguments;
pub mod bench;
pub mod chunked;
pub mod cli_common;
pub mod compare_cmd;
pub mod denoise;
pub mod export_cmd;
pub mod integrator_arg;
pub mod output;
pub mod pipeline_args;
pub mod render;
pub mod scene_load;
pub mod serve_cmd;
pub mod worker_cmd;
