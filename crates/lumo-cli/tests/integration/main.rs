//! The lumo-cli integration tests, one test program (each separate program would link the whole
//! crate again: minutes of a fresh build). Each module is one topic.
mod bench_cli;
mod chunked;
mod closed_pipes;
mod common;
mod compare_cli;
mod denoise_cli;
mod export_cli;
mod hostile_options;
mod interrupted_writes;
mod memory_limits;
mod output_checks;
mod scene_files;
mod sequence_cli;
