//! The lumo-image integration tests, one test program (each separate program would link the whole
//! crate again: minutes of a fresh build). Each module is one topic.
mod flip_reference;
mod hostile_input;
