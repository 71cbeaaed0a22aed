//! Photon tracing: light paths as in the light tracer (same emission, importance-mode BSDF
//! sampling, adjoint shading-normal correction, Russian roulette), but instead of connecting
//! each vertex to the camera they leave a [`Photon`] at every non-delta vertex after the first
//! bounce. Vertices hit straight from the light are skipped: the camera side adds that light
//! by next-event estimation, and storing it too would count direct light twice.

use std::ops::Range;

use glam::Vec3;

use super::kdtree::Photon;
use crate::geometry::{offset_point, survival_probability};
use crate::integrators::light::scatter_particle;
use crate::integrators::path::PathSettings;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// The sampler's "pixel x" of photon path `m` (with y = m >> 16, index = m & 0xffff): apart
/// from every image pixel and from the light tracer's stream, so photons reuse no other
/// path's numbers. `lumo render` and the server draw the same numbers for photon path `m`.
pub const PHOTON_STREAM_X: u32 = 0x5048_4f54;

/// Photons of a run of consecutive photon paths, kept per path so a map can take a prefix of
/// whole paths.
#[derive(Clone, Debug, Default)]
pub struct PhotonBatch {
    /// The photons, path after path.
    pub photons: Vec<Photon>,
    /// For each path, the end of its photons in `photons` (non-decreasing).
    pub path_end: Vec<u32>,
    /// Rays traced.
    pub rays: u64,
}

impl PhotonBatch {
    /// Traces photon paths `paths` (indices into the photon stream of `seed`) in order: a
    /// pure function of its arguments.
    pub fn trace(rs: &RenderScene, settings: &PathSettings, seed: u32, paths: Range<u64>) -> Self {
        let mut batch = PhotonBatch::default();
        for m in paths {
            let mut sampler =
                PixelSampler::new(PHOTON_STREAM_X, (m >> 16) as u32, (m & 0xffff) as u32, seed);
            batch.rays += trace_photon_path(rs, &mut sampler, settings, &mut batch.photons) as u64;
            batch.path_end.push(batch.photons.len() as u32);
        }
        batch
    }

    /// Photon paths traced (including those that stored nothing).
    pub fn paths(&self) -> u64 {
        self.path_end.len() as u64
    }

    /// Appends `other`'s paths after this batch's.
    pub fn append(&mut self, other: PhotonBatch) {
        let base = self.photons.len() as u32;
        self.photons.extend(other.photons);
        self.path_end
            .extend(other.path_end.iter().map(|e| e + base));
        self.rays += other.rays;
    }
}

/// Traces one photon path with the numbers of `sampler`, pushing its photons onto `out`.
/// Returns the rays traced.
pub fn trace_photon_path(
    rs: &RenderScene,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    out: &mut Vec<Photon>,
) -> u32 {
    let u_choice = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(e) = rs.lights.sample_emission(u_choice, u_pos, u_dir) else {
        return 0;
    };
    let mut origin = match e.normal {
        Some(n) => offset_point(e.p.into(), n.into(), e.dir.into(), rs.ray_epsilon).into(),
        None => e.p,
    };
    let (mut dir, mut throughput) = (e.dir, e.weight);
    // A light with a range weighs the photon by its window of the first segment's length.
    let mut range = rs.lights.range(e.light);
    let mut rays = 0;
    // Segments from the light to the vertex about to be hit. A photon of depth j needs at
    // least one camera segment to be seen, so light paths end at max_depth − 1 segments.
    let mut j = 1u32;
    let longest = settings.max_depth.saturating_sub(1);
    loop {
        if j > longest || throughput == Vec3::ZERO || !throughput.is_finite() {
            break;
        }
        rays += 1;
        let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
            break;
        };
        let s = rs.surface(&hit, origin, dir);
        if let Some(r) = range.take() {
            throughput *= lumo_scene::range_window(e.p.distance(s.p), r);
            if throughput == Vec3::ZERO {
                break;
            }
        }
        let bsdf = rs.bsdf(&s);
        let wl = -dir;
        let (ns, ng) = (s.frame.n, s.ng);
        let (cos_ns_l, cos_ng_l) = (ns.dot(wl).abs(), ng.dot(wl).abs());
        if cos_ng_l <= 0.0 || cos_ns_l <= 0.0 {
            break;
        }
        let wl_local = s.frame.to_local(wl);
        // One-sided BSDFs lit from behind are black both ways, as in the light tracer.
        if wl_local.z <= 0.0 && rs.one_sided(s.material) {
            break;
        }
        if j >= 2 && !bsdf.is_delta() {
            out.push(Photon {
                p: s.p,
                wi: wl,
                ng,
                power: throughput,
                depth: j,
            });
        }
        if j >= longest {
            break;
        }
        // Arrival half of the adjoint shading-normal correction (the gather applies its own
        // to the stored, uncorrected power).
        throughput *= cos_ns_l / cos_ng_l;
        let u_lobe = sampler.next_1d();
        let u_bsdf = sampler.next_2d();
        let u_rr = sampler.next_1d();
        let Some((new_dir, _, weight)) = scatter_particle(&bsdf, &s, wl, wl_local, u_lobe, u_bsdf)
        else {
            break;
        };
        // Departure half (in `weight`).
        throughput *= weight;
        origin = rs.offset(&s, new_dir);
        dir = new_dir;
        // The light tracer's roulette, at the same depth (its depth counts the camera
        // segment: j + 1).
        if j + 1 >= settings.rr_depth {
            let q = survival_probability(throughput.max_element(), 1.0);
            if u_rr >= q {
                break;
            }
            throughput /= q;
        }
        j += 1;
    }
    rays
}
