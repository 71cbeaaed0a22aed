//! Mitsuba sensors, integrators, shapes and emitters.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::props::Props;
use super::xml::Element;
use super::Builder;
use crate::load::{
    check::{check_emission, check_light, check_mesh},
    obj, ply, LoadError,
};
use crate::{
    shapes, Analytic, AnalyticKind, Camera, EnvMap, FovAxis, Instance, Lens, Light, Mesh,
    PixelFilter, Texture,
};

/// Tessellation of the analytic shapes: only their proxy (bounds, triangle counts, viewers);
/// the renderer intersects the exact shapes, as Mitsuba does.
const SPHERE_RINGS: u32 = 64;
const SPHERE_SEGMENTS: u32 = 128;
const ROUND_SEGMENTS: u32 = 128;

/// Proxy triangles the exact shapes of one file get at the tessellations above (about 30 MB);
/// past it each exact shape's proxy is its bounding box or square (12 or 2 triangles), so
/// the proxies grow with the file, not 16,128 triangles per sphere (5,000 spheres, a 315 KB
/// file, were 80.6 M triangles: 3.2 GB).
const PROXY_TRIANGLE_BUDGET: usize = 1 << 20;

/// Mitsuba's `max_depth = -1` (unbounded); Russian roulette ends such paths.
const UNBOUNDED_DEPTH: u32 = crate::DEPTH_LIMIT;

impl<'a> Builder<'a, '_> {
    /// `<sensor>`: camera, film size, sample count and seed.
    pub(super) fn sensor(&mut self, el: &'a Element) -> Result<(), LoadError> {
        let props = Props::new(el);
        let at = el.at();
        if self.has_camera {
            self.diag
                .warn(at.clone(), "more than one <sensor>; lumo uses the first")?;
            return Ok(());
        }
        let kind = props.kind();
        let lens = match kind {
            "perspective" | "orthographic" => Lens::Pinhole,
            "thinlens" => {
                let aperture_radius = props.float("aperture_radius", 0.0)?;
                let focus_distance = props.float("focus_distance", 0.0)?;
                if !(aperture_radius.is_finite() && aperture_radius >= 0.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!(
                            "thinlens aperture_radius {aperture_radius}: use a radius >= 0 \
                             (0 is a pinhole)"
                        ),
                    ));
                }
                if !(focus_distance.is_finite() && focus_distance > 0.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!(
                            "thinlens focus_distance {focus_distance}: give the distance of \
                             the plane in focus, > 0 (<float name=\"focus_distance\">)"
                        ),
                    ));
                }
                Lens::Thin {
                    aperture_radius,
                    focus_distance,
                }
            }
            other => {
                return Err(LoadError::invalid(
                    at,
                    format!(
                        "sensor type {other:?} is not supported; lumo renders perspective, \
                         thinlens and orthographic sensors"
                    ),
                ))
            }
        };
        let to_world = props.transform("to_world")?;
        let (fov, fov_axis) = if kind == "orthographic" {
            // Unused by an orthographic camera; any valid angle.
            (90.0, FovAxis::X)
        } else if props.has("fov") {
            let axis = match props.string("fov_axis")?.as_deref().unwrap_or("x") {
                "x" => FovAxis::X,
                "y" => FovAxis::Y,
                "smaller" => FovAxis::Smaller,
                "larger" => FovAxis::Larger,
                "diagonal" => FovAxis::Diagonal,
                other => {
                    return Err(LoadError::invalid(
                        at,
                        format!("fov_axis {other:?} is not one of x, y, smaller, larger, diagonal"),
                    ))
                }
            };
            (props.float("fov", 0.0)?, axis)
        } else {
            // A 35 mm-equivalent focal length gives the diagonal field of view of a 36×24 frame.
            let f = match props.string("focal_length")? {
                Some(s) => s
                    .trim()
                    .trim_end_matches("mm")
                    .trim()
                    .parse::<f32>()
                    .map_err(|_| {
                        LoadError::invalid(
                            at.clone(),
                            format!("focal_length {s:?} is not e.g. 50mm"),
                        )
                    })?,
                None => 50.0,
            };
            // 0mm became a 180° field of view, and the message spoke of that angle, not of the
            // focal length as written.
            if !(f.is_finite() && f > 0.0) {
                return Err(LoadError::invalid(
                    at,
                    format!("focal_length {f}mm: use a length > 0 (50mm is a normal lens)"),
                ));
            }
            let diagonal = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
            (
                2.0 * (diagonal / (2.0 * f)).atan().to_degrees(),
                FovAxis::Diagonal,
            )
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(LoadError::invalid(
                at,
                format!("field of view {fov}° is not between 0 and 180"),
            ));
        }
        // Clip planes at Mitsuba's defaults (0.01 and 10⁴) cut nothing a scene shows; others
        // may cut geometry away (a near plane through a wall), which lumo does not.
        for (name, default, side) in [
            ("near_clip", 1e-2f32, "nearer"),
            ("far_clip", 1e4, "farther"),
        ] {
            let v = props.float(name, default)?;
            if v != default {
                self.diag.warn(
                    at.clone(),
                    format!(
                        "{name} {v}: lumo does not clip camera rays, so geometry {side} than {v} is \
                         rendered; remove that geometry from the scene to see what Mitsuba \
                         shows, or move the camera"
                    ),
                )?;
            }
        }
        props.accept(&["shutter_open", "shutter_close"]);
        let origin = to_world.transform_point3(Vec3::ZERO);
        let forward = to_world.transform_vector3(Vec3::Z);
        let up = to_world.transform_vector3(Vec3::Y);
        if to_world.determinant() < 0.0 {
            self.diag.warn(
                at.clone(),
                "the camera transform mirrors the image; lumo renders it unmirrored",
            )?;
        }
        let forward = forward
            .try_normalize()
            .ok_or_else(|| LoadError::invalid(at.clone(), "the camera transform is singular"))?;
        // A lone <lookat> is taken literally: re-deriving target and up from its matrix would
        // round them, and the image would differ in the last bits from the same camera built
        // in code.
        let (origin, target, up) = props.value("to_world").and_then(single_lookat).unwrap_or((
            origin,
            origin + forward,
            up,
        ));
        self.scene.camera = Camera {
            origin,
            target,
            up,
            fov,
            fov_axis,
            lens,
            filter: Default::default(),
        };
        self.has_camera = true;
        for (i, c) in props.nested() {
            let c = self.resolve(c)?;
            match c.tag.as_str() {
                "film" => {
                    props.mark(i);
                    self.film(c)?;
                }
                "sampler" => {
                    props.mark(i);
                    let s = Props::new(c);
                    let spp = s.int("sample_count", 4)?;
                    let seed = s.int("seed", 0)?;
                    if spp < 1 || spp > u32::MAX as i64 {
                        return Err(LoadError::invalid(
                            c.at(),
                            format!(
                                "sample_count {spp}: use 1 to {} samples per pixel",
                                u32::MAX
                            ),
                        ));
                    }
                    if seed < 0 || seed > u32::MAX as i64 {
                        return Err(LoadError::invalid(
                            c.at(),
                            format!("seed {seed}: use 0 to {}", u32::MAX),
                        ));
                    }
                    self.settings.spp = Some(spp as u32);
                    self.settings.seed = Some(seed as u32);
                    // Every Mitsuba sampler type maps to lumo's own (Sobol-Burley): the same
                    // expected image; only the noise differs.
                    const SAMPLERS: [&str; 5] = [
                        "independent",
                        "stratified",
                        "multijitter",
                        "orthogonal",
                        "ldsampler",
                    ];
                    if !SAMPLERS.contains(&s.kind()) {
                        self.diag.warn(
                            c.at(),
                            format!(
                                "sampler {:?} is not one of Mitsuba 3's ({}); lumo samples with \
                                 its own Sobol sequence, as for all of them",
                                s.kind(),
                                SAMPLERS.join(", ")
                            ),
                        )?;
                    }
                    s.accept(&["jitter", "scramble_seed"]);
                    s.finish(self.diag)?;
                }
                _ => {}
            }
        }
        if kind == "orthographic" {
            // Mitsuba's view spans x in [-1, 1] and y in [-1/aspect, 1/aspect] of camera space,
            // scaled by to_world.
            let (w, h) = (
                self.scene.defaults.width as f32,
                self.scene.defaults.height as f32,
            );
            let sx = to_world.transform_vector3(Vec3::X).length();
            let sy = to_world.transform_vector3(Vec3::Y).length();
            if !(sx > 0.0 && sy > 0.0 && sx.is_finite() && sy.is_finite()) {
                return Err(LoadError::invalid(
                    at,
                    "orthographic sensor: to_world scales the view to nothing; give a \
                     non-zero <scale x=\"..\" y=\"..\"> (the view's half width and height)",
                ));
            }
            self.scene.camera.lens = Lens::Orthographic {
                half_width: sx,
                half_height: sy * h / w,
            };
        }
        self.sensor_medium(&props)?;
        props.finish(self.diag)
    }

    fn film(&mut self, el: &'a Element) -> Result<(), LoadError> {
        let props = Props::new(el);
        if props.kind() != "hdrfilm" {
            self.diag.warn(
                el.at(),
                format!("film {:?} is read as hdrfilm", props.kind()),
            )?;
        }
        let w = props.int("width", 768)?;
        let h = props.int("height", 576)?;
        if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
            return Err(LoadError::invalid(
                el.at(),
                format!("film size {w}x{h} is not within 1..=16384"),
            ));
        }
        self.settings.size = Some((w as usize, h as usize));
        self.scene.defaults.width = w as usize;
        self.scene.defaults.height = h as usize;
        props.accept(&["pixel_format", "component_format", "file_format", "banner"]);
        if props.bool("sample_border", false)? {
            self.diag.warn(
                el.at(),
                "sample_border = true is not supported: lumo keeps a pixel filter's samples on \
                 the image, as Mitsuba's default does (edge pixels may differ slightly)",
            )?;
        }
        for (i, c) in props.nested() {
            let c = self.resolve(c)?;
            if c.tag == "rfilter" {
                props.mark(i);
                let f = Props::new(c);
                self.scene.camera.filter = match f.kind() {
                    "box" => PixelFilter::Box,
                    "tent" => PixelFilter::Tent {
                        radius: positive(&f, "radius", 1.0)?,
                    },
                    "gaussian" => PixelFilter::Gaussian {
                        stddev: positive(&f, "stddev", 0.5)?,
                    },
                    other => {
                        self.diag.warn(
                            c.at(),
                            format!(
                                "rfilter {other:?} is not supported (lumo has box, tent and \
                                 gaussian); using the box filter (same mean, a different \
                                 sharpness)"
                            ),
                        )?;
                        f.accept(&["stddev", "radius", "b", "c", "lobes"]);
                        PixelFilter::Box
                    }
                };
                f.finish(self.diag)?;
            }
        }
        props.finish(self.diag)
    }

    /// `<integrator>`: depth settings.
    pub(super) fn integrator(&mut self, el: &'a Element) -> Result<(), LoadError> {
        // Nesting-guarded: an `aov` integrator may <ref> itself.
        self.nested(el, |b| b.convert_integrator(el))
    }

    fn convert_integrator(&mut self, el: &'a Element) -> Result<(), LoadError> {
        let props = Props::new(el);
        let at = el.at();
        match props.kind() {
            "path" | "volpath" | "volpathmis" | "prb" => {}
            "direct" => {
                // Direct illumination is a path of at most two segments.
                self.settings.max_depth = Some(2);
                self.scene.defaults.max_depth = 2;
                // lumo's path takes one light and one BSDF sample per vertex: the same
                // expected image as any counts, with other noise.
                for name in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                    if props.has(name) {
                        let n = props.int(name, 1)?;
                        if n != 1 {
                            self.diag.warn(
                                at.clone(),
                                format!(
                                    "direct {name} {n}: lumo takes one light and one BSDF \
                                     sample per pixel sample (the same expected image, with \
                                     other noise); raise the samples per pixel instead"
                                ),
                            )?;
                        }
                    }
                }
                return props.finish(self.diag);
            }
            "aov" | "moment" => {
                for (i, c) in props.nested() {
                    let c = self.resolve(c)?;
                    if c.tag == "integrator" {
                        props.mark(i);
                        self.integrator(c)?;
                    }
                }
                props.accept(&["aovs"]);
                return props.finish(self.diag);
            }
            other => self.diag.warn(
                at.clone(),
                format!("integrator {other:?} is not supported; lumo renders with its path tracer"),
            )?,
        }
        let max_depth = props.int("max_depth", -1)?;
        let rr_depth = props.int("rr_depth", 5)?;
        let max_depth = match max_depth {
            -1 => UNBOUNDED_DEPTH,
            d if d >= 1 && d <= UNBOUNDED_DEPTH as i64 => d as u32,
            d => {
                return Err(LoadError::invalid(
                    at,
                    format!("max_depth {d} must be -1 (unbounded) or 1..={UNBOUNDED_DEPTH}"),
                ))
            }
        };
        if !(1..=UNBOUNDED_DEPTH as i64).contains(&rr_depth) {
            return Err(LoadError::invalid(
                at,
                format!("rr_depth {rr_depth} must be 1..={UNBOUNDED_DEPTH}"),
            ));
        }
        self.settings.max_depth = Some(max_depth);
        self.settings.rr_depth = Some(rr_depth as u32);
        self.scene.defaults.max_depth = max_depth;
        if props.bool("hide_emitters", false)? {
            self.diag.warn(
                at,
                "hide_emitters is not supported; emitters seen directly are rendered",
            )?;
        }
        props.finish(self.diag)
    }

    /// `<shape>`: one or more meshes with the shape's material, placed once; a `shapegroup`
    /// (meshes without placement) or an `instance` (placements of a group's meshes).
    pub(super) fn shape(&mut self, el: &'a Element) -> Result<(), LoadError> {
        match el.attr("type") {
            Some("shapegroup") => self.shapegroup(el).map(drop),
            Some("instance") => self.instance(el),
            _ => {
                if let Some(mesh) = self.shape_mesh(el)? {
                    self.scene.add_mesh(mesh);
                }
                Ok(())
            }
        }
    }

    /// A `shapegroup`'s meshes (converted once, on first use): each nested shape becomes a
    /// mesh in the group's space, placed only by the `instance`s that refer to the group.
    fn shapegroup(&mut self, el: &'a Element) -> Result<Vec<usize>, LoadError> {
        let key = el as *const Element as usize;
        if let Some(meshes) = self.groups.get(&key) {
            return Ok(meshes.clone());
        }
        let props = Props::new(el);
        let mut meshes = Vec::new();
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag != "shape" {
                continue;
            }
            props.mark(i);
            if let Some(kind @ ("shapegroup" | "instance")) = r.attr("type") {
                // As Mitsuba: instancing does not nest.
                return Err(LoadError::invalid(
                    r.at(),
                    format!("a {kind} inside a shapegroup; instancing does not nest"),
                ));
            }
            if let Some(mesh) = self.shape_mesh(r)? {
                self.scene.meshes.push(mesh);
                meshes.push(self.scene.meshes.len() - 1);
            }
        }
        props.finish(self.diag)?;
        self.groups.insert(key, meshes.clone());
        Ok(meshes)
    }

    /// An `instance`: one lumo instance per mesh of the referenced shapegroup, each placed by
    /// the instance's `to_world` (the meshes themselves are shared, not copied).
    fn instance(&mut self, el: &'a Element) -> Result<(), LoadError> {
        let props = Props::new(el);
        let at = el.at();
        let to_world = props.transform("to_world")?;
        let mut group = None;
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            if r.tag == "shape" {
                props.mark(i);
                if r.attr("type") != Some("shapegroup") {
                    return Err(LoadError::invalid(
                        r.at(),
                        format!("an instance refers to {}; only a shapegroup", r.describe()),
                    ));
                }
                if group.is_some() {
                    return Err(LoadError::invalid(
                        at,
                        "an instance refers to more than one shapegroup",
                    ));
                }
                group = Some(r);
            }
        }
        let group = group.ok_or_else(|| {
            LoadError::invalid(
                at.clone(),
                "an instance needs a <ref id=\"...\"/> to a shapegroup",
            )
        })?;
        if !to_world.is_finite() || to_world.determinant() == 0.0 {
            return Err(LoadError::invalid(
                at,
                "the instance's to_world is singular or not finite",
            ));
        }
        props.finish(self.diag)?;
        for mesh in self.shapegroup(group)? {
            self.scene.instances.push(Instance {
                mesh,
                transform: to_world,
            });
        }
        Ok(())
    }

    /// The mesh of a single (non-group) `<shape>` in the space its `to_world` maps to; `None`
    /// (with a warning) for shape types lumo does not support.
    fn shape_mesh(&mut self, el: &'a Element) -> Result<Option<Mesh>, LoadError> {
        let props = Props::new(el);
        let at = el.at();
        let kind = props.kind();
        let to_world = props.transform("to_world")?;
        let mut bsdf = None;
        let (mut emission, mut emission_map) = (Vec3::ZERO, None);
        for (i, c) in props.nested() {
            let r = self.resolve(c)?;
            match r.tag.as_str() {
                "bsdf" => {
                    props.mark(i);
                    // Mitsuba refuses this too: which one was meant is ambiguous.
                    if bsdf.is_some() {
                        return Err(LoadError::invalid(
                            c.at(),
                            "a second <bsdf> in one <shape>; a shape has one BSDF (keep one, \
                             or nest them in a blend or two-sided BSDF)",
                        ));
                    }
                    bsdf = Some(r);
                }
                "emitter" => {
                    props.mark(i);
                    (emission, emission_map) = self.area_emitter(r)?;
                }
                _ => {}
            }
        }
        if emission_map.is_some() && matches!(kind, "sphere" | "disk" | "cylinder") {
            emission_map = None;
            self.diag.warn(
                at.clone(),
                format!(
                    "a texture as the radiance of an area light on a {kind} is not supported \
                     (only on meshes, rectangles and cubes); using its average {emission}"
                ),
            )?;
        }
        // A null BSDF is an invisible boundary (medium.rs); its material is never shaded.
        let shaded_bsdf = bsdf.filter(|b| b.attr("type") != Some("null"));
        let material = self.material(shaded_bsdf, emission, emission_map)?;
        let mut mesh = match kind {
            "rectangle" => shapes::rectangle(&to_world, material),
            "cube" => shapes::cube(&to_world, material),
            "disk" => analytic(
                self.proxy(
                    ROUND_SEGMENTS as usize,
                    || shapes::disk(&to_world, material, ROUND_SEGMENTS),
                    || shapes::rectangle(&to_world, material),
                ),
                AnalyticKind::Disk,
                to_world,
            ),
            "sphere" => {
                let center = props.vec3("center")?.unwrap_or(Vec3::ZERO);
                let radius = props.float("radius", 1.0)?;
                if radius <= 0.0 {
                    return Err(LoadError::invalid(
                        at,
                        format!("sphere radius {radius}: use a radius > 0"),
                    ));
                }
                // lumo's UV sphere has its poles on y; Mitsuba's on local z, with u = φ/2π
                // around z. Turning y onto z makes u, and so the tangent dp/du that orients
                // anisotropic roughness, Mitsuba's.
                // The renderer intersects the exact sphere; the tessellation is its proxy.
                let placed = to_world
                    * Mat4::from_translation(center)
                    * Mat4::from_scale(Vec3::splat(radius));
                let m = placed * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
                let full = (2 * SPHERE_RINGS * SPHERE_SEGMENTS - 2 * SPHERE_SEGMENTS) as usize;
                analytic(
                    self.proxy(
                        full,
                        || shapes::sphere(&m, material, SPHERE_RINGS, SPHERE_SEGMENTS),
                        || shapes::cube(&m, material),
                    ),
                    AnalyticKind::Sphere,
                    placed,
                )
            }
            "cylinder" => {
                let p0 = props.vec3("p0")?.unwrap_or(Vec3::ZERO);
                let p1 = props.vec3("p1")?.unwrap_or(Vec3::Z);
                let radius = props.float("radius", 1.0)?;
                let axis = p1 - p0;
                let len = axis.length();
                if len == 0.0 || radius <= 0.0 {
                    return Err(LoadError::invalid(
                        at,
                        "cylinder needs p0 != p1 and radius > 0",
                    ));
                }
                let rot = glam::Quat::from_rotation_arc(Vec3::Z, axis / len);
                let m = to_world
                    * Mat4::from_translation(p0)
                    * Mat4::from_quat(rot)
                    * Mat4::from_scale(Vec3::new(radius, radius, len));
                let bounds = m
                    * Mat4::from_translation(Vec3::new(0.0, 0.0, 0.5))
                    * Mat4::from_scale(Vec3::new(1.0, 1.0, 0.5));
                analytic(
                    self.proxy(
                        2 * ROUND_SEGMENTS as usize,
                        || shapes::cylinder(&m, material, ROUND_SEGMENTS),
                        || shapes::cube(&bounds, material),
                    ),
                    AnalyticKind::Cylinder,
                    m,
                )
            }
            "obj" | "ply" => {
                let file = props.string("filename")?.ok_or_else(|| {
                    LoadError::invalid(at.clone(), format!("{kind} shape needs a filename"))
                })?;
                let path = self.file_path(el, &file)?;
                // A mesh file that cannot be read is named at the element that names it (its
                // own errors name the mesh file and its line instead).
                let at_shape = |e: LoadError| match e {
                    LoadError::Io { path, error } => LoadError::invalid(
                        at.clone(),
                        format!(
                            "cannot read mesh file {}: {}",
                            path.display(),
                            lumo_image::describe_io_error(&error)
                        ),
                    ),
                    e => e,
                };
                let mut mesh = if kind == "obj" {
                    let (meshes, _) = obj::read(&path, self.diag).map_err(at_shape)?;
                    let mut all = Mesh::default();
                    for m in &meshes {
                        all.append(m);
                    }
                    // Mitsuba flips OBJ v by default (flip_tex_coords = true).
                    if props.bool("flip_tex_coords", true)? {
                        for uv in &mut all.uvs {
                            uv.y = 1.0 - uv.y;
                        }
                    }
                    all
                } else {
                    let mut mesh = ply::read(&path, self.diag).map_err(at_shape)?;
                    // Mitsuba uses vertex colours only through a mesh_attribute texture.
                    mesh.colors.clear();
                    mesh
                };
                mesh.material = material;
                mesh.transformed(&to_world)
            }
            "" => {
                return Err(LoadError::invalid(
                    at,
                    "<shape> has no type attribute; give one, e.g. type=\"obj\", \"ply\", \
                     \"rectangle\" or \"sphere\"",
                ))
            }
            other => {
                self.diag.warn(
                    at,
                    format!("shape type {other:?} is not supported by lumo; the shape is skipped"),
                )?;
                return Ok(None);
            }
        };
        if props.bool("face_normals", false)? {
            mesh.normals.clear();
        }
        if props.bool("flip_normals", false)? {
            if let Some(a) = &mut mesh.analytic {
                a.flip_normals = true;
            }
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
            for n in &mut mesh.normals {
                *n = -*n;
            }
        }
        mesh.name = el.attr("id").unwrap_or(kind).to_string();
        if let Some(a) = &mesh.analytic {
            if !a.to_mesh.is_finite() || a.to_mesh.determinant() == 0.0 {
                return Err(LoadError::invalid(
                    at,
                    format!(
                        "{kind}: its to_world is singular (a zero scale?) or not finite; an \
                         exact {kind} needs a non-zero size on every axis (to hide the shape, \
                         remove it)"
                    ),
                ));
            }
        }
        check_mesh(&mut mesh, &at, self.diag)?;
        self.shape_boundary(&props, bsdf, emission != Vec3::ZERO)?;
        props.finish(self.diag)?;
        Ok(Some(mesh))
    }

    /// A nested `area` emitter: its radiance, and its texture where it is one (the radiance is
    /// then the texture's average).
    fn area_emitter(&mut self, el: &'a Element) -> Result<(Vec3, Option<Arc<Texture>>), LoadError> {
        let props = Props::new(el);
        if props.kind() != "area" {
            return Err(LoadError::invalid(
                el.at(),
                format!(
                    "emitter {:?} inside a shape; only area emitters attach to shapes",
                    props.kind()
                ),
            ));
        }
        self.emission_spectrum = props.tabulated("radiance")?.map(Arc::new);
        let radiance = self.texture_param(&props, "radiance", Vec3::ONE)?;
        props.finish(self.diag)?;
        let (mean, texture) = match radiance {
            Texture::Constant(c) => (c, None),
            t => (t.average(), Some(Arc::new(t))),
        };
        Ok((check_emission(&el.at(), "radiance", mean)?, texture))
    }

    /// A top-level `<emitter>`.
    pub(super) fn emitter(&mut self, el: &'a Element) -> Result<(), LoadError> {
        let props = Props::new(el);
        let at = el.at();
        let to_world = props.transform("to_world")?;
        let light = match props.kind() {
            "point" => {
                let position = props
                    .vec3("position")?
                    .unwrap_or_else(|| to_world.transform_point3(Vec3::ZERO));
                Light::Point {
                    position,
                    intensity: self.color_param(&props, "intensity", Vec3::ONE)?,
                    // Mitsuba's lights have no range: the inverse-square law to any distance.
                    range: None,
                }
            }
            "spot" => {
                let cutoff = props.float("cutoff_angle", 20.0)?;
                if !(cutoff > 0.0 && cutoff <= 180.0) {
                    return Err(LoadError::invalid(
                        at,
                        format!(
                            "spot cutoff_angle {cutoff}: the cone's half-angle must be above 0 \
                             and at most 180 degrees"
                        ),
                    ));
                }
                let beam_width = props.float("beam_width", cutoff * 0.75)?;
                if beam_width < 0.0 {
                    return Err(LoadError::invalid(
                        at,
                        format!("spot beam_width {beam_width}: an angle cannot be negative"),
                    ));
                }
                let direction = to_world
                    .transform_vector3(Vec3::Z)
                    .try_normalize()
                    .ok_or_else(|| {
                        LoadError::invalid(
                            at.clone(),
                            "spot emitter: its to_world maps the z axis (the cone's axis) to \
                             zero; the transform is singular (a zero scale?)",
                        )
                    })?;
                Light::Spot {
                    position: to_world.transform_point3(Vec3::ZERO),
                    direction,
                    intensity: self.color_param(&props, "intensity", Vec3::ONE)?,
                    beam_width,
                    cutoff,
                    falloff: crate::SpotFalloff::LinearAngle,
                    range: None,
                }
            }
            "directional" => {
                let direction = props
                    .vec3("direction")?
                    .unwrap_or_else(|| to_world.transform_vector3(Vec3::Z));
                let direction = direction.try_normalize().ok_or_else(|| {
                    LoadError::invalid(at.clone(), "directional emitter needs a non-zero direction")
                })?;
                Light::Directional {
                    direction,
                    irradiance: self.color_param(&props, "irradiance", Vec3::ONE)?,
                }
            }
            "constant" => Light::Constant {
                radiance: self.color_param(&props, "radiance", Vec3::ONE)?,
            },
            "envmap" => {
                let file = props
                    .string("filename")?
                    .ok_or_else(|| LoadError::invalid(at.clone(), "envmap needs a filename"))?;
                let path = self.file_path(el, &file)?;
                let image = self.images.load(&path, false, &at)?;
                if self.has_environment {
                    self.diag
                        .warn(at.clone(), "more than one envmap; lumo keeps the last one")?;
                }
                self.has_environment = true;
                props.accept(&["filter_type", "mis_compensation"]);
                let scale = props.float("scale", 1.0)?;
                if scale < 0.0 {
                    return Err(LoadError::invalid(
                        at,
                        format!(
                            "envmap scale {scale}: an environment cannot emit negative light; \
                             use a scale ≥ 0"
                        ),
                    ));
                }
                if scale == 0.0 {
                    self.diag
                        .warn(at.clone(), "envmap scale 0: the environment emits nothing")?;
                }
                Light::Environment(EnvMap {
                    image: Arc::clone(&image),
                    scale,
                    to_world,
                })
            }
            "area" => {
                return Err(LoadError::invalid(
                    at,
                    "an area emitter must be nested in the <shape> that emits",
                ))
            }
            other => {
                return self.diag.warn(
                    at,
                    format!("emitter type {other:?} is not supported by lumo and was ignored"),
                )
            }
        };
        props.accept(&["sampling_weight"]);
        props.finish(self.diag)?;
        let light = check_light(&at, None, light)?;
        self.scene.lights.push(light);
        Ok(())
    }
}

/// (origin, target, up) of a transform made of exactly one `<lookat>`.
fn single_lookat(el: &Element) -> Option<(Vec3, Vec3, Vec3)> {
    let [op] = el.children.as_slice() else {
        return None;
    };
    if op.tag != "lookat" {
        return None;
    }
    let get = |k: &str| -> Option<Vec3> {
        let v = super::props::parse_list(op, op.attr(k)?).ok()?;
        (v.len() == 3).then(|| Vec3::new(v[0], v[1], v[2]))
    };
    Some((get("origin")?, get("target")?, get("up").unwrap_or(Vec3::Y)))
}

impl Builder<'_, '_> {
    /// An exact shape's proxy: `fine()`, its tessellation of `triangles` triangles, while the
    /// file's proxies stay within [`PROXY_TRIANGLE_BUDGET`], else `coarse()`, its bounding box
    /// or square. The renderer intersects the exact shape either way.
    fn proxy(
        &mut self,
        triangles: usize,
        fine: impl FnOnce() -> Mesh,
        coarse: impl FnOnce() -> Mesh,
    ) -> Mesh {
        let mesh = if self.proxy_triangles + triangles <= PROXY_TRIANGLE_BUDGET {
            fine()
        } else {
            coarse()
        };
        self.proxy_triangles += mesh.indices.len();
        mesh
    }
}

/// `mesh` (the tessellated proxy) marked as the exact shape `kind` placed by `to_mesh`.
fn analytic(mut mesh: Mesh, kind: AnalyticKind, to_mesh: Mat4) -> Mesh {
    mesh.analytic = Some(Analytic {
        kind,
        to_mesh,
        flip_normals: false,
    });
    mesh
}

/// A filter size parameter: finite and > 0 (Mitsuba's `radius` / `stddev`, in pixels).
fn positive(props: &Props<'_>, name: &str, default: f32) -> Result<f32, LoadError> {
    let v = props.float(name, default)?;
    if v.is_finite() && v > 0.0 && v <= 64.0 {
        Ok(v)
    } else {
        Err(LoadError::invalid(
            props.el.at(),
            format!(
                "rfilter {:?}: {name} {v} is not a size in pixels; use a value in (0, 64] (default {default})",
                props.kind()
            ),
        ))
    }
}
