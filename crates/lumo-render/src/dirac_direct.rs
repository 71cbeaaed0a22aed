//! The light that point, spot and directional lights (Dirac lights) give the first hit of a
//! pixel's own camera samples, computed exactly: what a denoiser can leave out of its input
//! and add back unfiltered.
//!
//! Why: a Dirac light's contribution at a first hit has no randomness but the pixel's own
//! footprint (its shadow ray either reaches the light or not), so it holds the sharpest
//! detail of a sunlit frame — one-pixel shadows of wires and branches — which no guide
//! shows and every filter blurs. The path tracer's estimate of it is noisy (it picks one light
//! per vertex), but its expectation per camera sample is exactly this pass's value, so the
//! colour minus this pass is the rest of the light with the same expectation, and the sharp
//! shadows skip the filter (the direct/indirect split of the interactive-GI papers, for the
//! lights where the direct part needs no filter at all).
//!
//! Each camera sample is the path tracer's own (`camera_sample`: same seed, same sub-pixel
//! position), and every step mirrors its first vertex: one-sided back faces and Dirac BSDFs
//! give nothing, masks weigh by their opacity (in the BSDF's value) and shadow rays cross
//! masks with transmittance 1 − opacity where the path tracer's do. Where the renderer would do
//! something else (participating media, spectral transport, a pixel filter other than the
//! box, next-event estimation off, max depth below 2) there is no pass (`None`).

use glam::Vec3;
use lumo_image::Image;
use lumo_scene::PixelFilter;

use crate::camera::PinholeCamera;
use crate::camera_sample::camera_sample;
use crate::direct_split::shadow_ray;
use crate::integrators::path::{mask_shadow, ShadowRay};
use crate::parallel::map_pixels;
use crate::{RenderScene, RenderSettings};

/// Camera samples per pixel of the pass at least. Below, the pass would keep a 1-spp frame's
/// aliasing (a wire's sunlit pixel is lit or not by its centre ray) unfiltered; with more
/// samples it is the pixel's footprint average, and the colour's own aliasing becomes part of
/// the residual the filter smooths. `tune-wires` at 1 spp, 256²: relMSE 1.15e-2 with the
/// frame's one sample, 9.8e-3 without the pass, and with 4: see docs/filters.md.
pub const MIN_SAMPLES: u32 = 4;

/// The mean over each pixel's `settings.spp` (at least [`MIN_SAMPLES`]) camera samples of the Dirac lights' light at
/// the sample's first hit (3 channels, linear RGB), or `None` where the scene has no Dirac
/// light or the renderer's first vertex would differ from this pass (see the module docs).
pub fn dirac_direct(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
) -> Option<Image> {
    let path = &settings.path;
    let applies = rs.lights.has_delta()
        && !rs.scene.media.is_active()
        && !path.spectral
        && path.nee
        && path.max_depth >= 2
        && settings.spp > 0
        && rs.scene.camera.filter == PixelFilter::Box;
    if !applies {
        return None;
    }
    let (w, h) = (settings.width, settings.height);
    let masks = mask_shadow::applies(rs);
    let n = settings.spp.max(MIN_SAMPLES);
    let pixels = map_pixels(w, h, &|_| {}, |x, y| {
        let sum: Vec3 = (0..n)
            .map(|i| {
                let (_, _, origin, dir) = camera_sample(camera, (x, y), i, settings.seed);
                first_vertex(rs, origin, dir, path.max_depth, masks)
            })
            .sum();
        sum / n as f32
    });
    Some(Image::from_vec(
        w,
        h,
        3,
        pixels.iter().flat_map(|v| v.to_array()).collect(),
    ))
}

/// The Dirac lights' light at the first hit of the camera ray `origin + t·dir`, as the path
/// tracer's next-event estimation there gives it in expectation.
fn first_vertex(rs: &RenderScene, origin: Vec3, dir: Vec3, max_depth: u32, masks: bool) -> Vec3 {
    let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
        return Vec3::ZERO;
    };
    let s = rs.surface(&hit, origin, dir);
    let bsdf = rs.bsdf(&s);
    let wo = s.frame.to_local(-dir);
    if (wo.z <= 0.0 && rs.one_sided(s.material)) || bsdf.is_delta() {
        return Vec3::ZERO;
    }
    let mut sum = Vec3::ZERO;
    for ls in rs.lights.delta_samples(s.p) {
        let f = bsdf.eval(wo, s.frame.to_local(ls.wi));
        if f == Vec3::ZERO {
            continue;
        }
        let (o, d, tmax) = shadow_ray(rs, &s, &ls);
        // A Dirac light has no density, so the path tracer gives its sample full weight.
        let value = f * ls.weight;
        if !rs.accel.occluded(o, d, 0.0, tmax) {
            sum += value;
        } else if masks {
            let sh = ShadowRay {
                origin: o,
                dir: d,
                tmax,
                contribution: value,
                // The first vertex is depth 1; its light vertex is depth 2.
                depth: 2,
            };
            let t = mask_shadow::transmittance(rs, &sh, mask_shadow::max_crossings(&sh, max_depth));
            sum += value * t;
        }
    }
    if sum.is_finite() {
        sum
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests;
