//! Particle tracing (a light tracer): paths start on the lights, scatter through the scene
//! with the same BSDFs and sampler as the path tracer, and every vertex is connected to the
//! pinhole camera. Each connection lands somewhere on the film as a *splat*; the image is a
//! density estimate, `pixel = Σ splats in the pixel / number of light paths`.
//!
//! The estimator uses the path tracer's shading-normal convention (Veach's adjoint
//! correction: on arrival `|ns·wl| / |ng·wl|`, on departure `|ng·w| / |ns·w|`), so on any
//! scene both integrators converge to the same image. Paths start from the scene's shared
//! lights ([`crate::lights::Lights::sample_emission`]), which do not emit from environment and
//! constant lights; those stay the path tracer's job.
//!
//! In scenes with participating media a particle starts in the medium around its light (as a
//! camera path would find it there), samples free flights in it as the volumetric path tracer
//! does (the same lane MIS for chromatic media), scatters by the phase function at medium
//! vertices and crosses null boundaries without a vertex; each connection to the camera
//! carries the transmittance of the media and null boundaries on the way (docs/media.md).

use glam::{Vec2, Vec3};

use lumo_scene::Boundary;
use lumo_spectrum::Wavelengths;

use crate::accel::Hit;
use crate::bsdf::{BsdfSample, TransportMode};
use crate::camera::PinholeCamera;
use crate::geometry::{offset_point, shadow_segment, survival_probability};
use crate::integrators::path::PathSettings;
use crate::lights::EmissionSample;
use crate::media::walk::{medium_at, mesh_of, target, transmittance, LaneMis, MAX_CROSSINGS};
use crate::media::{free_flight, phase, Coefficients, Flight};
use crate::render_scene::RenderScene;
use crate::render_scene::Surface;
use crate::sampler::PixelSampler;
use crate::shading::ShadingBsdf;

/// One connection of a light-path vertex to the camera.
#[derive(Clone, Copy, Debug)]
pub struct LightSplat {
    /// Film position in pixels (x right, y down).
    pub film: Vec2,
    /// Contribution in radiance units: a pixel's value is the sum of the splats that land in
    /// it divided by the number of light paths traced.
    pub value: Vec3,
}

/// What one light path did.
#[derive(Clone, Copy, Debug, Default)]
pub struct LightPathStats {
    /// Rays traced (closest-hit and shadow).
    pub rays: u32,
    /// Splats produced.
    pub splats: u32,
}

/// How a connection's shadow ray sees the scene in a scene with media: the medium it starts
/// in, the path's wavelengths and its sampler (for ratio tracking).
type Sight<'a> = (Option<usize>, Option<&'a Wavelengths>, &'a mut PixelSampler);

/// Radiance reaching the eye from `p`, already multiplied by the camera's importance, if `p`
/// is visible and on the film. `value` turns the direction to the camera into the vertex's
/// scattered (or emitted) value before the geometric term; `ng` is a surface vertex's normal
/// (`None` at a medium vertex, which has no cosine). Without `media` the line of sight must be
/// clear; with it, it carries the transmittance of media and null boundaries.
fn connect(
    rs: &RenderScene,
    camera: &PinholeCamera,
    p: Vec3,
    ng: Option<Vec3>,
    origin_off: impl Fn(Vec3) -> Vec3,
    value: impl Fn(Vec3) -> Vec3,
    media: Option<Sight>,
) -> Option<(LightSplat, u32)> {
    let (film, cos_cam) = camera.project_point(p)?;
    let to_cam = camera.origin() - p;
    let dist2 = to_cam.length_squared();
    let wc = to_cam / dist2.sqrt();
    let v = value(wc);
    if v == Vec3::ZERO {
        return None;
    }
    let o = origin_off(wc);
    let (dir, tmax) = shadow_segment(o.into(), camera.origin().into(), wc.into(), rs.ray_epsilon);
    let mut rays = 1;
    let tr = match media {
        None => {
            if rs.accel.occluded(o, dir.into(), 0.0, tmax) {
                Vec3::ZERO
            } else {
                Vec3::ONE
            }
        }
        Some((medium, wl, sampler)) => {
            transmittance(rs, medium, o, dir.into(), tmax, wl, sampler, &mut rays)
        }
    };
    if tr == Vec3::ZERO {
        return Some((
            LightSplat {
                film,
                value: Vec3::ZERO,
            },
            rays,
        ));
    }
    // G(c, x)·We: |cos_x| |cos_c| / d² · pixels / (A cos⁴θ_c).
    let cos_x = ng.map_or(1.0, |n| n.dot(wc).abs());
    let importance = cos_x * camera.pixel_importance() / (dist2 * cos_cam.powi(3));
    let value = v * tr * importance;
    value
        .is_finite()
        .then_some((LightSplat { film, value }, rays))
}

/// A particle's next direction at surface `s`, arriving from `wl` (world; `wl_local` in the
/// shading frame): the BSDF sampled in importance mode, the sample dropped where shading
/// normals would send it through the geometric surface. Returns the direction, the sample
/// and its weight with the departure half of Veach's adjoint shading-normal correction
/// (`|ng·wo| / |ns·wo|`); the arrival half is the caller's. Shared by every integrator that
/// traces light paths (light tracer, photons, bidirectional light subpaths).
pub(crate) fn scatter_particle(
    bsdf: &ShadingBsdf,
    s: &Surface,
    wl: Vec3,
    wl_local: Vec3,
    u_lobe: f32,
    u_bsdf: Vec2,
) -> Option<(Vec3, BsdfSample, Vec3)> {
    let bs = bsdf.sample_mode(TransportMode::Importance, wl_local, u_lobe, u_bsdf)?;
    particle_direction(bs, s, wl, wl_local)
}

/// The second half of [`scatter_particle`] for a sample `bs` already drawn in importance
/// mode (BDPT draws a Lambertian one without the BSDF dispatch): the world direction, the
/// sample and the weight with the departure half of the shading-normal correction.
#[inline(always)]
pub(crate) fn particle_direction(
    bs: BsdfSample,
    s: &Surface,
    wl: Vec3,
    wl_local: Vec3,
) -> Option<(Vec3, BsdfSample, Vec3)> {
    let new_dir = s.frame.to_world(bs.wi).normalize();
    let reflect = bs.wi.z * wl_local.z > 0.0;
    if reflect != (new_dir.dot(s.ng) * wl.dot(s.ng) > 0.0) {
        return None;
    }
    let cos_ns_o = s.frame.n.dot(new_dir).abs();
    if cos_ns_o <= 0.0 {
        return None;
    }
    Some((
        new_dir,
        bs,
        bs.weight * (s.ng.dot(new_dir).abs() / cos_ns_o),
    ))
}

/// What every vertex of one light path reads.
struct Tracer<'a> {
    rs: &'a RenderScene,
    camera: &'a PinholeCamera,
    settings: &'a PathSettings,
    /// The scene has participating media.
    vol: bool,
}

/// A light path between two vertices.
struct Particle {
    origin: Vec3,
    dir: Vec3,
    throughput: Vec3,
    /// The medium the ray starts in (scenes with media).
    medium: Option<usize>,
    /// Russian roulette at medium vertices compares the throughput with the particle's start
    /// (it is in power units): an albedo-1 medium keeps its particles, as in the path tracer.
    start: f32,
    /// Null boundaries crossed since the last vertex.
    crossings: u32,
    /// Depth of the path camera ← x_k ← … ← light when connecting at the k-th scene vertex.
    depth: u32,
    /// Until the first vertex, for a light with a range: the light's position and range,
    /// whose window of the first segment's length weighs the particle from that vertex on.
    range: Option<(Vec3, f32)>,
}

impl Particle {
    /// The particle reaches a vertex at `p` (surface or medium): the first one applies the
    /// light's range window to the throughput (null boundaries crossed on the way are not
    /// vertices, so the distance is the light's to `p`).
    #[inline(always)]
    fn arrive(&mut self, p: Vec3) {
        if let Some((light, range)) = self.range.take() {
            self.throughput *= lumo_scene::range_window(light.distance(p), range);
        }
    }
}

/// Where a light path goes after a step.
enum Next {
    /// On from the particle's new ray.
    Continue,
    /// The path ends.
    Stop,
    /// No medium vertex: on to the surface the ray hit.
    Surface,
}

/// The splats of one light path and its counters.
struct Splats<'a, F> {
    splat: &'a mut F,
    stats: LightPathStats,
}

impl<F: FnMut(LightSplat)> Splats<'_, F> {
    /// Counts a connection and passes on its splat, if it carries light. The wavelengths a
    /// splat is converted with are those of the path when it is made (a dispersive vertex
    /// stops the secondary lanes for every splat after it).
    #[inline(always)]
    fn emit(&mut self, s: Option<(LightSplat, u32)>, lambdas: &Option<Wavelengths>) {
        if let Some((mut sp, rays)) = s {
            self.stats.rays += rays;
            if let Some(w) = lambdas {
                sp.value = w.to_rgb(sp.value);
            }
            if sp.value != Vec3::ZERO {
                self.stats.splats += 1;
                (self.splat)(sp);
            }
        }
    }
}

/// Traces one light path with the numbers of `sampler`, calling `splat` for every vertex that
/// sees the camera (including the point on the light itself).
pub fn trace_light_path(
    rs: &RenderScene,
    camera: &PinholeCamera,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    splat: &mut impl FnMut(LightSplat),
) -> LightPathStats {
    let mut out = Splats {
        splat,
        stats: LightPathStats::default(),
    };
    let u_choice = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(mut e) = rs.lights.sample_emission(u_choice, u_pos, u_dir) else {
        return out.stats;
    };
    // Under spectral transport the particle carries three wavelengths (drawn after the
    // emission numbers, so RGB paths keep their sample stream) and every splat is its XYZ
    // estimate, written as linear sRGB.
    let mut lambdas = settings
        .spectral
        .then(|| Wavelengths::sample(sampler.next_1d()));
    if let Some(w) = &lambdas {
        e.radiance = rs.spectral_light(e.radiance, e.light, w);
        e.weight = rs.spectral_light(e.weight, e.light, w);
    }
    // Media: the particle starts in the medium around its light, and a lane of the path
    // samples chromatic media (drawn after the wavelengths; scenes without media keep their
    // sample stream).
    let t = Tracer {
        rs,
        camera,
        settings,
        vol: rs.scene.media.is_active(),
    };
    let mut lanes = t.vol.then(|| LaneMis::new(sampler.next_1d()));
    let mut pt = leave_light(&t, sampler, &e, &lambdas, &mut out);
    loop {
        let th = pt.throughput;
        if pt.depth > settings.max_depth || th == Vec3::ZERO || !th.is_finite() {
            break;
        }
        out.stats.rays += 1;
        let hit = rs.accel.intersect(pt.origin, pt.dir, 0.0, f32::INFINITY);
        if let (Some(m), Some(lanes)) = (pt.medium, lanes.as_mut()) {
            let tmax = hit.map_or(f32::INFINITY, |h| h.t);
            match medium_vertex(&t, sampler, &mut pt, (m, lanes, tmax), &lambdas, &mut out) {
                Next::Continue => continue,
                Next::Stop => break,
                Next::Surface => {}
            }
        }
        let Some(hit) = hit else {
            break;
        };
        let boundary = if t.vol {
            rs.scene.media.boundary(mesh_of(rs, &hit))
        } else {
            Default::default()
        };
        if boundary.null {
            // An invisible boundary: no vertex, only a change of medium.
            pt.crossings += 1;
            if pt.crossings > MAX_CROSSINGS {
                break;
            }
            let s = rs.surface(&hit, pt.origin, pt.dir);
            if let Some(f) = boundary.interface {
                pt.medium = target(f, s.ng, pt.dir);
            }
            pt.origin = rs.offset(&s, pt.dir);
            continue;
        }
        match surface_vertex(
            &t,
            sampler,
            &mut pt,
            (&hit, boundary),
            &mut lambdas,
            &mut out,
        ) {
            Next::Continue => {}
            Next::Stop | Next::Surface => break,
        }
    }
    out.stats
}

/// The particle leaving its light: its first ray, the medium around the light, and the
/// light itself seen by the camera (depth 1).
#[inline(always)]
fn leave_light<F: FnMut(LightSplat)>(
    t: &Tracer,
    sampler: &mut PixelSampler,
    e: &EmissionSample,
    lambdas: &Option<Wavelengths>,
    out: &mut Splats<'_, F>,
) -> Particle {
    let rs = t.rs;
    let origin = match e.normal {
        Some(normal) => {
            offset_point(e.p.into(), normal.into(), e.dir.into(), rs.ray_epsilon).into()
        }
        None => e.p,
    };
    let medium = if t.vol {
        medium_at(rs, t.camera.origin(), origin, &mut out.stats.rays)
    } else {
        None
    };
    if let Some(normal) = e.normal {
        let p = e.p;
        let off = |d: Vec3| offset_point(p.into(), normal.into(), d.into(), rs.ray_epsilon).into();
        let sight = t.vol.then_some((medium, lambdas.as_ref(), &mut *sampler));
        let seen = connect(
            rs,
            t.camera,
            p,
            Some(normal),
            off,
            |wc| {
                if normal.dot(wc) > 0.0 {
                    e.radiance / e.pdf.area
                } else {
                    Vec3::ZERO
                }
            },
            sight,
        );
        out.emit(seen, lambdas);
    }
    Particle {
        origin,
        dir: e.dir,
        throughput: e.weight,
        medium,
        start: e.weight.max_element(),
        crossings: 0,
        depth: 2,
        range: rs.lights.range(e.light).map(|r| (e.p, r)),
    }
}

/// A free flight through the particle's medium `m` (up to `tmax`, the surface hit) with the
/// path's lane MIS; where it scatters, a medium vertex: connected to the camera through the
/// media, then a phase sample (exact, weight 1) and Russian roulette.
#[inline(always)]
fn medium_vertex<F: FnMut(LightSplat)>(
    t: &Tracer,
    sampler: &mut PixelSampler,
    pt: &mut Particle,
    (m, lanes, tmax): (usize, &mut LaneMis, f32),
    lambdas: &Option<Wavelengths>,
    out: &mut Splats<'_, F>,
) -> Next {
    let med = &t.rs.scene.media.media[m];
    let c = Coefficients::of(med, lambdas.as_ref());
    let (origin, dir) = (pt.origin, pt.dir);
    let flight = free_flight(
        med,
        &c,
        origin,
        dir,
        tmax,
        lanes.lane,
        pt.throughput,
        sampler,
    );
    lanes.apply(&mut pt.throughput, &flight);
    let Flight::Scatter { t: at, .. } = flight else {
        return if pt.throughput == Vec3::ZERO {
            Next::Stop
        } else {
            Next::Surface
        };
    };
    let p = origin + dir * at;
    pt.arrive(p);
    let sight = Some((pt.medium, lambdas.as_ref(), &mut *sampler));
    let throughput = pt.throughput;
    let f = |wc: Vec3| throughput * phase::eval(med.phase, dir, wc);
    let seen = connect(t.rs, t.camera, p, None, |_| p, f, sight);
    out.emit(seen, lambdas);
    if pt.depth >= t.settings.max_depth {
        return Next::Stop;
    }
    let u_dir = sampler.next_2d();
    let u_rr = sampler.next_1d();
    let (wi, pdf) = phase::sample(med.phase, dir, u_dir);
    if pdf.is_nan() || pdf <= 0.0 {
        return Next::Stop;
    }
    pt.origin = p;
    pt.dir = wi;
    if pt.depth >= t.settings.rr_depth && pt.start > 0.0 {
        let q = (pt.throughput.max_element() / pt.start).min(1.0);
        if u_rr >= q {
            return Next::Stop;
        }
        pt.throughput /= q;
    }
    pt.depth += 1;
    pt.crossings = 0;
    Next::Continue
}

/// A surface vertex at `hit` (not a null boundary): the arrival half of the adjoint
/// shading-normal correction, the connection to the camera (unless the BSDF is a delta),
/// then the BSDF sampled in importance mode and Russian roulette.
#[inline(always)]
fn surface_vertex<F: FnMut(LightSplat)>(
    t: &Tracer,
    sampler: &mut PixelSampler,
    pt: &mut Particle,
    (hit, boundary): (&Hit, Boundary),
    lambdas: &mut Option<Wavelengths>,
    out: &mut Splats<'_, F>,
) -> Next {
    let (rs, settings) = (t.rs, t.settings);
    let s = rs.surface(hit, pt.origin, pt.dir);
    pt.arrive(s.p);
    if pt.throughput == Vec3::ZERO {
        // Beyond its light's range.
        return Next::Stop;
    }
    let mut bsdf = rs.bsdf(&s);
    if let Some(w) = lambdas {
        bsdf = rs.spectral_bsdf(bsdf, &s, w);
        pt.throughput *= w.live_mask();
    }
    let wl = -pt.dir;
    let (ns, ng) = (s.frame.n, s.ng);
    let (cos_ns_l, cos_ng_l) = (ns.dot(wl).abs(), ng.dot(wl).abs());
    if cos_ng_l <= 0.0 || cos_ns_l <= 0.0 {
        return Next::Stop;
    }
    // Arrival half of the adjoint shading-normal correction.
    pt.throughput *= cos_ns_l / cos_ng_l;
    let wl_local = s.frame.to_local(wl);
    // A one-sided BSDF lit from behind is black both ways (Mitsuba checks both directions
    // against the front side): no connection, no continuation — as the path tracer ends
    // a camera path at its back.
    if wl_local.z <= 0.0 && rs.one_sided(s.material) {
        return Next::Stop;
    }
    if !bsdf.is_delta() {
        let off = |d: Vec3| rs.offset(&s, d);
        // The shadow ray leaves into the medium on the camera's side of the surface.
        let sight = t.vol.then(|| {
            let to_cam = t.camera.origin() - s.p;
            let from = match boundary.interface {
                Some(f) => target(f, ng, to_cam),
                None => pt.medium,
            };
            (from, lambdas.as_ref(), &mut *sampler)
        });
        let throughput = pt.throughput;
        let f = |wc: Vec3| {
            // f without its cosine: eval includes |cos θi| of the light side.
            let f = bsdf.eval(s.frame.to_local(wc), wl_local) / wl_local.z.abs();
            throughput * f
        };
        let seen = connect(rs, t.camera, s.p, Some(ng), off, f, sight);
        out.emit(seen, lambdas);
    }
    if pt.depth >= settings.max_depth {
        return Next::Stop;
    }
    let u_lobe = sampler.next_1d();
    let u_bsdf = sampler.next_2d();
    let u_rr = sampler.next_1d();
    // Sampling "wi" with the light side as "wo" picks the particle's next direction; the
    // BSDFs are reciprocal except for refraction's radiance scaling, which importance
    // does not carry.
    let Some((new_dir, _, weight)) = scatter_particle(&bsdf, &s, wl, wl_local, u_lobe, u_bsdf)
    else {
        return Next::Stop;
    };
    pt.throughput *= weight;
    pt.origin = rs.offset(&s, new_dir);
    pt.dir = new_dir;
    if let Some(f) = boundary.interface {
        pt.medium = target(f, ng, new_dir);
    }
    pt.crossings = 0;
    if pt.depth >= settings.rr_depth {
        let q = survival_probability(pt.throughput.max_element(), 1.0);
        if u_rr >= q {
            return Next::Stop;
        }
        pt.throughput /= q;
    }
    pt.depth += 1;
    Next::Continue
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{render, RenderSettings};
    use lumo_image::luminance;
    use lumo_scene::builtin_scene;

    /// Light-traces `paths` paths into a `w`×`h` image (pixel = Σ splats / paths).
    fn light_image(
        rs: &RenderScene,
        w: usize,
        h: usize,
        paths: u32,
        settings: &PathSettings,
    ) -> Vec<Vec3> {
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let mut img = vec![Vec3::ZERO; w * h];
        for i in 0..paths {
            let mut sampler = PixelSampler::new(i >> 16, 7, i & 0xffff, 3);
            trace_light_path(rs, &camera, &mut sampler, settings, &mut |s| {
                let (x, y) = (s.film.x as usize, s.film.y as usize);
                if x < w && y < h {
                    img[y * w + x] += s.value;
                }
            });
        }
        img.iter().map(|v| *v / paths as f32).collect()
    }

    /// Mean over `b`×`b` blocks, to compare images at a scale where noise is small.
    fn blocks(img: &[Vec3], w: usize, h: usize, b: usize) -> Vec<f32> {
        let mut out = vec![0.0; (w / b) * (h / b)];
        for y in 0..h {
            for x in 0..w {
                out[(y / b) * (w / b) + x / b] += luminance(img[y * w + x].into()) / (b * b) as f32;
            }
        }
        out
    }

    #[test]
    fn cornell_matches_the_path_tracer() {
        let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
        let (w, h) = (32, 32);
        let path = PathSettings {
            max_depth: 4,
            ..Default::default()
        };
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 256,
            seed: 1,
            path,
        };
        let (frame, _) = render(&rs, &settings, &|_| {});
        let pt: Vec<Vec3> = (0..w * h)
            .map(|i| Vec3::from(frame.color.rgb(i % w, i / w)))
            .collect();
        let lt = light_image(&rs, w, h, 400_000, &path);
        let (a, b) = (blocks(&pt, w, h, 8), blocks(&lt, w, h, 8));
        let mean_a = a.iter().sum::<f32>() / a.len() as f32;
        let mean_b = b.iter().sum::<f32>() / b.len() as f32;
        assert!(
            (mean_a - mean_b).abs() < 0.03 * mean_a,
            "image means differ: path {mean_a}, light {mean_b}"
        );
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(
                (x - y).abs() < 0.12 * x.max(0.05),
                "block {i}: path {x}, light {y}"
            );
        }
    }

    #[test]
    fn splats_stay_on_the_film_and_empty_scenes_emit_nothing() {
        let rs = RenderScene::new(builtin_scene("cornell").expect("builtin")).expect("scene");
        assert!(!rs.lights.emits_no_particles());
        let camera = PinholeCamera::new(&rs.scene.camera, 20, 10);
        let mut n = 0;
        for i in 0..2000 {
            let mut sampler = PixelSampler::new(0, 0, i, 0);
            let st = trace_light_path(
                &rs,
                &camera,
                &mut sampler,
                &PathSettings::default(),
                &mut |s| {
                    assert!(s.film.x >= 0.0 && s.film.x < 20.0);
                    assert!(s.film.y >= 0.0 && s.film.y < 10.0);
                    assert!(s.value.min_element() >= 0.0 && s.value.is_finite());
                    n += 1;
                },
            );
            assert!(st.splats <= st.rays);
        }
        assert!(n > 500, "only {n} splats from 2000 paths");
        let mut dark = builtin_scene("cornell").expect("builtin");
        for m in &mut dark.materials {
            m.emission = Vec3::ZERO;
        }
        let dark = RenderScene::new(dark).expect("scene");
        assert!(dark.lights.emits_no_particles());
    }
}
