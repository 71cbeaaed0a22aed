//! The volumetric path tracer: [`PathState`]'s surface phases with participating media
//! between surfaces, one ray at a time. Scenes with media or invisible (`null`) boundaries take
//! this path in every renderer that uses the path tracer (the wavefront hands their paths
//! here; see docs/media.md).
//!
//! Along each ray the current medium samples a free flight ([`crate::media::free_flight`]);
//! a real scattering is a path vertex like a surface hit: next-event estimation with the
//! phase function, MIS (power heuristic) against phase sampling, then a phase sample. Null
//! surfaces are crossed without a vertex (no depth, no shading), changing the medium where
//! the shape has an interior or exterior; shadow rays cross them too and carry the
//! transmittance of every medium on the way (ratio tracking in grids).

use glam::Vec3;

use super::{PathSettings, PathState};
use crate::geometry::{power_heuristic, shadow_segment};
use crate::media::walk::{self, mesh_of, target, LaneMis, MAX_CROSSINGS};
use crate::media::{free_flight, phase, Coefficients, Flight};
use crate::render_scene::RenderScene;

impl PathState {
    /// Traces this path to its end through the scene's media, starting in the camera's
    /// medium.
    pub(crate) fn run_volumetric(&mut self, rs: &RenderScene, settings: &PathSettings) {
        let media = &rs.scene.media;
        let mut medium = media.camera;
        let mut crossings = 0;
        // Distance along the camera ray to the current origin: null crossings move the
        // origin, and the G-buffer's depth is measured from the camera.
        let mut travelled = 0.0f32;
        // The lane whose exponentials sample homogeneous media (walk.rs, tracking.rs).
        let mut lanes = LaneMis::new(self.sampler.next_1d());
        loop {
            let hit = rs
                .accel
                .intersect(self.origin, self.dir, 0.0, f32::INFINITY);
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            if let Some(m) = medium {
                let med = &media.media[m];
                let c = Coefficients::of(med, self.wl.as_ref());
                let flight = free_flight(
                    med,
                    &c,
                    self.origin,
                    self.dir,
                    tmax,
                    lanes.lane,
                    self.throughput,
                    &mut self.sampler,
                );
                lanes.apply(&mut self.throughput, &flight);
                match flight {
                    Flight::Scatter { t, .. } => {
                        self.radiance.rays += 1;
                        if !self.medium_vertex(rs, settings, m, t, travelled) {
                            return;
                        }
                        continue;
                    }
                    Flight::Pass { .. } => {
                        if self.throughput == Vec3::ZERO {
                            return;
                        }
                    }
                }
            }
            let boundary = hit.map(|h| media.boundary(mesh_of(rs, &h)));
            if let (Some(h), Some(b)) = (hit, boundary.filter(|b| b.null)) {
                // An invisible boundary: no vertex, only a change of medium.
                self.radiance.rays += 1;
                crossings += 1;
                if crossings > MAX_CROSSINGS {
                    return;
                }
                let s = rs.surface(&h, self.origin, self.dir);
                if let Some(f) = b.interface {
                    medium = target(f, s.ng, self.dir);
                }
                let next = rs.offset(&s, self.dir);
                if self.depth == 1 {
                    travelled += (next - self.origin).dot(self.dir);
                }
                self.origin = next;
                continue;
            }
            let recording = self.want_first_hit;
            let arrived = self.arrive(rs, settings, hit);
            if recording && !self.want_first_hit {
                self.first_hit.depth += travelled;
            }
            let Some(at) = arrived else {
                return;
            };
            let u = self.draw();
            let light = self.sample_light(rs, settings, &at, &u);
            if let Some(sh) = self.connect(rs, settings, &at, light) {
                let from = match boundary.and_then(|b| b.interface) {
                    Some(f) => target(f, at.s.ng, sh.dir),
                    None => medium,
                };
                let tr = self.transmittance(rs, from, sh.origin, sh.dir, sh.tmax);
                if tr != Vec3::ZERO {
                    self.radiance.add(sh.depth, sh.contribution * tr);
                }
            }
            if !self.scatter(rs, settings, &at, &u) {
                return;
            }
            if let Some(f) = boundary.and_then(|b| b.interface) {
                medium = target(f, at.s.ng, self.dir);
            }
            crossings = 0;
        }
    }

    /// A real scattering in medium `m` at `t` along the current ray (throughput already
    /// weighted; the ray's origin `travelled` along the camera ray at depth 1): the G-buffer
    /// record at the first vertex, light sampling with the phase
    /// function, a phase sample and Russian roulette. Returns whether the path goes on.
    fn medium_vertex(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        m: usize,
        t: f32,
        travelled: f32,
    ) -> bool {
        let med = &rs.scene.media.media[m];
        let p = self.origin + self.dir * t;
        if self.depth == 1 {
            // A pixel whose camera ray scatters in a medium: its albedo is the medium's
            // single-scattering albedo; its normal, position and depth are those of the
            // surface the ray would reach behind the fog (docs/media.md, "AOVs of a pixel in
            // fog"): the scattering distance itself is random per pixel, and as a guide it
            // made every fog pixel an edge the filters stopped at.
            self.radiance.albedo = med.albedo;
            self.radiance.emitted = Vec3::ZERO;
            if std::mem::take(&mut self.want_first_hit) {
                let (normal, position, depth) =
                    surface_behind(rs, self.origin, self.dir).unwrap_or((-self.dir, p, t));
                self.first_hit = super::FirstHit {
                    normal,
                    position,
                    depth: travelled + depth,
                    albedo: med.albedo,
                    emitted: Vec3::ZERO,
                };
            }
        }
        if self.depth >= settings.max_depth {
            return false;
        }
        let u = self.draw();
        if settings.nee {
            if let Some(ls) = rs.lights.sample(p, u.light, u.light_point) {
                let f = phase::eval(med.phase, self.dir, ls.wi);
                let (dir, tmax) = if ls.distance.is_finite() {
                    let (d, tm) =
                        shadow_segment(p.into(), ls.point.into(), ls.wi.into(), rs.ray_epsilon);
                    (Vec3::from(d), tm)
                } else {
                    (ls.wi, f32::INFINITY)
                };
                self.radiance.rays += 1;
                let w = if ls.pdf > 0.0 && settings.bsdf_emission {
                    power_heuristic(ls.pdf, f)
                } else {
                    1.0
                };
                let weight = match &self.wl {
                    None => ls.weight,
                    Some(wl) => rs.spectral_light(ls.weight, ls.light, wl),
                };
                let contribution = self.throughput * f * weight * w;
                if contribution != Vec3::ZERO {
                    let tr = self.transmittance(rs, Some(m), p, dir, tmax);
                    self.radiance.add(self.depth + 1, contribution * tr);
                }
            }
        }
        let (wi, pdf) = phase::sample(med.phase, self.dir, u.direction);
        if pdf.is_nan() || pdf <= 0.0 {
            return false;
        }
        self.prev_pdf = Some(pdf);
        self.prev_point = p;
        self.origin = p;
        self.dir = wi;
        if self.depth >= settings.rr_depth {
            // Without the surfaces' 0.95 cap: in an albedo-1 medium the throughput stays 1 and
            // a path may scatter hundreds of times before it leaves; a 5 % kill per scattering
            // would leave a few survivors with weights of 1.05^k (a heavy tail that reads as
            // a darker image at any practical sample count). Such paths end by leaving the
            // medium, by absorption (a throughput below 1) or at the depth limit.
            let q = (self.throughput.max_element() * self.eta_scale).min(1.0);
            if u.roulette >= q {
                return false;
            }
            self.throughput /= q;
        }
        if self.throughput == Vec3::ZERO || !self.throughput.is_finite() {
            return false;
        }
        self.depth += 1;
        true
    }

    /// [`walk::transmittance`] with this path's wavelengths, sampler and ray count.
    fn transmittance(
        &mut self,
        rs: &RenderScene,
        medium: Option<usize>,
        o: Vec3,
        d: Vec3,
        tmax: f32,
    ) -> Vec3 {
        walk::transmittance(
            rs,
            medium,
            o,
            d,
            tmax,
            self.wl.as_ref(),
            &mut self.sampler,
            &mut self.radiance.rays,
        )
    }
}

/// The first surface that is not a null boundary along `origin + t·dir`: its normal facing
/// the ray, its position and its distance from `origin` (`None` if the ray leaves the scene
/// or crosses too many boundaries).
fn surface_behind(rs: &RenderScene, origin: Vec3, dir: Vec3) -> Option<(Vec3, Vec3, f32)> {
    let media = &rs.scene.media;
    let (mut o, mut travelled) = (origin, 0.0f32);
    for _ in 0..=MAX_CROSSINGS {
        let h = rs.accel.intersect(o, dir, 0.0, f32::INFINITY)?;
        let s = rs.surface(&h, o, dir);
        if !media.boundary(mesh_of(rs, &h)).null {
            let n = s.frame.n;
            let n = if n.dot(dir) > 0.0 { -n } else { n };
            return Some((n, s.p, travelled + h.t));
        }
        let next = rs.offset(&s, dir);
        travelled += (next - o).dot(dir);
        o = next;
    }
    None
}
