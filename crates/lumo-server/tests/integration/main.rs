//! The lumo-server integration tests, one test program (each separate program would link the whole
//! crate again: minutes of a fresh build). Each module is one topic.
mod edits;
mod hostile;
mod protocol_golden;
mod protocol_layout;
mod remote;
mod server;
mod stream_bits;
mod worker;
