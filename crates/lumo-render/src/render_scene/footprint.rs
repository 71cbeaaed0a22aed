//! How wide a texture lookup is at a hit, for mip-mapped textures: the camera's footprint
//! of one sample at the hit's distance, laid onto the surface and measured in uv units.
//!
//! Every hit is treated as if the camera saw it directly (pbrt-v4's approximation of ray
//! differentials for any ray): a point reached by reflection or after a diffuse bounce has a
//! wider footprint in truth, so the estimate can only under-blur there, never blur detail a
//! direct view would keep. The width of one sample is the pixel's divided by √spp (at least
//! an eighth of it, as pbrt-v4 scales its ray differentials): the pixel's samples already
//! average its area, so each needs to average only its own share.

use lumo_scene::{BsdfSpec, Camera, Lens};

use super::{RenderScene, Surface};

/// What turns a hit's distance into the width of one sample's footprint.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) enum SampleSpread {
    /// No footprint: every texture is read at full resolution.
    #[default]
    Off,
    /// A perspective camera: width = `radians` × distance from the eye.
    Angle {
        /// The angle one sample spans.
        radians: f32,
    },
    /// An orthographic camera: every sample spans the same width.
    Width {
        /// World units.
        world: f32,
    },
}

impl SampleSpread {
    /// The spread of a `width`×`height` image of `camera` at `spp` samples per pixel.
    fn of(camera: &Camera, width: usize, height: usize, spp: u32) -> Self {
        if width == 0 || height == 0 || spp == 0 {
            return Self::Off;
        }
        let share = (1.0 / (spp as f32).sqrt()).max(0.125);
        match camera.lens {
            Lens::Orthographic { half_height, .. } => Self::Width {
                world: 2.0 * half_height / height as f32 * share,
            },
            // A thin lens's defocus blur is left out: the footprint of its sharp plane.
            Lens::Pinhole | Lens::Thin { .. } => {
                let (_, half_height) = camera.half_extent(width, height);
                Self::Angle {
                    radians: 2.0 * half_height / height as f32 * share,
                }
            }
        }
    }
}

/// Whether `b` (with its adapters) reads a mip-mapped texture.
pub(super) fn reads_footprint(b: &BsdfSpec) -> bool {
    match b {
        BsdfSpec::Diffuse { reflectance } => reflectance.uses_footprint(),
        BsdfSpec::GltfPbr {
            base_color,
            metallic_roughness,
            extensions,
            ..
        } => {
            base_color.uses_footprint()
                || metallic_roughness
                    .as_ref()
                    .is_some_and(|t| t.uses_footprint())
                || extensions.as_deref().is_some_and(|e| {
                    [&e.specular, &e.specular_color, &e.transmission]
                        .into_iter()
                        .chain([&e.sheen_color, &e.sheen_roughness])
                        .chain(e.clearcoat_texture.as_ref())
                        .chain(e.clearcoat_roughness_texture.as_ref())
                        .chain(e.clearcoat_normal.as_ref())
                        .any(|t| t.uses_footprint())
                })
        }
        BsdfSpec::NormalMap { normals, nested } => {
            normals.uses_footprint() || reads_footprint(nested)
        }
        _ => b.adapted().is_some_and(reads_footprint),
    }
}

impl RenderScene {
    /// Sets the footprint of texture lookups for `width`×`height` images at `spp` samples
    /// per pixel from the scene's camera (its position is read at each lookup, so an orbit
    /// that moves `scene.camera` needs no new call; a change of field of view or lens does).
    /// Until called, mip-mapped textures are read at full resolution.
    pub fn set_texture_footprint(&mut self, width: usize, height: usize, spp: u32) {
        self.sample_spread = SampleSpread::of(&self.scene.camera, width, height, spp);
    }

    /// The footprint of a texture lookup at `s` in uv units (zero where its material reads no
    /// mip-map or no footprint was set).
    #[inline(always)]
    pub(super) fn texture_footprint(&self, s: &Surface) -> f32 {
        if self.sample_spread == SampleSpread::Off || !self.reads_footprint[s.material] {
            return 0.0;
        }
        self.footprint_at(s)
    }

    /// [`Self::texture_footprint`] where it is needed: the sample's width at the hit's
    /// distance, widened by the slant of the surface (the circle of the same area as the
    /// slanted footprint), times the triangle's uv length per world length.
    #[inline(never)]
    fn footprint_at(&self, s: &Surface) -> f32 {
        let camera = &self.scene.camera;
        let (width, towards) = match self.sample_spread {
            SampleSpread::Off => return 0.0,
            SampleSpread::Angle { radians } => {
                let d = s.p - camera.origin;
                let dist = d.length();
                (radians * dist, d / dist)
            }
            SampleSpread::Width { world } => (world, camera.basis().2),
        };
        // At grazing angles the footprint is long and thin; a circle of its area blurs less
        // along it than its length would (isotropic lookups cannot follow the ellipse).
        let cos = s.ng.dot(towards).abs().max(1.0 / 64.0);
        let width = width / cos.sqrt();
        let per_world = self.uv_per_world(s);
        let footprint = width * per_world;
        if footprint.is_finite() {
            footprint
        } else {
            0.0
        }
    }

    /// The triangle's texture-coordinate length per world length at `s`: the square root of
    /// its uv area over its world area (zero for exact shapes and degenerate triangles).
    fn uv_per_world(&self, s: &Surface) -> f32 {
        if self.shape(s.instance).is_some() {
            return 0.0;
        }
        let inst = &self.scene.instances[s.instance as usize];
        let place = &self.placements[s.instance as usize];
        let mesh = &self.scene.meshes[inst.mesh];
        let t = s.triangle as usize;
        let [p0, p1, p2] = mesh.triangle(t);
        let [p0, p1, p2] = if place.identity {
            [p0, p1, p2]
        } else {
            [p0, p1, p2].map(|p| place.to_world.transform_point3(p))
        };
        let world = (p1 - p0).cross(p2 - p0).length();
        let [t0, t1, t2] = mesh.triangle_uvs(t);
        let uv = (t1 - t0).perp_dot(t2 - t0).abs();
        if world > 0.0 {
            (uv / world).sqrt()
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::{Mat4, Vec3};
    use lumo_image::Image;
    use lumo_scene::shapes::rectangle;
    use lumo_scene::{
        Instance, Material, MipFilter, MipMap, Scene, Texture, TextureFilter, WrapMode,
    };

    use crate::render_scene::RenderScene;

    /// A 16×16 mip-mapped grey texture.
    fn mipmapped() -> Texture {
        Texture::Mipmapped {
            mips: Arc::new(MipMap::new(Arc::new(Image::new(16, 16, 3, 0.5)))),
            magnify: TextureFilter::Bilinear,
            minify: TextureFilter::Bilinear,
            between: MipFilter::Linear,
            wrap: WrapMode::Repeat,
        }
    }

    /// The camera at (0, 0, 5) looking at the origin; the 2×2 rectangle at z = 0 facing it
    /// (instance 0) and, 3 further back, the same rectangle scaled by 2 and turned 60° about
    /// x (instance 1); both with `reflectance`.
    fn scene(reflectance: Texture) -> RenderScene {
        let mut scene = Scene::empty(crate::test_camera::camera_facing_origin(Vec3::new(
            0.0, 0.0, 5.0,
        )));
        let mut m = Material::diffuse("m", Vec3::splat(0.5));
        m.bsdf = lumo_scene::BsdfSpec::Diffuse { reflectance };
        let m = scene.add_material(m);
        let mesh = scene.add_mesh(rectangle(&Mat4::IDENTITY, m));
        scene.instances.push(Instance {
            mesh,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0))
                * Mat4::from_rotation_x(60f32.to_radians())
                * Mat4::from_scale(Vec3::splat(2.0)),
        });
        RenderScene::new(scene).expect("scene")
    }

    /// The footprint where the ray from the camera through `at` first meets the scene, and
    /// the point met.
    fn footprint_towards(rs: &RenderScene, at: Vec3) -> (f32, Vec3) {
        let origin = rs.scene.camera.origin;
        let dir = (at - origin).normalize();
        let hit = rs.accel.intersect(origin, dir, 0.0, 100.0).expect("a hit");
        let s = rs.surface(&hit, origin, dir);
        (rs.texture_footprint(&s), s.p)
    }

    /// Facing the camera, one sample of a 64×64 image at 16 spp spans a quarter of a
    /// pixel's angle (2·tan 20° / 64) times the distance; the rectangle has half a uv unit
    /// per world unit. Slanted by 60° (cos ½), the width grows by 1/√½; scaled by 2, the uv
    /// per world unit halves.
    #[test]
    fn the_footprint_is_a_samples_width_at_the_hit_in_uv_units() {
        let mut rs = scene(mipmapped());
        assert_eq!(footprint_towards(&rs, Vec3::new(0.2, 0.1, 0.0)).0, 0.0);
        rs.set_texture_footprint(64, 64, 16);
        let radians = 2.0 * 20f32.to_radians().tan() / 64.0 * 0.25;
        let (f, p) = footprint_towards(&rs, Vec3::new(0.2, 0.1, 0.0));
        let to = p - rs.scene.camera.origin;
        let cos = to.normalize().z.abs();
        let want = radians * to.length() / cos.sqrt() * 0.5;
        assert!((f - want).abs() < 1e-5 * want, "{f} vs {want}");

        // Beside the front rectangle, onto the slanted one behind it.
        let (f, p) = footprint_towards(&rs, Vec3::new(1.8, 0.0, -3.0));
        assert!(p.z < -2.0, "{p}");
        let to = p - rs.scene.camera.origin;
        let n = Vec3::new(0.0, -(60f32.to_radians().sin()), 60f32.to_radians().cos());
        let cos = n.dot(to.normalize()).abs();
        let want = radians * to.length() / cos.sqrt() * 0.25;
        assert!((f - want).abs() < 1e-3 * want, "{f} vs {want}");

        // More samples per pixel: narrower, down to an eighth of a pixel.
        rs.set_texture_footprint(64, 64, 1);
        let wide = footprint_towards(&rs, Vec3::new(0.2, 0.1, 0.0)).0;
        rs.set_texture_footprint(64, 64, 4096);
        let narrow = footprint_towards(&rs, Vec3::new(0.2, 0.1, 0.0)).0;
        assert!((wide / narrow - 8.0).abs() < 1e-3, "{wide} {narrow}");
    }

    /// A material without a mip-map pays nothing and reads no footprint.
    #[test]
    fn plain_textures_get_no_footprint() {
        let mut rs = scene(Texture::Constant(Vec3::splat(0.5)));
        rs.set_texture_footprint(64, 64, 1);
        assert_eq!(footprint_towards(&rs, Vec3::new(0.2, 0.1, 0.0)).0, 0.0);
    }
}
