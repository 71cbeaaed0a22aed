//! The first hit of every pixel centre's camera ray, traced once per frame sixteen rays at a
//! time: the temporal filter's passes that need it (the direct-light split, the instance ids
//! of the motion vectors, the deforming meshes' triangles) share one set instead of each
//! tracing its own rays.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::accel::packet::{RayPacket, LANES};
use crate::accel::Hit;
use crate::camera::PinholeCamera;
use crate::render_scene::RenderScene;

/// The ray through the centre of pixel (x, y) and the lens centre (origin, unit direction):
/// the G-buffer's ray, which a one-sample frame's path starts with.
pub fn pixel_centre_ray(camera: &PinholeCamera, x: usize, y: usize) -> (Vec3, Vec3) {
    camera.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), Vec2::splat(0.5))
}

/// The first hit of each pixel's [`pixel_centre_ray`] of a `width`×`height` image, row-major
/// (`None` where the ray escapes).
pub fn camera_hits(
    rs: &RenderScene,
    camera: &PinholeCamera,
    width: usize,
    height: usize,
) -> Vec<Option<Hit>> {
    let mut out = Vec::new();
    camera_hits_into(&mut out, rs, camera, width, height);
    out
}

/// [`camera_hits`] written into `out` (resized; its memory reused from frame to frame). Rows
/// in parallel, sixteen rays per packet; the packet traversal finds the hits one ray at a
/// time would (`accel`'s tests), so the result is the same on any number of threads.
pub fn camera_hits_into(
    out: &mut Vec<Option<Hit>>,
    rs: &RenderScene,
    camera: &PinholeCamera,
    width: usize,
    height: usize,
) {
    out.clear();
    out.resize(width * height, None);
    if width == 0 {
        return;
    }
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (k, chunk) in row.chunks_mut(LANES).enumerate() {
            let mut rays = RayPacket::default();
            for lane in 0..chunk.len() {
                let (origin, dir) = pixel_centre_ray(camera, k * LANES + lane, y);
                rays.set(lane, origin, dir, 0.0, f32::INFINITY);
            }
            let mut hits = [None; LANES];
            rs.accel.intersect_packet(&rays, &mut hits);
            chunk.copy_from_slice(&hits[..chunk.len()]);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::builtin_scene;

    /// Bit for bit the hits of the same rays traced one at a time, at a width that leaves a
    /// partly filled packet at each row's end.
    #[test]
    fn packet_hits_equal_one_ray_at_a_time() {
        let rs = RenderScene::new(builtin_scene("cornell-spheres").expect("scene")).expect("rs");
        let (w, h) = (37, 21);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let hits = camera_hits(&rs, &camera, w, h);
        assert_eq!(hits.len(), w * h);
        let mut seen = 0;
        for y in 0..h {
            for x in 0..w {
                let (o, d) = pixel_centre_ray(&camera, x, y);
                let one = rs.accel.intersect(o, d, 0.0, f32::INFINITY);
                assert_eq!(
                    Hit::bits(hits[y * w + x]),
                    Hit::bits(one),
                    "pixel ({x}, {y})"
                );
                seen += usize::from(one.is_some());
            }
        }
        assert!(seen > w * h / 2, "{seen} hits");
    }
}
