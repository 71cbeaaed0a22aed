//! The unidirectional path tracer: next-event estimation with multiple importance sampling
//! (power heuristic), Russian roulette, and separate direct and indirect estimates.
//!
//! Depth follows Mitsuba: a path of `k` segments has depth `k`; `max_depth = 1` shows emitters
//! only, `2` adds direct light, `3` one indirect bounce. "Direct" is everything of depth ≤ 2.

pub(crate) mod mask_shadow;
pub(crate) mod vector_bounce;
mod volume;
pub mod wavefront;

use glam::{Vec2, Vec3};
use lumo_spectrum::Wavelengths;

use crate::accel::Hit;
use crate::bsdf::Bsdf;
use crate::geometry::{power_heuristic, shadow_segment, survival_probability};
use crate::lights::LightSample;
use crate::render_scene::RenderScene;
use crate::render_scene::Surface;
use crate::sampler::PixelSampler;
use crate::shading::ShadingBsdf;
use crate::specular_albedo;

/// Integrator parameters.
#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    /// Longest path depth (Mitsuba convention).
    pub max_depth: u32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// Light sampling (next-event estimation) on.
    pub nee: bool,
    /// BSDF-sampled hits of emitters count (off: NEE only, for tests).
    pub bsdf_emission: bool,
    /// Spectral transport: each path carries three hero-rotated wavelengths and its estimate
    /// is converted to RGB through CIE XYZ (off: RGB transport).
    pub spectral: bool,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            max_depth: 8,
            rr_depth: 5,
            nee: true,
            bsdf_emission: true,
            spectral: false,
        }
    }
}

/// What the first hit of a camera ray looks like, for the G-buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstHit {
    /// Shading normal facing the camera (zero on a miss).
    pub normal: Vec3,
    /// World position (zero on a miss).
    pub position: Vec3,
    /// Distance from the camera (infinite on a miss).
    pub depth: f32,
    /// Reflectance used for demodulation (zero on a miss).
    pub albedo: Vec3,
    /// Radiance emitted towards the camera at the hit (the environment's on a miss): pipelines
    /// keep emitters out of the filters, which would otherwise smear them over their neighbours.
    pub emitted: Vec3,
}

impl FirstHit {
    /// Whether the pixel shows an emitter whose radiance a filter must not spread: it emits
    /// towards the camera and has an albedo (where the albedo is zero, demodulation already
    /// passes the pixel through). The rule of every filtered pipeline and the server's frames.
    pub fn is_visible_emitter(&self) -> bool {
        self.emitted != Vec3::ZERO && self.albedo != Vec3::ZERO
    }
}

/// Radiance carried by one camera path, split by depth.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathRadiance {
    /// Emitted light seen directly plus direct illumination (depth ≤ 2).
    pub direct: Vec3,
    /// Everything of depth ≥ 3.
    pub indirect: Vec3,
    /// Rays traced (closest-hit and shadow).
    pub rays: u32,
    /// Reflectance of the first surface the path hit (zero on a miss). A pixel's albedo plane
    /// is the mean of its samples' (the colour's average over the same samples), so that
    /// demodulating by it does not re-impose one sample's texture on the whole pixel.
    pub albedo: Vec3,
    /// Radiance the first hit emits towards the camera (a light, or the environment on a
    /// miss; already part of `direct`). Its mean over a pixel's samples is the part of the
    /// pixel's colour that filters must not spread: with several samples a pixel on a light's
    /// rim mixes the light with its surroundings while its centre ray may see either.
    pub emitted: Vec3,
}

impl PathRadiance {
    #[inline]
    pub(crate) fn add(&mut self, depth: u32, value: Vec3) {
        // A NaN from a degenerate configuration must not poison the pixel.
        if !value.is_finite() {
            return;
        }
        if depth <= 2 {
            self.direct += value;
        } else {
            self.indirect += value;
        }
    }
}

/// A shadow ray of next-event estimation and what it adds to its path if nothing blocks it.
#[derive(Clone, Copy, Debug)]
pub struct ShadowRay {
    /// Ray origin (offset off the surface).
    pub origin: Vec3,
    /// Unit direction towards the light.
    pub dir: Vec3,
    /// Largest ray parameter that still lies before the light.
    pub tmax: f32,
    /// Radiance the path receives if the ray is unoccluded.
    pub(crate) contribution: Vec3,
    /// Depth the contribution counts at.
    pub(crate) depth: u32,
}

/// A path's shading point after [`PathState::arrive`]: surface, BSDF, outgoing direction.
#[derive(Clone, Copy, Debug)]
struct Arrival {
    /// The surface hit.
    s: Surface,
    /// Its BSDF.
    bsdf: ShadingBsdf,
    /// Direction back along the ray, in the shading frame.
    wo: Vec3,
}

/// The random numbers of one bounce.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BounceNumbers {
    pub(crate) light: f32,
    pub(crate) light_point: Vec2,
    pub(crate) lobe: f32,
    pub(crate) direction: Vec2,
    pub(crate) roulette: f32,
}

/// One camera path between ray queries: the integrator as a state machine, so that the
/// one-path loop ([`trace_path`]) and the wavefront renderer ([`crate::integrators::path::wavefront`]), which
/// traces the rays of many paths together, run the same code and give the same result.
#[derive(Clone, Copy, Debug)]
// Fields in the order a bounce touches them, the first-hit record (written once per path)
// last: a batch's states outgrow the first-level cache, and keeping the per-bounce fields
// together touches fewer cache lines per path.
#[repr(C)]
pub struct PathState {
    /// The path's random numbers.
    pub sampler: PixelSampler,
    /// Origin of the ray to trace next.
    pub origin: Vec3,
    /// Unit direction of the ray to trace next.
    pub dir: Vec3,
    pub(crate) throughput: Vec3,
    pub(crate) eta_scale: f32,
    pub(crate) depth: u32,
    /// Density of the BSDF sample that produced the current ray; None for camera rays and
    /// delta lobes (no MIS against light sampling).
    pub(crate) prev_pdf: Option<f32>,
    pub(crate) prev_point: Vec3,
    pub(crate) want_first_hit: bool,
    /// Radiance gathered so far.
    pub radiance: PathRadiance,
    /// The path's wavelengths under spectral transport: the lanes of every colour it carries
    /// are then these wavelengths, not R, G, B.
    pub(crate) wl: Option<Wavelengths>,
    /// The first hit, once known (filled only if asked for).
    pub first_hit: FirstHit,
}

impl PathState {
    /// A path starting with the ray `origin + t·dir` (unit `dir`); `want_first_hit` asks for
    /// the G-buffer record of its first hit.
    pub fn new(origin: Vec3, dir: Vec3, sampler: PixelSampler, want_first_hit: bool) -> Self {
        PathState {
            origin,
            dir,
            sampler,
            radiance: PathRadiance::default(),
            first_hit: FirstHit::default(),
            want_first_hit,
            throughput: Vec3::ONE,
            prev_pdf: None,
            prev_point: origin,
            eta_scale: 1.0,
            depth: 1,
            wl: None,
        }
    }

    /// This path under spectral transport if `spectral`: its wavelengths drawn from its own
    /// sampler (the next dimension, so RGB paths keep their sample stream).
    #[inline]
    pub fn spectral(mut self, spectral: bool) -> Self {
        if spectral {
            self.make_spectral();
        }
        self
    }

    /// Puts this path under spectral transport in place (see [`PathState::spectral`]).
    #[inline]
    pub fn make_spectral(&mut self) {
        self.wl = Some(Wavelengths::sample(self.sampler.next_1d()));
    }

    /// What the path gathered, as RGB: under spectral transport its per-wavelength radiance
    /// through the CIE observer.
    #[inline]
    pub fn result(&self) -> PathRadiance {
        match &self.wl {
            None => self.radiance,
            Some(wl) => {
                let (direct, indirect) =
                    wl.to_rgb_pair(self.radiance.direct, self.radiance.indirect);
                PathRadiance {
                    direct,
                    indirect,
                    rays: self.radiance.rays,
                    albedo: self.radiance.albedo,
                    // The RGB emission, as the G-buffer's emission plane (`FirstHit::emitted`).
                    emitted: self.radiance.emitted,
                }
            }
        }
    }

    /// Emitted radiance `rgb` (of `material`'s surface, or of the environment for `None`) at
    /// this path's wavelengths; `rgb` itself under RGB transport.
    #[inline]
    fn emitted(&self, rs: &RenderScene, rgb: Vec3, material: Option<usize>) -> Vec3 {
        match (&self.wl, material) {
            (None, _) => rgb,
            (Some(wl), Some(m)) => rs.spectral_emission(rgb, m, wl),
            (Some(wl), None) => lumo_spectrum::upsample::illuminant(rgb, wl),
        }
    }

    /// Takes the closest hit of the current ray (traced by the caller) and does everything up
    /// to the next ray: emission and MIS, light sampling, BSDF sampling, Russian roulette.
    /// Returns the shadow ray to test (if any; the caller passes unoccluded ones to
    /// [`PathState::add_unoccluded`]) and whether the path goes on with `origin`/`dir`.
    ///
    /// The work is split into the phases below for reading; they stay private. (Running each
    /// phase over a whole packet before the next measured 10 % slower on the Cornell box than
    /// whole bounces per path: the surface and BSDF records moved between phases cost more
    /// than the overlap of paths gained.)
    #[inline]
    pub fn advance(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        hit: Option<Hit>,
    ) -> (Option<ShadowRay>, bool) {
        let Some(at) = self.arrive(rs, settings, hit) else {
            return (None, false);
        };
        let u = self.draw();
        let light = self.sample_light(rs, settings, &at, &u);
        let shadow = self.connect(rs, settings, &at, light);
        let goes_on = self.scatter(rs, settings, &at, &u);
        (shadow, goes_on)
    }

    /// Phase 1 of [`PathState::advance`]: counts the ray; adds what a miss or the hit
    /// emitter contributes; records the first hit. Returns the shading point if the path may
    /// bounce again.
    #[inline]
    fn arrive(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        hit: Option<Hit>,
    ) -> Option<Arrival> {
        self.radiance.rays += 1;
        let (depth, dir) = (self.depth, self.dir);
        let Some(hit) = hit else {
            if depth == 1 {
                self.radiance.emitted = rs.lights.environment(dir);
            }
            if depth == 1 || settings.bsdf_emission || self.prev_pdf.is_none() {
                let le = rs.lights.environment(dir);
                if le != Vec3::ZERO {
                    let w = match self.prev_pdf {
                        Some(pdf) if settings.nee => {
                            power_heuristic(pdf, rs.lights.environment_pdf(dir))
                        }
                        _ => 1.0,
                    };
                    let le = self.emitted(rs, le, None);
                    self.radiance.add(depth, self.throughput * le * w);
                }
            }
            if std::mem::take(&mut self.want_first_hit) {
                self.first_hit = FirstHit {
                    depth: f32::INFINITY,
                    emitted: rs.lights.environment(dir),
                    ..Default::default()
                };
            }
            return None;
        };
        let s = rs.shading_surface(&hit, self.origin, dir);
        let bsdf = rs.bsdf(&s);
        let le = rs.emission(&s, dir);
        self.take_hit(rs, settings, &s, hit.t, &bsdf.bsdf, le);
        let bsdf = match &mut self.wl {
            None => bsdf,
            Some(wl) => {
                let b = rs.spectral_bsdf(bsdf, &s, wl);
                // Lanes a dispersive interface stopped carry nothing from here on.
                self.throughput *= wl.live_mask();
                b
            }
        };
        if depth >= settings.max_depth {
            return None;
        }
        let wo = s.frame.to_local(-dir);
        // A one-sided BSDF seen from behind reflects nothing: no light sample, no bounce.
        if wo.z <= 0.0 && rs.one_sided(s.material) {
            return None;
        }
        Some(Arrival { s, bsdf, wo })
    }

    /// What a hit contributes before the path bounces: the first-hit record if asked for, and
    /// the radiance `le` the surface emits towards the ray, MIS-weighted against light
    /// sampling. (Shared by [`PathState::arrive`] and the vector bounce.)
    #[inline(always)]
    pub(crate) fn take_hit(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        s: &Surface,
        t: f32,
        bsdf: &Bsdf,
        le: Vec3,
    ) {
        if self.depth == 1 {
            // The albedo plane: behind glass and mirrors, what they show (`specular_albedo`).
            self.radiance.albedo = if bsdf.is_delta() {
                let (a, rays) = specular_albedo::albedo_behind(rs, s, bsdf, self.dir);
                self.radiance.rays += rays;
                a
            } else {
                bsdf.albedo_towards(s.frame.to_local(-self.dir))
            };
            self.radiance.emitted = le;
        }
        if std::mem::take(&mut self.want_first_hit) {
            // Asked for by the camera ray only, so at its first hit.
            debug_assert_eq!(self.depth, 1);
            let n = s.frame.n;
            self.first_hit = FirstHit {
                normal: if n.dot(self.dir) > 0.0 { -n } else { n },
                position: s.p,
                depth: t,
                albedo: self.radiance.albedo,
                emitted: le,
            };
        }
        if le != Vec3::ZERO
            && (self.depth == 1 || settings.bsdf_emission || self.prev_pdf.is_none())
        {
            let w = match self.prev_pdf {
                Some(pdf) if settings.nee => power_heuristic(
                    pdf,
                    rs.lights
                        .triangle_pdf(s.instance, s.triangle, self.prev_point, s.p),
                ),
                _ => 1.0,
            };
            let le = self.emitted(rs, le, Some(s.material));
            self.radiance.add(self.depth, self.throughput * le * w);
        }
    }

    /// Phase 2: the bounce's random numbers, always all of them and in one order, so the
    /// sample stream does not depend on which branches a bounce takes.
    #[inline(always)]
    pub(crate) fn draw(&mut self) -> BounceNumbers {
        BounceNumbers {
            light: self.sampler.next_1d(),
            light_point: self.sampler.next_2d(),
            lobe: self.sampler.next_1d(),
            direction: self.sampler.next_2d(),
            roulette: self.sampler.next_1d(),
        }
    }

    /// Phase 3: a point on a light for next-event estimation (none for delta BSDFs).
    #[inline]
    fn sample_light(
        &self,
        rs: &RenderScene,
        settings: &PathSettings,
        at: &Arrival,
        u: &BounceNumbers,
    ) -> Option<LightSample> {
        if !settings.nee || at.bsdf.is_delta() {
            return None;
        }
        rs.lights.sample(at.s.p, u.light, u.light_point)
    }

    /// Phase 4: the shadow ray towards the light point, with the MIS-weighted contribution it
    /// carries.
    #[inline]
    fn connect(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        at: &Arrival,
        light: Option<LightSample>,
    ) -> Option<ShadowRay> {
        let ls = light?;
        let (s, bsdf, wo) = (&at.s, &at.bsdf, at.wo);
        let wi = s.frame.to_local(ls.wi);
        // Reject light from below the geometric surface unless the BSDF transmits.
        let f = bsdf.eval(wo, wi);
        if f == Vec3::ZERO {
            return None;
        }
        let o = rs.offset(s, ls.wi);
        let (dir, tmax) = if ls.distance.is_finite() {
            let (d, t) = shadow_segment(o.into(), ls.point.into(), ls.wi.into(), rs.ray_epsilon);
            (Vec3::from(d), t)
        } else {
            (ls.wi, f32::INFINITY)
        };
        self.radiance.rays += 1;
        let w = if ls.pdf > 0.0 && settings.bsdf_emission {
            power_heuristic(ls.pdf, bsdf.pdf(wo, wi))
        } else {
            1.0
        };
        let weight = match &self.wl {
            None => ls.weight,
            Some(wl) => rs.spectral_light(ls.weight, ls.light, wl),
        };
        Some(ShadowRay {
            origin: o,
            dir,
            tmax,
            contribution: self.throughput * f * weight * w,
            depth: self.depth + 1,
        })
    }

    /// Phase 5: continues the path by sampling the BSDF, with Russian roulette. Returns
    /// whether it goes on.
    #[inline]
    fn scatter(
        &mut self,
        rs: &RenderScene,
        settings: &PathSettings,
        at: &Arrival,
        u: &BounceNumbers,
    ) -> bool {
        let (s, wo, dir) = (&at.s, at.wo, self.dir);
        let Some(bs) = at.bsdf.sample(wo, u.lobe, u.direction) else {
            return false;
        };
        let new_dir = s.frame.to_world(bs.wi).normalize();
        // Shading normals can send a sample through the geometric surface; drop it.
        let reflect = bs.wi.z * wo.z > 0.0;
        if reflect != (new_dir.dot(s.ng) * (-dir).dot(s.ng) > 0.0) {
            return false;
        }
        self.throughput *= bs.weight;
        if bs.eta != 1.0 {
            self.eta_scale *= bs.eta * bs.eta;
        }
        // Straight through a mask, where shadow rays cross masks too: the emitter this path
        // may reach is weighed against the light sample of the vertex before the mask, so
        // that vertex's density and position stay (mask_shadow.rs).
        let crossed = at.bsdf.passes(u.lobe) && mask_shadow::applies(rs);
        if !crossed {
            self.prev_pdf = if bs.delta { None } else { Some(bs.pdf) };
            self.prev_point = s.p;
        }
        self.origin = rs.offset(s, new_dir);
        self.dir = new_dir;
        if self.depth >= settings.rr_depth {
            // Roulette on throughput without the 1/η² radiance scaling (as Mitsuba does), so
            // paths inside glass are not killed for a change of units.
            let q = survival_probability(self.throughput.max_element(), self.eta_scale);
            if u.roulette >= q {
                return false;
            }
            self.throughput /= q;
        }
        if self.throughput == Vec3::ZERO {
            return false;
        }
        self.depth += 1;
        true
    }

    /// Traces this path to its end one ray at a time.
    pub(crate) fn run(&mut self, rs: &RenderScene, settings: &PathSettings) {
        if rs.scene.media.is_active() {
            return self.run_volumetric(rs, settings);
        }
        loop {
            let hit = rs
                .accel
                .intersect(self.origin, self.dir, 0.0, f32::INFINITY);
            let (shadow, goes_on) = self.advance(rs, settings, hit);
            if let Some(sh) = shadow {
                if !rs.accel.occluded(sh.origin, sh.dir, 0.0, sh.tmax) {
                    self.add_unoccluded(&sh);
                } else if mask_shadow::applies(rs) {
                    mask_shadow::credit_blocked(rs, self, &sh, settings.max_depth);
                }
            }
            if !goes_on {
                break;
            }
        }
    }

    /// Adds the contribution of a shadow ray this path produced and nothing blocked.
    #[inline]
    pub fn add_unoccluded(&mut self, shadow: &ShadowRay) {
        self.radiance.add(shadow.depth, shadow.contribution);
    }

    /// Adds the contribution of a shadow ray this path produced, scaled by the transmittance
    /// `t` of what it crossed (masks).
    #[inline]
    pub(crate) fn add_shadow(&mut self, shadow: &ShadowRay, t: f32) {
        self.radiance.add(shadow.depth, shadow.contribution * t);
    }
}

/// [`trace_path`]'s estimate as CIE XYZ (what the progressive server streams) and its rays:
/// under spectral transport straight from the wavelengths, without passing through RGB.
pub fn trace_path_xyz(
    rs: &RenderScene,
    origin: Vec3,
    dir: Vec3,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
) -> (Vec3, u32) {
    let mut path = PathState::new(origin, dir, *sampler, false).spectral(settings.spectral);
    path.run(rs, settings);
    *sampler = path.sampler;
    let l = path.radiance.direct + path.radiance.indirect;
    let xyz = match &path.wl {
        Some(wl) => wl.to_xyz(l),
        None => lumo_spectrum::cie::SRGB_TO_XYZ * l,
    };
    (xyz, path.radiance.rays)
}

/// Traces one path starting with the ray `origin + t·dir` (unit `dir`), one ray at a time.
pub fn trace_path(
    rs: &RenderScene,
    origin: Vec3,
    dir: Vec3,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    first_hit: Option<&mut FirstHit>,
) -> PathRadiance {
    let mut path =
        PathState::new(origin, dir, *sampler, first_hit.is_some()).spectral(settings.spectral);
    path.run(rs, settings);
    *sampler = path.sampler;
    if let Some(fh) = first_hit {
        *fh = path.first_hit;
    }
    path.result()
}
