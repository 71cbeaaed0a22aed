//! The lumo-scene integration tests, one test program (each separate program would link the whole
//! crate again: minutes of a fresh build). Each module is one topic.
mod attributes;
mod common;
mod gltf;
mod gltf_extensions;
mod hostile_input;
mod in_memory;
mod media;
mod meshes;
mod mitsuba;
mod mitsuba_principled;
mod mitsuba_silent;
mod mutated;
mod robustness;
mod skins;
mod unbounded;
mod wrong_output;
