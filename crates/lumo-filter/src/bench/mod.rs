//! Inputs and configurations for benchmarks, tests and the parameter sweep: the procedural
//! [`synthetic`] frame and the papers' [`table2`] filter configurations (shared by
//! `cargo bench -p lumo-filter` and `lumo bench speed`).

pub mod synthetic;
pub mod table2;
