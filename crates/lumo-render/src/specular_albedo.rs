//! The albedo plane behind glass and mirrors.
//!
//! A denoiser divides the colour by the albedo plane so that texture is not blurred. At a
//! surface whose every lobe is a Dirac delta (smooth glass, a mirror) the colour shows what
//! lies behind or in front of it — a refracted checkerboard — while that surface's own
//! "albedo" is a constant, so the filters blurred the refracted texture away
//! (`cornell-spheres`). OIDN's convention is the albedo of the first non-delta surface along
//! the specular chain; following the path's own sampled branch gives a speckled plane at a
//! few samples per pixel (each sample takes the reflection or the refraction), so here both
//! branches are followed at once, each weighted by its Fresnel share: a deterministic,
//! noise-free albedo.

use glam::{Vec2, Vec3};

use crate::bsdf::Bsdf;
use crate::render_scene::{RenderScene, Surface};

/// Longest chain of Dirac bounces followed (into and out of a sphere is two).
const MAX_BOUNCES: u32 = 4;
/// Branches whose weight falls below this (in every channel) are dropped.
const MIN_WEIGHT: f32 = 0.05;

/// The albedo plane's value at a first hit `s` with an all-delta `bsdf`, seen along `dir`:
/// the sum over its lobes (reflection, refraction) of the lobe's share times the albedo of
/// the first non-delta surface it shows, followed through up to [`MAX_BOUNCES`] delta
/// surfaces; 0 for a branch that leaves the scene. Also returns the rays traced.
pub(crate) fn albedo_behind(rs: &RenderScene, s: &Surface, bsdf: &Bsdf, dir: Vec3) -> (Vec3, u32) {
    let mut rays = 0;
    let albedo = follow(rs, s, bsdf, dir, Vec3::ONE, MAX_BOUNCES, &mut rays);
    (albedo, rays)
}

fn follow(
    rs: &RenderScene,
    s: &Surface,
    bsdf: &Bsdf,
    dir: Vec3,
    weight: Vec3,
    left: u32,
    rays: &mut u32,
) -> Vec3 {
    let wo = s.frame.to_local(-dir);
    let mut sum = Vec3::ZERO;
    let mut previous: Option<Vec3> = None;
    // A lobe-selection number of 0 picks the first lobe (reflection), one just below 1 the
    // last (refraction); a BSDF with one lobe returns it twice.
    for u_lobe in [0.0, 1.0 - f32::EPSILON] {
        let Some(bs) = bsdf.sample(wo, u_lobe, Vec2::ZERO) else {
            continue;
        };
        if previous == Some(bs.wi) {
            continue;
        }
        previous = Some(bs.wi);
        // weight / pdf is the lobe's share over its probability; the radiance scaling of a
        // refraction (1/η² in `weight`) is not reflectance, so it is taken out again.
        let w = weight * bs.weight * bs.pdf * (bs.eta * bs.eta);
        if w.max_element() < MIN_WEIGHT || !w.is_finite() {
            continue;
        }
        let new_dir = s.frame.to_world(bs.wi).normalize();
        let origin = rs.offset(s, new_dir);
        *rays += 1;
        let Some(hit) = rs.accel.intersect(origin, new_dir, 0.0, f32::INFINITY) else {
            continue;
        };
        let next = rs.surface(&hit, origin, new_dir);
        let next_bsdf = rs.bsdf(&next).bsdf;
        sum += if next_bsdf.is_delta() && left > 1 {
            follow(rs, &next, &next_bsdf, new_dir, w, left - 1, rays)
        } else {
            w * next_bsdf.albedo_towards(next.frame.to_local(-new_dir))
        };
    }
    sum
}
