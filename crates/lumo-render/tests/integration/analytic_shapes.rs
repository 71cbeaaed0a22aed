//! Mitsuba's `sphere`, `disk` and `cylinder` are intersected exactly: hit distances, normals
//! and uv against closed forms (outside, inside, grazing, flipped normals, secondary rays
//! leaving the surface), and a silhouette that a tessellated sphere gets visibly wrong.

use std::path::Path;

use glam::{Vec2, Vec3};
use lumo_render::camera::PinholeCamera;
use lumo_render::{render, PathSettings, RenderScene, RenderSettings};
use lumo_scene::load::{load_mitsuba_str, LoadOptions};

fn scene(body: &str) -> RenderScene {
    let text = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,10" target="0,0,0" up="0,1,0"/></transform>
  </sensor>
  {body}
</scene>"#
    );
    let loaded = load_mitsuba_str(&text, Path::new("test.xml"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    RenderScene::new(loaded.scene).unwrap()
}

/// Hit distance, normal and uv of the ray, or `None`; checks that the any-hit query agrees.
fn trace(rs: &RenderScene, o: Vec3, d: Vec3) -> Option<(f32, Vec3, Vec2, Vec3)> {
    let hit = rs.accel.intersect(o, d, 0.0, f32::INFINITY);
    assert_eq!(
        hit.is_some(),
        rs.accel.occluded(o, d, 0.0, f32::INFINITY),
        "closest-hit and any-hit disagree for {o} {d}"
    );
    let hit = hit?;
    let s = rs.surface(&hit, o, d);
    Some((hit.t, s.ng, s.uv, s.p))
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

fn close3(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

const SPHERE: &str = r#"<shape type="sphere"><float name="radius" value="2"/>
    <bsdf type="diffuse"/></shape>"#;

#[test]
fn sphere_hits_match_the_closed_form() {
    let rs = scene(SPHERE);
    // (origin, direction, t, normal, uv): u = φ/2π around local z, v = θ/π from +z.
    let cases = [
        (Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 3.0, Vec3::Z, None),
        (
            Vec3::new(5.0, 0.0, 0.0),
            -Vec3::X,
            3.0,
            Vec3::X,
            Some(Vec2::new(0.0, 0.5)),
        ),
        (
            Vec3::new(0.0, 5.0, 0.0),
            -Vec3::Y,
            3.0,
            Vec3::Y,
            Some(Vec2::new(0.25, 0.5)),
        ),
        (
            Vec3::new(0.0, 0.0, -5.0),
            Vec3::Z,
            3.0,
            -Vec3::Z,
            Some(Vec2::new(0.0, 1.0)),
        ),
        // From the centre: the near root is behind, the far one (the wall) is the hit.
        (Vec3::ZERO, Vec3::X, 2.0, Vec3::X, Some(Vec2::new(0.0, 0.5))),
    ];
    for (o, d, t, n, uv) in cases {
        let (ht, hn, huv, hp) = trace(&rs, o, d).unwrap_or_else(|| panic!("{o} {d} missed"));
        assert!(close(ht, t, 1e-5), "t {ht} != {t}");
        assert!(close3(hn, n, 1e-5), "n {hn} != {n}");
        assert!(
            close(hp.length(), 2.0, 1e-6),
            "hit point {hp} off the sphere"
        );
        if let Some(uv) = uv {
            assert!(
                close(huv.x, uv.x, 1e-5) && close(huv.y, uv.y, 1e-5),
                "{huv} != {uv}"
            );
        }
    }
    // A general direction: the exact distance of a ray 1 off the centre line.
    let (t, n, _, _) = trace(&rs, Vec3::new(1.0, 0.0, 6.0), -Vec3::Z).unwrap();
    assert!(close(t, 6.0 - 3f32.sqrt(), 1e-5), "{t}");
    assert!(
        close3(n, Vec3::new(0.5, 0.0, 3f32.sqrt() / 2.0), 1e-5),
        "{n}"
    );
}

#[test]
fn sphere_grazing_rays_hit_inside_the_radius_and_miss_outside() {
    let rs = scene(SPHERE);
    for (y, hits) in [(2.0 - 1e-4, true), (2.0 - 1e-6, true), (2.0 + 1e-5, false)] {
        let r = trace(&rs, Vec3::new(-6.0, y, 0.0), Vec3::X);
        assert_eq!(r.is_some(), hits, "grazing ray at y = {y}");
        if let Some((t, n, _, _)) = r {
            // Both roots are nearly equal; the nearer one is taken.
            let half = (4.0f64 - (y as f64).powi(2)).max(0.0).sqrt() as f32;
            assert!(close(t, 6.0 - half, 1e-3), "{t}");
            assert!(n.y > 0.99, "{n}");
        }
    }
}

#[test]
fn rays_leaving_a_sphere_do_not_hit_it_again() {
    let rs = scene(SPHERE);
    let mut escapes = 0;
    for i in 0..200 {
        // Points all over the sphere, each hit from outside.
        let a = i as f32 * 0.731;
        let dir = -Vec3::new(a.cos() * (a * 0.37).sin(), (a * 0.37).cos(), a.sin()).normalize();
        let o = -dir * 6.0 + Vec3::new(0.3, -0.2, 0.1);
        let Some(hit) = rs.accel.intersect(o, dir, 0.0, f32::INFINITY) else {
            continue;
        };
        let s = rs.surface(&hit, o, dir);
        // Out along the normal, tangent to the surface and back in.
        let tangent = s.frame.s;
        for (w, expect_hit) in [
            (s.ng, false),
            ((s.ng * 0.02 + tangent).normalize(), false),
            (-s.ng, true),
            ((-s.ng + tangent).normalize(), true),
        ] {
            let origin = rs.offset(&s, w);
            let h = rs.accel.intersect(origin, w, 0.0, f32::INFINITY);
            assert_eq!(h.is_some(), expect_hit, "from {} along {w}", s.p);
            if let Some(h) = h {
                // The far side: a chord of length 2r·|cos|, never a hit at the start.
                let chord = 4.0 * w.dot(-s.ng);
                assert!(close(h.t, chord, 1e-3), "t {} chord {chord}", h.t);
            } else {
                escapes += 1;
            }
        }
    }
    assert!(escapes > 100);
}

#[test]
fn flipped_normals_point_inwards() {
    let rs = scene(
        r#"<shape type="sphere"><float name="radius" value="2"/><boolean name="flip_normals" value="true"/>
    <bsdf type="diffuse"/></shape>"#,
    );
    let (_, n, _, _) = trace(&rs, Vec3::new(5.0, 0.0, 0.0), -Vec3::X).unwrap();
    assert!(close3(n, -Vec3::X, 1e-6), "{n}");
    let rs = scene(
        r#"<shape type="disk"><boolean name="flip_normals" value="true"/><bsdf type="diffuse"/></shape>"#,
    );
    let (_, n, _, _) = trace(&rs, Vec3::new(0.1, 0.2, 3.0), -Vec3::Z).unwrap();
    assert!(close3(n, -Vec3::Z, 1e-6), "{n}");
}

#[test]
fn disk_hits_match_the_closed_form() {
    let rs = scene(
        r#"<shape type="disk"><transform name="to_world"><scale value="2"/><translate z="1"/></transform>
    <bsdf type="diffuse"/></shape>"#,
    );
    let (t, n, uv, p) = trace(&rs, Vec3::new(0.5, 0.5, 5.0), -Vec3::Z).unwrap();
    assert!(close(t, 4.0, 1e-6) && close3(n, Vec3::Z, 1e-6), "{t} {n}");
    assert!(close(p.z, 1.0, 1e-7), "{p}");
    // Mitsuba's disk uv: (r, φ/2π) in the unit disk.
    assert!(
        close(uv.x, 0.5f32.sqrt() / 2.0, 1e-6) && close(uv.y, 0.125, 1e-6),
        "{uv}"
    );
    // From below, and just past the rim.
    let (t, n, _, _) = trace(&rs, Vec3::new(-1.0, 0.0, -2.0), Vec3::Z).unwrap();
    assert!(close(t, 3.0, 1e-6) && close3(n, Vec3::Z, 1e-6));
    assert!(trace(&rs, Vec3::new(1.999, 0.0, 5.0), -Vec3::Z).is_some());
    assert!(trace(&rs, Vec3::new(2.001, 0.0, 5.0), -Vec3::Z).is_none());
    // In its own plane: no hit.
    assert!(trace(&rs, Vec3::new(-5.0, 0.0, 1.0), Vec3::X).is_none());
}

#[test]
fn cylinder_hits_match_the_closed_form() {
    let rs = scene(
        r#"<shape type="cylinder"><point name="p0" value="0,0,0"/><point name="p1" value="0,0,2"/>
    <float name="radius" value="0.5"/><bsdf type="diffuse"/></shape>"#,
    );
    let (t, n, uv, _) = trace(&rs, Vec3::new(5.0, 0.0, 1.0), -Vec3::X).unwrap();
    assert!(close(t, 4.5, 1e-6) && close3(n, Vec3::X, 1e-6), "{t} {n}");
    assert!(close(uv.x, 0.0, 1e-6) && close(uv.y, 0.5, 1e-6), "{uv}");
    // From inside the open tube: the wall ahead, normal still outwards, u = φ/2π.
    let (t, n, uv, _) = trace(&rs, Vec3::new(0.0, 0.0, 1.0), Vec3::Y).unwrap();
    assert!(close(t, 0.5, 1e-6) && close3(n, Vec3::Y, 1e-6), "{t} {n}");
    assert!(close(uv.x, 0.25, 1e-6) && close(uv.y, 0.5, 1e-6), "{uv}");
    // Past the ends (the cylinder has no caps), and down its axis.
    assert!(trace(&rs, Vec3::new(5.0, 0.0, 2.01), -Vec3::X).is_none());
    assert!(trace(&rs, Vec3::new(5.0, 0.0, -0.01), -Vec3::X).is_none());
    assert!(trace(&rs, Vec3::new(0.0, 0.0, 5.0), -Vec3::Z).is_none());
    // A slanted ray that enters through the open end hits the inside wall.
    let d = Vec3::new(0.3, 0.0, -1.0).normalize();
    let (t, _, _, p) = trace(&rs, Vec3::new(0.0, 0.0, 3.0), d).unwrap();
    assert!(
        close(p.x, 0.5, 1e-5) && close(t, 0.5 / d.x, 1e-4),
        "{p} {t}"
    );
}

/// A sphere that emits 1 seen directly against black: a pixel's value is the fraction of it
/// the sphere covers. The camera looks at a stretch of the silhouette 10⁻³ radii wide, where
/// a tessellated sphere's polygon edge lies several pixels inside the true circle.
#[test]
fn sphere_silhouette_matches_analytic_coverage_where_tessellation_does_not() {
    // Camera 4 radii from the centre, aimed along the tangent to the sphere's top and rolled,
    // so the edge crosses the pixels at a slant.
    let sin = 0.25f32;
    let aim = Vec3::new(0.0, sin, -(1.0 - sin * sin).sqrt());
    let origin = Vec3::new(0.0, 0.0, 4.0);
    let target = origin + aim * 3.873;
    let text = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="0.015"/>
    <transform name="to_world"><lookat origin="0,0,4" target="{},{},{}" up="0.4,1,0"/></transform>
  </sensor>
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#,
        target.x, target.y, target.z
    );
    let loaded = load_mitsuba_str(&text, Path::new("test.xml"), &LoadOptions::default()).unwrap();
    let (w, h) = (32usize, 32usize);
    let camera = PinholeCamera::new(&loaded.scene.camera, w, h);
    // Coverage by the exact sphere: 16×16 sub-pixel rays tested in f64.
    let mut expected = vec![0.0f64; w * h];
    let n = 16;
    for y in 0..h {
        for x in 0..w {
            let mut inside = 0;
            for j in 0..n {
                for i in 0..n {
                    let film = Vec2::new(
                        x as f32 + (i as f32 + 0.5) / n as f32,
                        y as f32 + (j as f32 + 0.5) / n as f32,
                    );
                    let d = camera.direction(film).as_dvec3().normalize();
                    let o = origin.as_dvec3();
                    let b = o.dot(d);
                    if b * b - (o.length_squared() - 1.0) >= 0.0 && b < 0.0 {
                        inside += 1;
                    }
                }
            }
            expected[y * w + x] = inside as f64 / (n * n) as f64;
        }
    }
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 64,
        seed: 1,
        path: PathSettings {
            max_depth: 1,
            ..Default::default()
        },
    };
    let image_error = |scene: lumo_scene::Scene| {
        let rs = RenderScene::new(scene).unwrap();
        let img = render(&rs, &settings, &|_| {}).0.color;
        let mut abs = 0.0f64;
        let mut signed = 0.0f64;
        for y in 0..h {
            for x in 0..w {
                let e = img.rgb(x, y)[1] as f64 - expected[y * w + x];
                abs += e.abs();
                signed += e;
            }
        }
        let px = (w * h) as f64;
        (abs / px, signed / px)
    };
    let covered = expected.iter().sum::<f64>() / (w * h) as f64;
    assert!(
        covered > 0.2 && covered < 0.8,
        "the view shows the silhouette: {covered}"
    );
    let (abs, signed) = image_error(loaded.scene.clone());
    assert!(
        abs < 0.02 && signed.abs() < 0.005,
        "exact sphere: mean |error| {abs}, mean error {signed}"
    );
    // The same sphere as its tessellated proxy: the edge is off by pixels.
    let mut tessellated = loaded.scene;
    for m in &mut tessellated.meshes {
        m.analytic = None;
    }
    let (abs_t, signed_t) = image_error(tessellated);
    assert!(
        signed_t.abs() > 0.03 && abs_t > 3.0 * abs,
        "tessellated sphere: mean |error| {abs_t}, mean error {signed_t}"
    );
}

/// A sphere light and a disk light over a floor with a cylinder and a ball: the light tracer
/// (particles leaving the exact shapes, uniform by area) and the path tracer (the sphere light
/// sampled by its visible cone, MIS with BSDF-sampled hits) estimate the same image mean.
#[test]
fn light_tracer_and_path_tracer_agree_on_analytic_lights() {
    use lumo_render::camera::PinholeCamera;
    use lumo_render::integrators::light::trace_light_path;
    use lumo_render::sampler::PixelSampler;
    let text = r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0,2.5,4" target="0,0.4,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf>
  </shape>
  <shape type="cylinder"><point name="p0" value="0.8,0,0"/><point name="p1" value="0.8,1,0"/><float name="radius" value="0.3"/>
    <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></bsdf></shape>
  <shape type="sphere"><point name="center" value="-0.6,0.4,0.3"/><float name="radius" value="0.4"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></shape>
  <shape type="sphere"><point name="center" value="0.2,1.8,0.5"/><float name="radius" value="0.25"/>
    <emitter type="area"><rgb name="radiance" value="8"/></emitter></shape>
  <shape type="disk"><transform name="to_world"><rotate x="1" angle="120"/><scale value="0.3"/><translate x="-1.2" y="1.2" z="-0.8"/></transform>
    <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
</scene>"#;
    let loaded = load_mitsuba_str(text, Path::new("t.xml"), &LoadOptions::default()).unwrap();
    let scene = loaded.scene;
    let rs = RenderScene::new(scene.clone()).unwrap();
    let (w, h) = (32usize, 32usize);
    let max_depth = 3;
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 1024,
        seed: 2,
        path: PathSettings {
            max_depth,
            ..Default::default()
        },
    };
    let path_mean = render(&rs, &settings, &|_| {}).0.color.channel_means()[0];
    let film = PinholeCamera::new(&scene.camera, w, h);
    let mut total = 0.0f64;
    let paths = 400_000u32;
    for m in 0..paths {
        let mut sampler = PixelSampler::new(1 << 20, m >> 16, m & 0xffff, 9);
        trace_light_path(&rs, &film, &mut sampler, &settings.path, &mut |s| {
            total += s.value.x as f64;
        });
    }
    let light_mean = total / paths as f64 / (w * h) as f64;
    assert!(
        (light_mean - path_mean).abs() < 0.03 * path_mean,
        "light tracer {light_mean:.5} vs path tracer {path_mean:.5}"
    );
}
