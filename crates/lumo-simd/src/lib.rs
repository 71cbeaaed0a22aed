//! The one place for lumo's vector-instruction-set plumbing, shared by the renderer and the
//! filters:
//!
//! - [`Isa`]: which instruction set the hot loops may use, detected once, capped by the
//!   `LUMO_SIMD` environment variable (`avx2`, `baseline`) so narrower forms can be timed on
//!   machines with wider ones. Every form computes the same bits (each crate tests its kernels
//!   against the baseline), so the cap changes speed only — except the À-Trous kernels' FMA
//!   forms, which differ from the baseline in the last bits (docs/filters.md).
//! - [`multiversion!`]: one function body compiled for AVX-512, AVX2 and baseline x86-64,
//!   dispatched on [`Isa::detect`].
//! - [`LANES`] / [`Lanes`]: the 16-float lane array the packet, vector-bounce and filter
//!   kernels loop over (one AVX-512 register, two AVX2 ones).
//! - [`fastmath`]: branch-free `exp` variants that vectorise.
// The multiversion! macro expands to unsafe calls of target-feature functions; each says why
// it is sound.
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod fastmath;
mod isa;
mod multiversion;

pub use isa::Isa;

/// Floats per lane array: one AVX-512 register, two AVX2 ones.
pub const LANES: usize = 16;

/// Sixteen floats, one per lane (a ray of a packet, a path of a bounce, a pixel of a run).
pub type Lanes = [f32; LANES];
