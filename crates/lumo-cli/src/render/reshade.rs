//! Re-shaded samples for the temporal filter's history rejection (A-SVGF's temporal
//! gradients, Schied et al. 2018): one surface point per 3×3 block of the previous frame is
//! traced again in this frame's scene with the random numbers it was traced with then. Where
//! nothing changed along the path the two luminances are the same; where a light, a shadow or a
//! material changed they differ by that change, not by noise (lumo-filter's `reshade.rs`).
//!
//! The point is carried with its instance's motion and re-traced from this frame's camera; it
//! counts only if that ray still reaches it (otherwise it was disoccluded or covered). On a
//! mesh that deforms (a skin, morph targets) no transform carries it: it is carried as its
//! triangle and barycentric coordinates and evaluated on this frame's deformed triangle
//! (`lumo_render::deformed_point`, which the motion vectors use in the other direction). With
//! the camera and the point's instance unchanged the ray is the previous frame's own pixel-centre
//! ray, bit for bit, so an unchanged scene gives exactly zero differences.

use glam::{Mat4, Vec2, Vec3};
use lumo_filter::{project_to_pixel, ShadingChange};
use lumo_image::{luminance, Image};
use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::path::wavefront::trace_paths;
use lumo_render::integrators::path::PathState;
use lumo_render::sampler::PixelSampler;
use lumo_render::{deformed_point, Frame, MeshPoses, PathSettings, PixelHit, RenderScene};
use rayon::prelude::*;

/// Side of the blocks of the previous frame that each give one re-shaded sample (A-SVGF: 3).
pub const BLOCK: usize = 3;

/// A first hit re-traced this far from where it was (relative to its distance) was covered or
/// uncovered by something else.
const SAME_POINT: f32 = 1e-2;

/// What re-shading needs of a traced frame, kept until the next frame.
pub struct ShadedFrame {
    /// The random-number seed the frame was traced with.
    pub seed: u32,
    /// First-hit positions (3 channels) and distances (1 channel, non-finite or ≤ 0 = miss).
    position: Image,
    depth: Image,
    /// Luminance of the traced colour (direct + indirect), or of its indirect light alone
    /// where the temporal filter splits the direct light off (`indirect_only`).
    luminance: Vec<f32>,
    indirect_only: Vec<bool>,
}

impl ShadedFrame {
    /// Keeps what re-shading `frame` (traced with `seed`, one sample per pixel) needs;
    /// `indirect_only` marks the pixels whose direct light the temporal filter takes apart
    /// (the direct-light split), where only the indirect light is compared.
    pub fn new(frame: &Frame, seed: u32, indirect_only: Option<&[bool]>) -> Self {
        Self::reusing(None, frame, seed, indirect_only)
    }

    /// [`Self::new`] written over `old`'s memory (an earlier frame's, no longer needed), so
    /// that a sequence allocates (and page-faults) nothing here per frame; the same values.
    pub fn reusing(
        old: Option<Self>,
        frame: &Frame,
        seed: u32,
        indirect_only: Option<&[bool]>,
    ) -> Self {
        let n = frame.color.width * frame.color.height;
        let mut s = old.unwrap_or_else(|| Self {
            seed,
            position: Image::new(0, 0, 3, 0.0),
            depth: Image::new(0, 0, 1, 0.0),
            luminance: Vec::new(),
            indirect_only: Vec::new(),
        });
        s.seed = seed;
        copy_image(&mut s.position, &frame.position);
        copy_image(&mut s.depth, &frame.depth);
        s.indirect_only.clear();
        match indirect_only {
            Some(v) => s.indirect_only.extend_from_slice(v),
            None => s.indirect_only.resize(n, false),
        }
        let only = &s.indirect_only;
        s.luminance.clear();
        s.luminance.extend((0..n).map(|i| {
            let plane = if only[i] {
                &frame.indirect
            } else {
                &frame.color
            };
            let c = &plane.data[i * 3..i * 3 + 3];
            luminance([c[0], c[1], c[2]])
        }));
        s
    }
}

/// `dst` made a copy of `src`, in `dst`'s memory when it is large enough.
fn copy_image(dst: &mut Image, src: &Image) {
    dst.width = src.width;
    dst.height = src.height;
    dst.channels = src.channels;
    dst.data.clear();
    dst.data.extend_from_slice(&src.data);
}

/// The camera and instance placement of a frame.
pub struct Pose<'a> {
    /// World → clip of the pinhole camera ([`lumo_filter::pinhole_view_projection`]).
    pub view_proj: Mat4,
    /// Instance transforms (object → world).
    pub transforms: &'a [Mat4],
    /// The instance under each pixel centre (`u32::MAX` = none), when instances move.
    pub ids: Option<&'a [u32]>,
    /// When meshes deform: the triangle and barycentrics under each pixel centre and the
    /// deforming meshes' vertex positions at this pose (only the earlier pose's are read).
    pub surface: Option<(&'a [PixelHit], &'a MeshPoses)>,
}

/// The pixel of block (`bx`, `by`) that is re-shaded: a hash of the block and the seed, so
/// the choice moves every frame and no pixel is favoured.
fn block_pixel(bx: usize, by: usize, seed: u32, w: usize, h: usize) -> (usize, usize) {
    let mut v =
        (bx as u32).wrapping_mul(0x9e37_79b9) ^ (by as u32).wrapping_mul(0x85eb_ca6b) ^ seed;
    v ^= v >> 16;
    v = v.wrapping_mul(0x7feb_352d);
    v ^= v >> 15;
    let k = (v % (BLOCK * BLOCK) as u32) as usize;
    (
        (bx * BLOCK + k % BLOCK).min(w - 1),
        (by * BLOCK + k / BLOCK).min(h - 1),
    )
}

/// Re-shades one point per 3×3 block of `before` (posed as `then`) in `rs` as it is now (posed
/// as `now`, camera `camera` at `w`×`h`), tracing with `path`. Returns the samples whose point
/// is still seen, each at the pixel it lies in now.
pub fn reshade(
    rs: &RenderScene,
    camera: &PinholeCamera,
    path: &PathSettings,
    before: &ShadedFrame,
    then: &Pose,
    now: &Pose,
) -> Vec<ShadingChange> {
    let (w, h) = (before.position.width, before.position.height);
    if w == 0 || h == 0 {
        return vec![];
    }
    let same_camera = then.view_proj == now.view_proj;
    // Per instance: world then → world now (identity when the instance list changed).
    let forward: Vec<Option<Mat4>> = if then.transforms.len() == now.transforms.len() {
        then.transforms
            .iter()
            .zip(now.transforms)
            .map(|(t, n)| (t != n).then(|| *n * t.inverse()))
            .collect()
    } else {
        vec![None; now.transforms.len()]
    };
    let (bw, bh) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
    // A row of blocks at a time: first the points still in view, then their paths together
    // through the wavefront renderer (sixteen rays per packet; each path the same bits as
    // traced alone), then the test that each path reached its point again.
    let rows: Vec<Vec<ShadingChange>> = (0..bh)
        .into_par_iter()
        .map(|by| {
            let mut pending = Vec::with_capacity(bw);
            let mut paths = Vec::with_capacity(bw);
            for bx in 0..bw {
                let (x, y) = block_pixel(bx, by, before.seed, w, h);
                let i = y * w + x;
                let d = before.depth.data[i * before.depth.channels];
                if !(d.is_finite() && d > 0.0) {
                    continue;
                }
                let q = &before.position.data[i * 3..i * 3 + 3];
                let p = Vec3::new(q[0], q[1], q[2]);
                // A point on a deforming mesh moves by its triangle point's step (which
                // includes its instance's motion); any other by its instance's transform.
                let deformed = then
                    .surface
                    .and_then(|(hits, poses)| deformed_point(&rs.scene, hits.get(i)?, poses));
                let (p_now, moved) = match deformed {
                    Some(d) => (p + (d.now - d.then), d.now != d.then),
                    None => {
                        let m = then
                            .ids
                            .and_then(|ids| forward.get(ids[i] as usize).copied().flatten());
                        (m.map_or(p, |m| m.transform_point3(p)), m.is_some())
                    }
                };
                let origin = camera.origin();
                // The previous frame's own ray where neither the camera nor the point
                // moved: the same path, bit for bit, when nothing else changed.
                let dir = if same_camera && !moved {
                    camera.direction(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                } else {
                    (p_now - origin).normalize()
                };
                let Some(pix) = project_to_pixel(&now.view_proj, p_now, w, h) else {
                    continue;
                };
                let (px, py) = (pix[0].floor(), pix[1].floor());
                if !(px >= 0.0 && py >= 0.0 && (px as usize) < w && (py as usize) < h) {
                    continue;
                }
                // The sampler as the camera sample left it (after its jitter draw).
                let mut sampler = PixelSampler::new(x as u32, y as u32, 0, before.seed);
                sampler.next_2d();
                paths.push(PathState::new(origin, dir, sampler, true).spectral(path.spectral));
                pending.push((i, p_now, py as usize * w + px as usize));
            }
            trace_paths(rs, path, &mut paths);
            let origin = camera.origin();
            pending
                .iter()
                .zip(&paths)
                .filter_map(|(&(i, p_now, pixel), traced)| {
                    let (r, hit) = (traced.result(), &traced.first_hit);
                    let dist = (p_now - origin).length();
                    if !(hit.depth.is_finite()
                        && (hit.position - p_now).length() <= SAME_POINT * dist)
                    {
                        return None;
                    }
                    Some(ShadingChange {
                        pixel,
                        now: if before.indirect_only[i] {
                            luminance(r.indirect.to_array())
                        } else {
                            luminance((r.direct + r.indirect).to_array())
                        },
                        before: before.luminance[i],
                    })
                })
                .collect()
        })
        .collect();
    rows.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_filter::pinhole_view_projection;
    use lumo_render::{render, RenderSettings};
    use lumo_scene::builtin_scene;

    /// A kept frame written over an older one (another size, another split mask) holds what
    /// a fresh one holds, bit for bit.
    #[test]
    fn a_reused_shaded_frame_equals_a_fresh_one() {
        let rs = RenderScene::new(builtin_scene("cornell").expect("scene")).expect("scene");
        let frame = |w, h, seed| {
            let s = RenderSettings {
                width: w,
                height: h,
                spp: 1,
                seed,
                path: PathSettings::default(),
            };
            render(&rs, &s, &|_| {}).0
        };
        let (a, b) = (frame(12, 10, 1), frame(16, 7, 2));
        let mask: Vec<bool> = (0..12 * 10).map(|i| i % 3 == 0).collect();
        let fresh = ShadedFrame::new(&a, 1, Some(&mask));
        let old = ShadedFrame::new(&b, 2, None);
        let reused = ShadedFrame::reusing(Some(old), &a, 1, Some(&mask));
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(reused.seed, fresh.seed);
        assert_eq!(reused.indirect_only, fresh.indirect_only);
        assert_eq!(bits(&reused.luminance), bits(&fresh.luminance));
        for (r, f) in [
            (&reused.position, &fresh.position),
            (&reused.depth, &fresh.depth),
        ] {
            assert_eq!(
                (r.width, r.height, r.channels),
                (f.width, f.height, f.channels)
            );
            assert_eq!(bits(&r.data), bits(&f.data));
        }
    }

    fn pose(rs: &RenderScene, w: usize, h: usize) -> (Mat4, Vec<Mat4>) {
        let c = &rs.scene.camera;
        let (hw, hh) = c.half_extent(w, h);
        (
            pinhole_view_projection(c.origin, c.target, c.up, [hw, hh]),
            rs.scene.instances.iter().map(|i| i.transform).collect(),
        )
    }

    /// A 1-spp frame of `rs` at w×h with `seed`, as the temporal loop keeps it for re-shading.
    fn shaded_frame(rs: &RenderScene, w: usize, h: usize, seed: u32) -> ShadedFrame {
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 1,
            seed,
            path: PathSettings::default(),
        };
        let (frame, _) = render(rs, &settings, &|_| {});
        ShadedFrame::new(&frame, seed, None)
    }

    /// Re-shading an unchanged scene repeats the previous frame's paths bit for bit; with every
    /// emitter twice as bright the same paths carry twice the light. Both fail if the re-traced
    /// path does not draw the random numbers the frame's sample drew.
    #[test]
    fn the_same_paths_are_traced_again() {
        let (w, h) = (24, 24);
        let scene = builtin_scene("cornell").expect("built-in scene");
        let rs = RenderScene::new(scene.clone()).expect("scene");
        let before = shaded_frame(&rs, w, h, 11);
        let (vp, transforms) = pose(&rs, w, h);
        let at = Pose {
            view_proj: vp,
            transforms: &transforms,
            ids: None,
            surface: None,
        };
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let same = reshade(&rs, &camera, &PathSettings::default(), &before, &at, &at);
        assert!(same.len() > w * h / 9 / 2, "{} samples", same.len());
        assert!(
            same.iter().all(|c| c.now == c.before),
            "unchanged scene, same values"
        );
        assert!(same.iter().any(|c| c.now > 0.0));

        let mut brighter = scene;
        for m in &mut brighter.materials {
            m.emission *= 2.0;
        }
        let rs2 = RenderScene::new(brighter).expect("scene");
        let doubled = reshade(&rs2, &camera, &PathSettings::default(), &before, &at, &at);
        assert_eq!(doubled.len(), same.len());
        for c in &doubled {
            assert!(
                (c.now - 2.0 * c.before).abs() <= 1e-4 * c.before.max(1.0),
                "{c:?}"
            );
        }
    }

    /// The large box's vertices moved (stretched upwards and shifted towards the camera; its instance's
    /// transform unchanged, as under a skin): carried by triangle and barycentrics, its points
    /// are found again about as often as in the unchanged scene, at the pixels they moved to;
    /// carried by the instance's transform alone (no triangles given, as before), most are lost.
    #[test]
    fn points_on_a_deformed_mesh_are_found_again() {
        let (w, h) = (64, 64);
        let mut rs = RenderScene::new(builtin_scene("cornell").expect("scene")).expect("scene");
        let mesh = rs.scene.meshes.len() - 1;
        let inst = rs
            .scene
            .instances
            .iter()
            .position(|i| i.mesh == mesh)
            .expect("the box's instance") as u32;
        let before = shaded_frame(&rs, w, h, 5);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let hits = lumo_render::pixel_hits(&rs, &camera, w, h);
        let poses = MeshPoses::capture(&rs.scene, &[mesh]);
        let (vp, transforms) = pose(&rs, w, h);
        let then = Pose {
            view_proj: vp,
            transforms: &transforms,
            ids: None,
            surface: Some((&hits, &poses)),
        };
        let rigid_then = Pose {
            surface: None,
            ..then
        };
        let now = Pose {
            surface: None,
            ..then
        };
        let on_box = |rs: &RenderScene, changes: &[ShadingChange]| {
            let now_hits = lumo_render::pixel_hits(rs, &camera, w, h);
            changes
                .iter()
                .filter(|c| now_hits[c.pixel].instance == inst)
                .count()
        };
        let unchanged = reshade(&rs, &camera, &PathSettings::default(), &before, &then, &now);
        let still = on_box(&rs, &unchanged);
        assert!(still > 10, "{still} samples on the box");

        let floor = rs.scene.bounds().0.y;
        // Towards the camera by 5 % of its distance, past the 1 % at which a ray to the old
        // place finds another point, and a little taller; mostly along the view, so that few
        // points cross the box's outline (where the pixel they land in shows something else).
        for p in &mut rs.scene.meshes[mesh].positions {
            p.y = floor + (p.y - floor) * 1.05;
            p.z += 0.2;
        }
        rs.update(&[mesh]).expect("refit");
        let followed = reshade(&rs, &camera, &PathSettings::default(), &before, &then, &now);
        let lost = reshade(
            &rs,
            &camera,
            &PathSettings::default(),
            &before,
            &rigid_then,
            &now,
        );
        let (followed, lost) = (on_box(&rs, &followed), on_box(&rs, &lost));
        assert!(
            followed * 10 >= still * 9,
            "{followed} of {still} points found again"
        );
        assert!(
            lost * 2 < still,
            "{lost} of {still} found without the triangles"
        );
    }
}
