//! The lumo-render integration tests, one test program (each separate program would link the whole
//! crate again: minutes of a fresh build). Each module is one topic.
mod accel;
mod analytic_shapes;
mod animation;
mod bsdf_sampling;
mod common;
mod direct_light_geometry;
mod emission_texture;
mod gltf_clearcoat;
mod gltf_pbr;
mod gltf_sheen;
mod gltf_specular;
mod gltf_transmission;
mod gltf_volume;
mod integrator;
mod light_render;
mod light_sampling;
mod media;
mod media_light;
mod mitsuba_adapters;
mod mitsuba_cornell;
mod mitsuba_suite;
mod spectral;
mod specular_albedo;
mod transport_modes;
mod wavefront;
