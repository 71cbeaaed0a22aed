//! Particle tracing (a light tracer): paths start on the lights, scatter through the scene
//! with the same BSDFs and sampler as the path tracer, and every vertex is connected to the
//! pinhole camera. Each connection lands somewhere on the film as a *splat*; the image is a
//! density estimate, `pixel = Σ splats in the pixel / number of light paths`.
//!
//! The estimator uses the path tracer's shading-normal convention (Veach's adjoint
//! correction: on arrival `|ns·wl| / |ng·wl|`, on departure `|ng·w| / |ns·w|`), so on any
//! scene both integrators converge to the same image. Environment and constant lights are not
//! emitted (a particle from infinity needs a scene-sized disk per direction); they stay the path
//! tracer's job.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::{Camera, Light, Scene};

use crate::accel::analytic::Shape;
use crate::geometry::{
    shadow_segment, square_to_cosine_hemisphere, square_to_disk, square_to_triangle,
    square_to_uniform_sphere, Basis, UNIFORM_SPHERE_PDF,
};
use crate::integrators::path::PathSettings;
use crate::lights::distribution::Distribution1d;
use crate::lights::{triangle_radiance, SpotCone, TexturedEmission};
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// Something that emits particles.
#[derive(Clone, Copy, Debug)]
enum Emitter {
    /// One-sided emissive triangle.
    Triangle {
        p0: Vec3,
        e1: Vec3,
        e2: Vec3,
        normal: Vec3,
        area: f32,
        radiance: Vec3,
        /// Index into the textured emission records, or `NO_TEXTURE`.
        texture: u32,
    },
    /// One-sided emissive exact sphere, disk or cylinder, sampled uniformly by area.
    Shape {
        shape: Shape,
        radiance: Vec3,
    },
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: Vec3,
        cone: SpotCone,
    },
    Directional {
        direction: Vec3,
        irradiance: Vec3,
    },
}

/// The scene's emitters with a power-proportional choice among them.
pub struct Emitters {
    emitters: Vec<Emitter>,
    /// Radiance textures of textured emissive triangles (`Emitter::Triangle::texture`).
    textured: Vec<TexturedEmission>,
    choice: Distribution1d,
    scene_center: Vec3,
    scene_radius: f32,
}

impl Emitters {
    /// Collects emissive triangles, point, spot and directional lights of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds();
        let scene_center = (lo + hi) * 0.5;
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);
        let mut emitters = Vec::new();
        let mut textured = Vec::new();
        let mut power = Vec::new();
        for inst in &scene.instances {
            let mesh = &scene.meshes[inst.mesh];
            let material = &scene.materials[mesh.material];
            if !material.is_emissive() {
                continue;
            }
            if let Some(a) = &mesh.analytic {
                let shape = Shape::new(a, inst.transform);
                if shape.area > 0.0 && shape.area.is_finite() {
                    power.push(shape.area * PI * luminance(material.emission.into()));
                    emitters.push(Emitter::Shape {
                        shape,
                        radiance: material.emission,
                    });
                }
                continue;
            }
            for t in 0..mesh.triangle_count() {
                let [a, b, c] = mesh.triangle(t).map(|p| inst.transform.transform_point3(p));
                let cross = (b - a).cross(c - a);
                let area = 0.5 * cross.length();
                if area <= 0.0 {
                    continue;
                }
                power.push(area * PI * luminance(material.emission.into()));
                let texture = TexturedEmission::register(&mut textured, material, mesh, t);
                emitters.push(Emitter::Triangle {
                    p0: a,
                    e1: b - a,
                    e2: c - a,
                    normal: cross / (2.0 * area),
                    area,
                    radiance: material.emission,
                    texture,
                });
            }
        }
        for light in &scene.lights {
            match light {
                Light::Point {
                    position,
                    intensity,
                } => {
                    power.push(4.0 * PI * luminance((*intensity).into()));
                    emitters.push(Emitter::Point {
                        position: *position,
                        intensity: *intensity,
                    });
                }
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    beam_width,
                    cutoff,
                } => {
                    // The same cone and power as the path tracer's light choice.
                    let cone = SpotCone::new(*beam_width, *cutoff);
                    power.push(cone.solid_angle() * luminance((*intensity).into()));
                    emitters.push(Emitter::Spot {
                        position: *position,
                        axis: direction.normalize(),
                        intensity: *intensity,
                        cone,
                    });
                }
                Light::Directional {
                    direction,
                    irradiance,
                } => {
                    power.push(PI * scene_radius * scene_radius * luminance((*irradiance).into()));
                    emitters.push(Emitter::Directional {
                        direction: direction.normalize(),
                        irradiance: *irradiance,
                    });
                }
                Light::Constant { .. } | Light::Environment(_) => {}
            }
        }
        Self {
            choice: Distribution1d::new(&power),
            emitters,
            textured,
            scene_center,
            scene_radius,
        }
    }

    /// True when the scene has nothing the light tracer can emit from.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
            || self.choice.total().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
    }
}

/// The pinhole camera as the light tracer needs it: projection of world points to the film
/// and the importance normalisation.
#[derive(Clone, Copy, Debug)]
pub struct FilmCamera {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Half-extents of the image plane at distance 1.
    half: Vec2,
    size: Vec2,
    /// Pixels per unit film area: the importance of one pixel is `pixels / (A cos⁴θ)`.
    pixel_importance: f32,
}

impl FilmCamera {
    /// The camera for a `width`×`height` film.
    pub fn new(camera: &Camera, width: usize, height: usize) -> Self {
        let (right, up, forward) = camera.basis();
        let (hw, hh) = camera.half_extent(width, height);
        let area = 4.0 * hw * hh;
        Self {
            origin: camera.origin,
            forward,
            right,
            up,
            half: Vec2::new(hw, hh),
            size: Vec2::new(width as f32, height as f32),
            pixel_importance: (width * height) as f32 / area,
        }
    }

    /// Eye position.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Film position (pixels, x right, y down) of world point `p` and the cosine between the
    /// view axis and the direction to `p`, if `p` is in front and inside the film.
    fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.origin;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / (z * self.half.x);
        let sy = d.dot(self.up) / (z * self.half.y);
        if !(-1.0..1.0).contains(&sx) || !(-1.0..1.0).contains(&sy) {
            return None;
        }
        let film = Vec2::new((sx + 1.0) * 0.5, (1.0 - sy) * 0.5) * self.size;
        Some((film, z / d.length()))
    }
}

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

/// Radiance reaching the eye from `p` along a clear line of sight, already multiplied by the
/// camera's importance, if `p` is visible and on the film. `wl_value` turns the direction to
/// the camera into the vertex's scattered (or emitted) value before the geometric term.
fn connect(
    rs: &RenderScene,
    camera: &FilmCamera,
    p: Vec3,
    ng: Vec3,
    origin_off: impl Fn(Vec3) -> Vec3,
    value: impl Fn(Vec3) -> Vec3,
) -> Option<(LightSplat, u32)> {
    let (film, cos_cam) = camera.project(p)?;
    let to_cam = camera.origin - p;
    let dist2 = to_cam.length_squared();
    let wc = to_cam / dist2.sqrt();
    let v = value(wc);
    if v == Vec3::ZERO {
        return None;
    }
    let o = origin_off(wc);
    let (dir, tmax) = shadow_segment(o.into(), camera.origin.into(), wc.into(), rs.ray_epsilon);
    if rs.accel.occluded(o, dir.into(), 0.0, tmax) {
        return Some((
            LightSplat {
                film,
                value: Vec3::ZERO,
            },
            1,
        ));
    }
    // G(c, x)·We: |cos_x| |cos_c| / d² · pixels / (A cos⁴θ_c).
    let importance = ng.dot(wc).abs() * camera.pixel_importance / (dist2 * cos_cam.powi(3));
    let value = v * importance;
    value.is_finite().then_some((LightSplat { film, value }, 1))
}

/// Traces one light path with the numbers of `sampler`, calling `splat` for every vertex that
/// sees the camera (including the point on the light itself).
pub fn trace_light_path(
    rs: &RenderScene,
    emitters: &Emitters,
    camera: &FilmCamera,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    splat: &mut impl FnMut(LightSplat),
) -> LightPathStats {
    let mut stats = LightPathStats::default();
    let u_choice = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    if emitters.is_empty() {
        return stats;
    }
    let (index, _) = emitters.choice.sample(u_choice);
    let pick = emitters.choice.pmf(index);
    if pick <= 0.0 {
        return stats;
    }
    let mut emit = |s: Option<(LightSplat, u32)>, stats: &mut LightPathStats| {
        if let Some((sp, rays)) = s {
            stats.rays += rays;
            if sp.value != Vec3::ZERO {
                stats.splats += 1;
                splat(sp);
            }
        }
    };
    // The first ray: origin, direction and throughput (radiance × cos / densities).
    // A point on an area emitter: position, normal, area and radiance.
    let area_point = match emitters.emitters[index] {
        Emitter::Triangle {
            p0,
            e1,
            e2,
            normal,
            area,
            radiance,
            texture,
        } => {
            let b = square_to_triangle(u_pos);
            let radiance = triangle_radiance(&emitters.textured, texture, radiance, b);
            Some((p0 + e1 * b.x + e2 * b.y, normal, area, radiance))
        }
        Emitter::Shape { shape, radiance } => {
            let sp = shape.sample_area(u_pos);
            Some((sp.p, sp.n, shape.area, radiance))
        }
        _ => None,
    };
    let (mut origin, mut dir, mut throughput) = match emitters.emitters[index] {
        Emitter::Triangle { .. } | Emitter::Shape { .. } => {
            let Some((p, normal, area, radiance)) = area_point else {
                return stats;
            };
            let pdf_area = pick / area;
            let off = |d: Vec3| {
                let side = if normal.dot(d) >= 0.0 { 1.0 } else { -1.0 };
                p + normal * (side * rs.ray_epsilon * (1.0 + p.abs().max_element()))
            };
            // The light itself seen by the camera (depth 1).
            let seen = connect(rs, camera, p, normal, off, |wc| {
                if normal.dot(wc) > 0.0 {
                    radiance / pdf_area
                } else {
                    Vec3::ZERO
                }
            });
            emit(seen, &mut stats);
            let local = square_to_cosine_hemisphere(u_dir);
            let dir = Basis::new(normal).to_world(local).normalize();
            // Le·cos / (pdf_A · cos/π) = Le·π / pdf_A.
            (off(dir), dir, radiance * PI / pdf_area)
        }
        Emitter::Point {
            position,
            intensity,
        } => {
            let dir = square_to_uniform_sphere(u_dir);
            (position, dir, intensity / (pick * UNIFORM_SPHERE_PDF))
        }
        Emitter::Spot {
            position,
            axis,
            intensity,
            cone,
        } => {
            // Uniform in the cutoff cone, weighted by the falloff.
            let cos_outer = cone.cos_cutoff();
            let cos = 1.0 - u_dir.x * (1.0 - cos_outer);
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let phi = 2.0 * PI * u_dir.y;
            let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
            let dir = Basis::new(axis).to_world(local).normalize();
            let falloff = cone.falloff(cos);
            let pdf_dir = 1.0 / (2.0 * PI * (1.0 - cos_outer));
            (position, dir, intensity * falloff / (pick * pdf_dir))
        }
        Emitter::Directional {
            direction,
            irradiance,
        } => {
            // A disk covering the scene, perpendicular to the light, outside the scene.
            let r = emitters.scene_radius;
            let d = square_to_disk(u_pos) * r;
            let f = Basis::new(direction);
            let p = emitters.scene_center + f.to_world(Vec3::new(d.x, d.y, 0.0)) - direction * r;
            (p, direction, irradiance * (PI * r * r) / pick)
        }
    };
    // Depth of the path camera ← x_k ← … ← light when connecting at the k-th scene vertex.
    let mut depth = 2u32;
    loop {
        if depth > settings.max_depth || throughput == Vec3::ZERO || !throughput.is_finite() {
            break;
        }
        stats.rays += 1;
        let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
            break;
        };
        let s = rs.surface(&hit, origin, dir);
        let bsdf = rs.bsdf(&s);
        let wl = -dir;
        let (ns, ng) = (s.frame.n, s.ng);
        let (cos_ns_l, cos_ng_l) = (ns.dot(wl).abs(), ng.dot(wl).abs());
        if cos_ng_l <= 0.0 || cos_ns_l <= 0.0 {
            break;
        }
        // Arrival half of the adjoint shading-normal correction.
        throughput *= cos_ns_l / cos_ng_l;
        let wl_local = s.frame.to_local(wl);
        // A one-sided BSDF lit from behind is black both ways (Mitsuba checks both directions
        // against the front side): no connection, no continuation — as the path tracer ends
        // a camera path at its back.
        if wl_local.z <= 0.0 && rs.one_sided(s.material) {
            break;
        }
        if !bsdf.is_delta() {
            let off = |d: Vec3| rs.offset(&s, d);
            let seen = connect(rs, camera, s.p, ng, off, |wc| {
                // f without its cosine: eval includes |cos θi| of the light side.
                let f = bsdf.eval(s.frame.to_local(wc), wl_local) / wl_local.z.abs();
                throughput * f
            });
            emit(seen, &mut stats);
        }
        if depth >= settings.max_depth {
            break;
        }
        let u_lobe = sampler.next_1d();
        let u_bsdf = sampler.next_2d();
        let u_rr = sampler.next_1d();
        // Sampling "wi" with the light side as "wo" picks the particle's next direction;
        // the BSDFs are reciprocal, so the weight is the same f·|cos|/pdf.
        let Some(bs) = bsdf.sample(wl_local, u_lobe, u_bsdf) else {
            break;
        };
        let new_dir = s.frame.to_world(bs.wi).normalize();
        let reflect = bs.wi.z * wl_local.z > 0.0;
        if reflect != (new_dir.dot(ng) * wl.dot(ng) > 0.0) {
            break;
        }
        let cos_ns_o = ns.dot(new_dir).abs();
        if cos_ns_o <= 0.0 {
            break;
        }
        // Departure half of the correction.
        throughput *= bs.weight * (ng.dot(new_dir).abs() / cos_ns_o);
        origin = rs.offset(&s, new_dir);
        dir = new_dir;
        if depth >= settings.rr_depth {
            let q = throughput.max_element().min(0.95);
            if u_rr >= q {
                break;
            }
            throughput /= q;
        }
        depth += 1;
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{render, RenderSettings};
    use lumo_scene::builtin_scene;

    /// Light-traces `paths` paths into a `w`×`h` image (pixel = Σ splats / paths).
    fn light_image(
        rs: &RenderScene,
        w: usize,
        h: usize,
        paths: u32,
        settings: &PathSettings,
    ) -> Vec<Vec3> {
        let emitters = Emitters::new(&rs.scene);
        let camera = FilmCamera::new(&rs.scene.camera, w, h);
        let mut img = vec![Vec3::ZERO; w * h];
        for i in 0..paths {
            let mut sampler = PixelSampler::new(i >> 16, 7, i & 0xffff, 3);
            trace_light_path(rs, &emitters, &camera, &mut sampler, settings, &mut |s| {
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
        let emitters = Emitters::new(&rs.scene);
        assert!(!emitters.is_empty());
        let camera = FilmCamera::new(&rs.scene.camera, 20, 10);
        let mut n = 0;
        for i in 0..2000 {
            let mut sampler = PixelSampler::new(0, 0, i, 0);
            let st = trace_light_path(
                &rs,
                &emitters,
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
        assert!(Emitters::new(&dark).is_empty());
    }
}
