//! Bidirectional path tracing (Veach 1997, ch. 10): for every camera sample a camera subpath
//! and a light subpath are traced, and every prefix pair (s light vertices, t camera
//! vertices) is joined into a complete path — the camera path reaching a light (s = 0),
//! next-event estimation (s = 1), a light vertex seen through the pinhole (t = 1, splatted
//! onto the film like the light tracer's connections) and a shadow ray between two scene
//! vertices. Multiple importance sampling with the power heuristic weighs the strategies
//! of each path ([`mis`]), computed with the ratio recursion over the vertices' forward and
//! reverse densities.
//!
//! Conventions shared with the path and light tracers: depth (`s + t − 1` segments) as in
//! Mitsuba, Russian roulette from `rr_depth` on both subpaths, the light tracer's adjoint
//! shading-normal correction and importance transport through refraction on the light
//! subpath. Light subpaths start from [`crate::lights::Lights::sample_emission`]; the
//! environment emits no particles, so paths that end there are weighed between s = 0 and
//! s = 1 only, exactly as the path tracer weighs them.
//!
//! Scenes with participating media or null boundaries take [`volume`]: medium vertices on
//! both subpaths and shadow segments that carry the media's transmittance.

mod connect;
mod diffuse_connect;
mod diffuse_nee;
mod diffuse_splat;
mod diffuse_walk;
mod lanes;
mod mis;
mod subpath;
#[cfg(test)]
mod tests;
mod vertex;
mod volume;

use glam::Vec2;

use crate::accel::packet::{RayPacket, LANES};
use crate::camera::PinholeCamera;
use crate::integrators::light::LightSplat;
use crate::integrators::path::{PathRadiance, PathSettings};
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;
use connect::{finish, prepare, Contribution, Pending, Prepared};
use diffuse_connect::{diffuse_joins, is_diffuse_join, DiffuseJoin};
use diffuse_nee::{diffuse_nees, NeeJob};
use diffuse_splat::{diffuse_splats, SplatJob};
use lanes::{is_lambertian, MIN_VECTOR_LANES};
use mis::{set_camera_ratios, set_light_ratios};
use subpath::{camera_start, light_start, random_walks};
use vertex::{Context, Vertex};

/// Bidirectional path tracing parameters.
#[derive(Clone, Copy, Debug, Default)]
pub struct BdptSettings {
    /// Depth limit, Russian roulette (`nee` and `bsdf_emission` are not used: every strategy
    /// runs).
    pub path: PathSettings,
    /// Run only strategy (s, t), unweighted: an estimator of the paths of depth `s + t − 1`
    /// on its own (for tests and pictures of single strategies).
    pub only: Option<(usize, usize)>,
}

/// Reused storage of one thread's samples: the subpaths' vertices and the strategies waiting
/// for their shadow rays.
#[derive(Default)]
pub struct BdptScratch {
    /// Subpaths of a group: sample `k`'s camera subpath at `k`, its light subpath at
    /// `GROUP + k` (one slice, so that both walks share packets).
    paths: Vec<Vec<Vertex>>,
    /// The group's strategies waiting for their shadow rays, sample by sample.
    pending: Vec<Pending>,
    /// Per entry of `pending`: its shadow ray is blocked, or it has nothing to add.
    blocked: Vec<bool>,
    /// The strategies among `pending` that join two Lambertian vertices, computed together
    /// in vector lanes once the group's strategies are listed.
    joins: Vec<DiffuseJoin>,
    /// The next-event strategies among `pending` from Lambertian vertices to emissive
    /// triangles, computed together in vector lanes likewise.
    nees: Vec<NeeJob>,
    /// The strategies among `pending` that show a Lambertian light vertex to the camera
    /// (t = 1), computed together in vector lanes likewise.
    splats: Vec<SplatJob>,
}

/// Most samples [`trace_bdpt_samples`] takes at once (one ray packet).
pub const GROUP: usize = LANES;
// A group's samplers are made in one `PixelSampler::run`.
const _: () = assert!(GROUP <= crate::sampler::RUN);

/// The sampler seed offset of light subpaths: camera sample `i` of pixel (x, y) draws its
/// light subpath from the same pixel and index under this seed, an independent sequence.
pub const LIGHT_SUBPATH_SEED: u32 = 0x6264_7074;

/// The two samplers of camera sample `index` of pixel (x, y): the camera subpath's and the
/// light subpath's.
pub fn samplers(x: u32, y: u32, index: u32, seed: u32) -> (PixelSampler, PixelSampler) {
    (
        PixelSampler::new(x, y, index, seed),
        PixelSampler::new(x, y, index, seed ^ LIGHT_SUBPATH_SEED),
    )
}

/// One bidirectional sample through film position `film` (pixels): returns the radiance of
/// the strategies that land in the sample's own pixel (split by depth like the path
/// tracer's) and calls `splat` for the light vertices seen by the camera (t = 1), which land
/// anywhere: a pixel's value is its samples' mean plus the splats in it divided by the total
/// number of samples (the light tracer's normalisation).
#[allow(clippy::too_many_arguments)]
pub fn trace_bdpt_sample(
    rs: &RenderScene,
    camera: &PinholeCamera,
    film: Vec2,
    camera_sampler: &mut PixelSampler,
    light_sampler: &mut PixelSampler,
    settings: &BdptSettings,
    scratch: &mut BdptScratch,
    splat: &mut impl FnMut(LightSplat),
) -> PathRadiance {
    let mut samplers = [(*camera_sampler, *light_sampler)];
    let mut out = [PathRadiance::default()];
    trace_bdpt_samples(
        rs,
        camera,
        &[film],
        &mut samplers,
        settings,
        scratch,
        &mut out,
        &mut |_, s| splat(s),
    );
    (*camera_sampler, *light_sampler) = samplers[0];
    out[0]
}

/// [`trace_bdpt_sample`] for up to [`GROUP`] samples at once, sample `k` through `films[k]`
/// with `samplers[k]` (camera, light) into `out[k]`; `splat` receives the sample's index.
/// The subpaths' rays of each step go through the BVH as one packet, whose hits are bit for
/// bit the single rays', and each sample's strategies then run as [`trace_bdpt_sample`]'s:
/// every sample gets exactly the values it gets alone, and the splats come sample by sample.
#[allow(clippy::too_many_arguments)]
pub fn trace_bdpt_samples(
    rs: &RenderScene,
    camera: &PinholeCamera,
    films: &[Vec2],
    samplers: &mut [(PixelSampler, PixelSampler)],
    settings: &BdptSettings,
    scratch: &mut BdptScratch,
    out: &mut [PathRadiance],
    splat: &mut impl FnMut(usize, LightSplat),
) {
    let n = films.len().min(GROUP).min(samplers.len()).min(out.len());
    let ctx = Context { rs, camera };
    if rs.scene.media.is_active() {
        // Media: each sample walks and joins on its own, through the media (volume.rs).
        volume::trace_samples(
            &ctx,
            &films[..n],
            &mut samplers[..n],
            settings,
            scratch,
            &mut out[..n],
            splat,
        );
        return;
    }
    let max_depth = settings.path.max_depth.max(1) as usize;
    scratch.paths.resize_with(2 * GROUP, Vec::new);
    let mut walks = [None; 2 * GROUP];
    let mut subpath_samplers = [PixelSampler::new(0, 0, 0, 0); 2 * GROUP];
    let mut max_vertices = [0usize; 2 * GROUP];
    // Both subpaths of every sample walk together, a packet of the next sixteen live walks
    // per step: the walks are independent (each its own sampler and vertices), so the order
    // of their steps changes nothing, while packets stay full until fewer than sixteen walks
    // are left (a packet costs sixteen lanes however few rays it holds).
    for k in 0..n {
        let (cam, light) = (k, GROUP + k);
        walks[cam] = camera_start(&ctx, films[k], max_depth + 1, &mut scratch.paths[cam]);
        subpath_samplers[cam] = samplers[k].0;
        max_vertices[cam] = max_depth + 1;
        walks[light] = light_start(
            &ctx,
            &mut samplers[k].1,
            max_depth,
            &mut scratch.paths[light],
        );
        subpath_samplers[light] = samplers[k].1;
        max_vertices[light] = max_depth;
    }
    let total_rays = random_walks(
        &ctx,
        &mut walks,
        &mut subpath_samplers,
        &settings.path,
        &max_vertices,
        &mut scratch.paths,
    );
    for k in 0..n {
        samplers[k] = (subpath_samplers[k], subpath_samplers[GROUP + k]);
        set_camera_ratios(&mut scratch.paths[k]);
        set_light_ratios(&mut scratch.paths[GROUP + k]);
    }
    // Every sample's strategies up to their shadow rays (the Lambertian ones as placeholders
    // that the lane loops then fill for the whole group), then all the group's shadow rays in
    // full packets, then each sample's visible strategies weighed and added in the order they
    // were listed (the order of tracing one sample alone).
    let (cams, lights) = scratch.paths.split_at(GROUP);
    scratch.pending.clear();
    scratch.joins.clear();
    scratch.nees.clear();
    scratch.splats.clear();
    let mut ends = [0usize; GROUP];
    for (k, o) in out[..n].iter_mut().enumerate() {
        *o = prepare_all(
            &ctx,
            (k, &lights[k], &cams[k]),
            n >= MIN_VECTOR_LANES,
            settings,
            &mut scratch.pending,
            (&mut scratch.joins, &mut scratch.nees, &mut scratch.splats),
        );
        ends[k] = scratch.pending.len();
    }
    diffuse_nees(&ctx, cams, &scratch.nees, &mut scratch.pending);
    diffuse_splats(&ctx, lights, &scratch.splats, &mut scratch.pending);
    diffuse_joins(
        rs.ray_epsilon,
        cams,
        lights,
        &scratch.joins,
        &mut scratch.pending,
    );
    // The group's shadow rays in full packets, skipping the placeholders the lane loops left
    // empty (`s = 0`: nothing to add); each sample counts its own.
    scratch.blocked.clear();
    scratch.blocked.resize(scratch.pending.len(), true);
    let mut rays = RayPacket::default();
    let mut lanes = [0usize; LANES];
    let mut filled = 0;
    let mut start = 0;
    for (k, o) in out[..n].iter_mut().enumerate() {
        for i in start..ends[k] {
            let p = &scratch.pending[i];
            if p.s == 0 {
                continue;
            }
            o.rays += 1;
            rays.set(filled, p.ray.origin, p.ray.dir, 0.0, p.ray.tmax);
            lanes[filled] = i;
            filled += 1;
            if filled == LANES {
                trace_shadows(rs, &rays, &lanes[..filled], &mut scratch.blocked);
                rays = RayPacket::default();
                filled = 0;
            }
        }
        start = ends[k];
    }
    if filled > 0 {
        trace_shadows(rs, &rays, &lanes[..filled], &mut scratch.blocked);
    }
    let unweighted = settings.only.is_some();
    let mut start = 0;
    for (k, o) in out[..n].iter_mut().enumerate() {
        for i in start..ends[k] {
            if scratch.blocked[i] {
                continue;
            }
            let p = &scratch.pending[i];
            let c = finish(&ctx, &lights[k], &cams[k], p, unweighted);
            add(o, p.s + p.t - 1, c, &mut |s| splat(k, s));
        }
        start = ends[k];
    }
    // The subpaths' rays, counted with the group's first sample.
    if n > 0 {
        out[0].rays += total_rays;
    }
}

/// Traces a packet of shadow rays, lane `l` the ray of pending strategy `lanes[l]`, and marks
/// in `blocked` whether each is occluded (entries not traced stay blocked).
#[inline]
fn trace_shadows(rs: &RenderScene, rays: &RayPacket, lanes: &[usize], blocked: &mut [bool]) {
    let occluded = rs.accel.occluded_packet(rays);
    for (lane, &i) in lanes.iter().enumerate() {
        blocked[i] = occluded & (1 << lane) != 0;
    }
}

/// Appends a placeholder to `pending` for a strategy a lane loop will fill, and returns its
/// slot.
#[inline]
fn reserve(pending: &mut Vec<Pending>) -> u32 {
    pending.push(Pending::placeholder());
    (pending.len() - 1) as u32
}

/// Adds one strategy's contribution: radiance to the sample, a splat through `splat`.
#[inline]
fn add(
    radiance: &mut PathRadiance,
    depth: usize,
    c: Contribution,
    splat: &mut impl FnMut(LightSplat),
) {
    match c {
        Contribution::Pixel(v) => radiance.add(depth as u32, v),
        Contribution::Splat(film, value) if value.is_finite() => splat(LightSplat { film, value }),
        Contribution::Splat(..) => {}
    }
}

/// Every strategy of sample `k`'s subpaths up to its shadow ray: returns the radiance of
/// those that need none (s = 0) and appends the others to `pending` in order, the joins of
/// two Lambertian vertices, the next-event strategies from Lambertian vertices to emissive
/// triangles and the Lambertian light vertices seen by the camera as placeholders listed in
/// `joins`, `nees` and `splats` ([`diffuse_joins`], [`diffuse_nees`] and [`diffuse_splats`]
/// fill them) when `lanes` (a group large enough for lane loops to pay).
fn prepare_all(
    ctx: &Context,
    (k, light, cam): (usize, &[Vertex], &[Vertex]),
    lanes: bool,
    settings: &BdptSettings,
    pending: &mut Vec<Pending>,
    (joins, nees, splats): (&mut Vec<DiffuseJoin>, &mut Vec<NeeJob>, &mut Vec<SplatJob>),
) -> PathRadiance {
    let max_depth = settings.path.max_depth.max(1) as usize;
    let mut radiance = PathRadiance::default();
    let unweighted = settings.only.is_some();
    for t in 1..=cam.len() {
        // Only the strategies that exist: s + t ≥ 2 and depth s + t − 1 ≤ `max_depth`.
        let s_last = light.len().max(1).min((max_depth + 1).saturating_sub(t));
        for s in usize::from(t < 2)..=s_last {
            let depth = s + t - 1;
            if settings.only.is_some_and(|only| only != (s, t)) {
                continue;
            }
            // s = 1 with t ≥ 2 samples its own light point (next-event estimation).
            if s > light.len() && !(s == 1 && t >= 2) {
                continue;
            }
            if lanes && t == 1 && s >= 2 && is_lambertian(&light[s - 1]) {
                // Off the film: nothing, as `prepare` decides first.
                if let Some((film, cos_cam)) = ctx.camera.project_point(light[s - 1].p) {
                    splats.push(SplatJob {
                        slot: reserve(pending),
                        k: k as u32,
                        s: s as u32,
                        film,
                        cos_cam,
                    });
                }
                continue;
            }
            if lanes && s == 1 && t >= 2 && is_lambertian(&cam[t - 1]) {
                let pt = &cam[t - 1];
                // Points behind the triangle's plane take the scalar strategy, which ends at
                // the light sample's back-facing test before any other work (the test here
                // only routes: either way the result is the scalar one).
                let chosen = ctx.rs.lights.choose_triangle(pt.u_light.0);
                if let Some((pick, _, light)) =
                    chosen.filter(|(_, tri, _)| tri.normal.dot(pt.p - tri.p0) > 0.0)
                {
                    nees.push(NeeJob {
                        slot: reserve(pending),
                        k: k as u32,
                        t: t as u32,
                        light,
                        pick,
                    });
                    continue;
                }
            }
            if lanes && s >= 2 && t >= 2 && is_diffuse_join(&cam[t - 1], &light[s - 1]) {
                joins.push(DiffuseJoin {
                    slot: reserve(pending),
                    k: k as u32,
                    s: s as u32,
                    t: t as u32,
                });
                continue;
            }
            match prepare(ctx, light, cam, (s, t), unweighted) {
                Prepared::Nothing => {}
                Prepared::Done(c) => add(&mut radiance, depth, c, &mut |_| {}),
                Prepared::Pending(p) => pending.push(p),
            }
        }
    }
    radiance
}
