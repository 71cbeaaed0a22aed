//! The vertices of camera and light subpaths and the densities between them.
//!
//! Every vertex keeps two densities in the measure of its own position (area; solid angle
//! for a camera path that escaped to the environment): `pdf_fwd`, with which its own subpath
//! generated it from the vertex before, and `pdf_rev`, with which the opposite subpath would
//! have generated it from the vertex after. Their ratios are all the multiple importance
//! weights need ([`super::mis`]). A density through a Dirac lobe is stored as 1: it
//! appears once as a forward and once as a reverse density in every ratio chain that passes
//! the specular vertex, so the placeholders cancel (strategies that would have to connect at
//! such a vertex are excluded by the `delta` flags instead).

use glam::{Vec2, Vec3};
use lumo_scene::PhaseFunction;

use crate::bsdf::BsdfSample;
use crate::camera::PinholeCamera;
use crate::geometry::{cosine_hemisphere_pdf, cosine_pdf, max3_abs, square_to_cosine_hemisphere};
use crate::lights::{EmissionPdf, Lights};
use crate::media::phase;
use crate::render_scene::{RenderScene, Surface};
use crate::shading::ShadingBsdf;

/// What a vertex is.
// Most vertices are surfaces and live in reused buffers ([`super::BdptScratch`]); boxing the
// large variant would allocate per vertex.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub(super) enum Kind {
    /// The pinhole: the camera subpath's first vertex.
    Camera,
    /// A light subpath's first vertex, or a light point chosen by next-event estimation.
    Light {
        /// Index of the light ([`Lights::emission_pdf_of`]).
        light: u32,
        /// A point or spot light (its position is a Dirac delta).
        delta_position: bool,
        /// A directional light (its direction is a Dirac delta; the vertex sits on a
        /// scene-sized disk outside the scene).
        directional: bool,
    },
    /// A camera ray that left the scene: the environment seen in direction `dir`.
    Environment {
        /// Unit direction of the escaping ray.
        dir: Vec3,
    },
    /// A scattering point on a surface.
    Surface {
        /// The surface. Its texture coordinates are left zero on the Lambertian vertices
        /// that the lane walk makes ([`super::diffuse_walk`]): the reflectance, the only
        /// texture such a vertex has, is already in `lambert`, and nothing else reads them.
        s: Surface,
        /// Its BSDF.
        bsdf: ShadingBsdf,
        /// The unit direction back towards the previous vertex of its own subpath (the
        /// reverse of the ray that found it) in the shading frame.
        wo_local: Vec3,
        /// `|ng·wo|` of that direction `wo` (world), the arrival cosine that the light side of a connection divides out.
        cos_ng_wo: f32,
        /// [`Vertex::w_prev`] in the shading frame (only `z` for a Lambertian vertex).
        wp_local: Vec3,
        /// The reflectance of a plain Lambertian BSDF ([`ShadingBsdf::lambert`]): its value
        /// and density come from two cosines, without the general BSDF code.
        lambert: Option<Vec3>,
        /// A one-sided material seen from behind: black both ways, no connections.
        black: bool,
    },
    /// A real scattering in a participating medium (scenes with media, [`super::volume`]):
    /// the phase function is its "BSDF", and it has no normal, so no cosine enters its
    /// densities or its value.
    Medium {
        /// The medium's phase function.
        phase: PhaseFunction,
    },
}

/// One vertex of a subpath.
// The scalar fields that the weights and the lane loops read come first and the large `kind`
// last (`repr(C)` keeps that order): a group's subpaths outgrow the L1 cache, and with the
// default layout a weight's few reads touched more lines (1.5 % of a `cornell` sample).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct Vertex {
    /// Position (the light's position for point and spot lights; unused for the environment).
    pub p: Vec3,
    /// Unit geometric normal of surfaces and area lights (zero for the others).
    pub ng: Vec3,
    /// Throughput of the subpath up to (not including) this vertex's own scattering: for a
    /// camera subpath the radiance weight, for a light subpath the particle's power weight.
    pub beta: Vec3,
    /// Emitted radiance towards the previous vertex (camera subpaths: surfaces that emit and
    /// the environment; the light's radiance for an area light's own vertex).
    pub le: Vec3,
    /// Density with which its own subpath generated it.
    pub pdf_fwd: f32,
    /// Density with which the opposite subpath would generate it.
    pub pdf_rev: f32,
    /// Its own subpath left it through a Dirac lobe.
    pub delta: bool,
    /// What the strategies that move the connection two or more vertices back along this
    /// vertex's subpath add to a weight, per unit of the running density product there: the
    /// sum over the vertices `i ≤` this one that may start a strategy (no Dirac lobe next to
    /// them) of `Π (pdf_rev / pdf_fwd)²` from `i` to this one. Summed once per subpath
    /// ([`super::mis::set_camera_ratios`]), so that a weight is O(1) instead of a loop down
    /// both subpaths.
    pub tail: f32,
    /// Scene vertices: the unit direction towards the previous vertex of its own subpath and
    /// the squared distance to it, exactly as [`Vertex::towards`] computes them (the weights
    /// need them for every strategy that ends here; zero for subpath origins).
    pub w_prev: Vec3,
    /// See `w_prev`.
    pub d2_prev: f32,
    /// Random numbers for next-event estimation from this vertex (camera subpaths), drawn
    /// with the vertex so that the sample stream does not depend on which strategies run.
    pub u_light: (f32, Vec2),
    /// `ray_epsilon · (1 + max |p_i|)`: how far a ray origin moves off this vertex along its
    /// geometric normal ([`crate::geometry::offset_point`]'s scale, computed once per vertex
    /// instead of once per strategy; [`Vertex::new`] leaves it 0, [`Vertex::set_offset`]).
    pub off_scale: f32,
    /// In scenes with media, the medium its own subpath's ray reached it through (the medium
    /// of a medium vertex; the camera's, or the one around the light, at subpath origins);
    /// `None` elsewhere. A connection leaving a surface without an interface starts in it.
    pub medium: Option<u32>,
    /// What it is.
    pub kind: Kind,
}

impl Vertex {
    /// A vertex with no densities yet.
    pub fn new(kind: Kind, p: Vec3, ng: Vec3, beta: Vec3) -> Self {
        Vertex {
            kind,
            p,
            ng,
            beta,
            le: Vec3::ZERO,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            tail: 0.0,
            w_prev: Vec3::ZERO,
            d2_prev: 0.0,
            u_light: (0.0, Vec2::ZERO),
            off_scale: 0.0,
            medium: None,
        }
    }

    /// Sets [`Vertex::off_scale`] for ray epsilon `eps`, the operations of
    /// [`crate::geometry::offset_point`] (so its offsets are the same bits).
    #[inline]
    pub fn set_offset(&mut self, eps: f32) {
        self.off_scale = eps * (1.0 + max3_abs(self.p.into()));
    }

    /// A ray origin just off this vertex on the side of `w`: [`crate::geometry::offset_point`]
    /// with the cached scale (`side · eps · (1 + m)` with `side = ±1` is `±(eps · (1 + m))`
    /// exactly), the vertex itself where it has no normal.
    #[inline]
    pub fn origin_off(&self, w: Vec3) -> Vec3 {
        if !matches!(self.kind, Kind::Surface { .. }) && self.ng == Vec3::ZERO {
            return self.p;
        }
        let (p, ng) = (self.p, self.ng);
        let along = (ng.x * w.x) + (ng.y * w.y) + (ng.z * w.z);
        let k = if along >= 0.0 {
            self.off_scale
        } else {
            -self.off_scale
        };
        Vec3::new(p.x + ng.x * k, p.y + ng.y * k, p.z + ng.z * k)
    }

    /// Whether a strategy may connect to this vertex with a deterministic segment: surfaces
    /// with a non-Dirac lobe, area lights, point and spot lights, the camera.
    pub fn is_connectible(&self) -> bool {
        // By reference: binding the surface's BSDF by value copies it.
        match &self.kind {
            Kind::Camera => true,
            Kind::Light { directional, .. } => !directional,
            Kind::Environment { .. } => false,
            Kind::Surface { bsdf, black, .. } => !black && !bsdf.is_delta(),
            Kind::Medium { .. } => true,
        }
    }

    /// A light whose position or direction is a Dirac delta (no camera path can hit it).
    pub fn is_delta_light(&self) -> bool {
        match self.kind {
            Kind::Light {
                delta_position,
                directional,
                ..
            } => delta_position || directional,
            _ => false,
        }
    }

    /// The cosine that turns a solid-angle density arriving along `w` into an area density
    /// here: the geometric normal's for surfaces and area lights, 1 for points.
    fn arrival_cos(&self, w: Vec3) -> f32 {
        if self.ng == Vec3::ZERO {
            1.0
        } else {
            self.ng.dot(w).abs()
        }
    }

    /// Makes `prev` the vertex before this scene vertex on its subpath (the tests turn a
    /// camera subpath around into a light subpath): the cached direction and distance, and
    /// the direction it arrived from.
    #[cfg(test)]
    pub fn set_previous(&mut self, prev: &Vertex) {
        let (w, d2) = self.towards(prev);
        (self.w_prev, self.d2_prev) = (w, d2);
        if let Kind::Surface {
            s,
            wo_local,
            cos_ng_wo,
            wp_local,
            lambert,
            ..
        } = &mut self.kind
        {
            *wo_local = s.frame.to_local(w);
            *cos_ng_wo = s.ng.dot(w).abs();
            *wp_local = surface_local(s, lambert.is_some(), w);
        }
    }

    /// The unit direction from `self` to `to` (the environment's own direction) and the
    /// squared distance between them (1 for the environment; zero direction for coincident
    /// points).
    #[inline]
    pub fn towards(&self, to: &Vertex) -> (Vec3, f32) {
        if let Kind::Environment { dir } = to.kind {
            return (dir, 1.0);
        }
        let d = to.p - self.p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        (d / dist2.sqrt(), dist2)
    }

    /// Density (in `to`'s measure) with which `self`, reached from `prev` in its own
    /// subpath, would generate `to` next. Subpath origins take `prev = None`. (The weights
    /// use [`Vertex::pdf_along`], sharing the directions; the tests use this form.)
    #[cfg(test)]
    pub fn pdf(&self, ctx: &Context, prev: Option<&Vertex>, to: &Vertex) -> f32 {
        let w_prev = prev.map(|prev| self.towards(prev).0);
        let (w, dist2) = self.towards(to);
        self.pdf_along(ctx, w_prev, to, w, dist2)
    }

    /// [`Vertex::pdf`] with the geometry already known: `w_prev` the unit direction towards
    /// the previous vertex, `(w, dist2)` what [`Vertex::towards`] returns for `to`.
    pub fn pdf_along(
        &self,
        ctx: &Context,
        w_prev: Option<Vec3>,
        to: &Vertex,
        w: Vec3,
        dist2: f32,
    ) -> f32 {
        match self.kind {
            Kind::Camera => area_density_along(ctx.camera.direction_pdf(w), to, w, dist2),
            Kind::Light {
                light, directional, ..
            } => {
                if let Kind::Environment { .. } = to.kind {
                    return 0.0;
                }
                if directional {
                    // Parallel rays from a disk of the scene's size: the density on the disk
                    // (the choice of the light is the light vertex's own density).
                    let r = ctx.rs.lights.scene_radius();
                    return to.arrival_cos(w) / (std::f32::consts::PI * r * r);
                }
                ctx.rs
                    .lights
                    .emission_pdf_of(light, self.ng, w)
                    .map_or(0.0, |e| area_density_along(e.solid_angle, to, w, dist2))
            }
            // Light does not leave the environment towards the scene (it emits no particles).
            Kind::Environment { .. } => 0.0,
            Kind::Surface {
                ref s, ref bsdf, ..
            } => {
                let Some(w_prev) = w_prev else { return 0.0 };
                let pdf = bsdf.pdf(s.frame.to_local(w_prev), s.frame.to_local(w));
                area_density_along(pdf, to, w, dist2)
            }
            Kind::Medium { phase } => {
                let Some(w_prev) = w_prev else { return 0.0 };
                // Travelling away from `w_prev`, scattered into `w`.
                area_density_along(phase::eval(phase, -w_prev, w), to, w, dist2)
            }
        }
    }

    /// Unit direction `w` (world) in this surface vertex's shading frame, only `z` (the
    /// cosine to the shading normal, the same bits) for a Lambertian vertex; zero for the
    /// other kinds.
    #[inline]
    pub fn local(&self, w: Vec3) -> Vec3 {
        match self.kind {
            Kind::Surface { ref s, lambert, .. } => surface_local(s, lambert.is_some(), w),
            _ => Vec3::ZERO,
        }
    }

    /// [`Vertex::pdf_along`] with its own subpath's previous vertex as the one it was reached
    /// from (the cached direction): the density of generating `to` along `(w, dist2)`, with
    /// `w_local` = [`Vertex::local`]`(w)`.
    #[inline(always)]
    pub fn pdf_onward(
        &self,
        ctx: &Context,
        to: &Vertex,
        w: Vec3,
        w_local: Vec3,
        dist2: f32,
    ) -> f32 {
        match self.kind {
            Kind::Surface {
                ref bsdf,
                wp_local,
                lambert,
                ..
            } => area_density_along(bsdf_pdf(bsdf, lambert, wp_local, w_local), to, w, dist2),
            Kind::Medium { .. } => self.pdf_along(ctx, Some(self.w_prev), to, w, dist2),
            _ => self.pdf_along(ctx, None, to, w, dist2),
        }
    }

    /// [`Vertex::pdf_along`] the other way along its own subpath: the density with which this
    /// vertex, reached along `w_in` (unit, towards the vertex it is joined to; `w_in_local`
    /// its [`Vertex::local`]), generates its own subpath's previous vertex `prev`.
    #[inline(always)]
    pub fn pdf_back(&self, ctx: &Context, w_in: Vec3, w_in_local: Vec3, prev: &Vertex) -> f32 {
        match self.kind {
            Kind::Surface {
                ref bsdf,
                wp_local,
                lambert,
                ..
            } => area_density_along(
                bsdf_pdf(bsdf, lambert, w_in_local, wp_local),
                prev,
                self.w_prev,
                self.d2_prev,
            ),
            _ => self.pdf_along(ctx, Some(w_in), prev, self.w_prev, self.d2_prev),
        }
    }

    /// This vertex of a camera subpath seen as the origin of a light subpath towards `to`:
    /// the density with which the light subpath would start here (area; next-event
    /// estimation's solid-angle density for the environment, the only strategy that samples
    /// it) and with which it would then generate `to` (in `to`'s measure; 0 from the
    /// environment, which emits no particles).
    /// `to` must be the vertex before it on its subpath (its cached direction is used).
    pub fn as_light_origin(&self, ctx: &Context, to: &Vertex) -> (f32, f32) {
        match self.kind {
            Kind::Environment { dir } => (ctx.rs.lights.environment_pdf(dir), 0.0),
            Kind::Surface { ref s, .. } => {
                let w = (to.p - self.p).normalize_or_zero();
                ctx.rs
                    .lights
                    .emission_pdf(s.instance, s.triangle, s.ng, w)
                    .map_or((0.0, 0.0), |e| {
                        let pdf = area_density_along(e.solid_angle, to, self.w_prev, self.d2_prev);
                        (e.area, pdf)
                    })
            }
            _ => (0.0, 0.0),
        }
    }

    /// What scattering at this vertex contributes to a connection towards `w` (world, unit):
    /// for a camera subpath's vertex `f(wo, w)·|cos_ns w|`; for a light subpath's vertex the
    /// adjoint `f(w, wl)` with Veach's shading-normal correction and the geometric cosine
    /// `|ng·w|`, so that both sides multiply into `value / distance²`; for a medium vertex
    /// its phase function, either way.
    #[inline]
    pub fn scatter_towards(&self, w: Vec3, light_side: bool) -> Vec3 {
        self.scatter_local(w, self.local(w), light_side)
    }

    /// [`Vertex::scatter_towards`] with `w_l` = [`Vertex::local`]`(w)` already computed (a
    /// connection reuses it for its weight's densities).
    #[inline]
    pub fn scatter_local(&self, w: Vec3, w_l: Vec3, light_side: bool) -> Vec3 {
        if let Kind::Medium { phase } = self.kind {
            // The phase function is symmetric in its two directions, and a medium vertex has
            // no cosine on either side.
            return Vec3::splat(phase::eval(phase, -self.w_prev, w));
        }
        // By reference: binding the surface and its BSDF by value copies them.
        let Kind::Surface {
            ref s,
            ref bsdf,
            wo_local: wo_l,
            lambert,
            black,
            cos_ng_wo,
            ..
        } = self.kind
        else {
            return Vec3::ZERO;
        };
        if black {
            return Vec3::ZERO;
        }
        let eval = |a: Vec3, b: Vec3| match lambert {
            Some(albedo) => lambert_eval(albedo, a.z, b.z),
            None => bsdf.eval(a, b),
        };
        if !light_side {
            return eval(wo_l, w_l);
        }
        // eval includes |cos| on the light side (wo here); divide it out, then apply the
        // arrival half of the correction (|ns·wl| / |ng·wl|) and the geometric cosine of the
        // departure.
        let cos_ng_w = s.ng.dot(w).abs();
        if wo_l.z == 0.0 || cos_ng_wo == 0.0 {
            return Vec3::ZERO;
        }
        eval(w_l, wo_l) / cos_ng_wo * cos_ng_w
    }
}

/// [`Vertex::local`] of a surface.
#[inline(always)]
pub(super) fn surface_local(s: &Surface, lambert: bool, w: Vec3) -> Vec3 {
    if lambert {
        Vec3::new(0.0, 0.0, w.dot(s.frame.n))
    } else {
        s.frame.to_local(w)
    }
}

/// The BSDF's density of `wi` given `wo` (local; only `z` read for a Lambertian one).
#[inline(always)]
pub(super) fn bsdf_pdf(bsdf: &ShadingBsdf, lambert: Option<Vec3>, wo: Vec3, wi: Vec3) -> f32 {
    match lambert {
        Some(_) => lambert_pdf(wo.z, wi.z),
        None => bsdf.pdf(wo, wi),
    }
}

/// A two-sided Lambertian BSDF's value `f·|cos θi|` from the cosines of `wo` and `wi`: the
/// same operations as [`crate::bsdf::Bsdf::eval`] (orientation, hemisphere test, cosine
/// density), so the same bits.
#[inline(always)]
fn lambert_eval(albedo: Vec3, zo: f32, zi: f32) -> Vec3 {
    let (zo, zi) = if zo < 0.0 { (-zo, -zi) } else { (zo, zi) };
    if zo <= 0.0 || zi <= 0.0 {
        return Vec3::ZERO;
    }
    albedo * cosine_pdf(zi)
}

/// [`crate::bsdf::Bsdf::sample`] of a two-sided Lambertian BSDF of reflectance `albedo`
/// (the same operations, without the dispatch over BSDF kinds).
#[inline(always)]
pub(super) fn lambert_sample(albedo: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    let flip = wo.z < 0.0;
    if wo.z == 0.0 {
        return None;
    }
    let wi = square_to_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi);
    let wi = if flip { -wi } else { wi };
    (albedo.is_finite() && pdf > 0.0).then_some(BsdfSample {
        wi,
        weight: albedo,
        pdf,
        delta: false,
        eta: 1.0,
    })
}

/// [`lambert_eval`]'s density ([`crate::bsdf::Bsdf::pdf`] of a diffuse BSDF).
#[inline(always)]
fn lambert_pdf(zo: f32, zi: f32) -> f32 {
    let (zo, zi) = if zo < 0.0 { (-zo, -zi) } else { (zo, zi) };
    if zo <= 0.0 {
        0.0
    } else {
        cosine_pdf(zi)
    }
}

/// A solid-angle density `pdf` along unit direction `w` as an area density at `to`, at squared
/// distance `dist2` (left as is for the environment, whose vertices live in solid angle).
#[inline]
pub(super) fn area_density_along(pdf: f32, to: &Vertex, w: Vec3, dist2: f32) -> f32 {
    if let Kind::Environment { .. } = to.kind {
        return pdf;
    }
    if dist2 == 0.0 {
        return 0.0;
    }
    pdf * to.arrival_cos(w) / dist2
}

/// What the densities need besides the vertices.
pub(super) struct Context<'a> {
    /// The scene (lights, materials).
    pub rs: &'a RenderScene,
    /// The camera (its direction density).
    pub camera: &'a PinholeCamera,
}

/// The light vertex that next-event estimation chose, in the form the weights need: its
/// density is the particle density of [`Lights::sample_emission`] (the environment's, which
/// emits no particles, next-event estimation's own), so every strategy of a path is weighed
/// with one consistent set of densities.
pub(super) fn light_vertex(
    lights: &Lights,
    light: u32,
    point: Vec3,
    normal: Vec3,
    towards: Vec3,
    environment: Option<Vec3>,
) -> Vertex {
    if let Some(dir) = environment {
        let mut v = Vertex::new(Kind::Environment { dir }, point, Vec3::ZERO, Vec3::ONE);
        v.pdf_fwd = lights.environment_pdf(dir);
        return v;
    }
    let e = lights.emission_pdf_of(light, normal, towards);
    let (delta_position, directional) =
        e.map_or((false, false), |e| (e.delta_position, e.delta_direction));
    let mut v = Vertex::new(
        Kind::Light {
            light,
            delta_position,
            directional,
        },
        point,
        normal,
        Vec3::ONE,
    );
    v.pdf_fwd = e.map_or(0.0, |e| light_origin_density(lights, &e));
    v
}

/// A light vertex's own density: the choice of the light and the point on it (area lights),
/// the choice alone for point, spot and directional lights — a directional light's point on
/// its disk belongs to the next vertex (see [`Vertex::pdf`]).
pub(super) fn light_origin_density(lights: &Lights, e: &EmissionPdf) -> f32 {
    if e.delta_direction {
        let r = lights.scene_radius();
        e.area * std::f32::consts::PI * r * r
    } else {
        e.area
    }
}
