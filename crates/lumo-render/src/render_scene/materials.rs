//! A hit's material as the integrators see it: the scene's BSDF description with textures
//! evaluated at the hit, Mitsuba's adapters applied (normal and bump maps, masks) and the
//! shading frame oriented by the surface's ∂p/∂u.

use glam::{Vec2, Vec3};
use lumo_scene::{BsdfSpec, Texture};

use super::branches::{hit_uniform, Pick};
use super::{RenderScene, Surface};
use crate::bsdf::{Bsdf, SpecHit};
use crate::geometry::Basis;
use crate::shading::ShadingBsdf;

impl RenderScene {
    /// Mitsuba's shading frame at `s`: the tangent is ∂p/∂u made perpendicular to the normal
    /// and the bitangent n × tangent, which orients anisotropic roughness (α_u along ∂p/∂u).
    /// Falls back to the normal-only frame where the uv map is degenerate.
    pub(super) fn tangent_frame(&self, s: &Surface) -> Basis {
        let n = s.frame.n;
        match self
            .dp_duv(s)
            .and_then(|(dp_du, _)| (dp_du - n * n.dot(dp_du)).try_normalize())
        {
            Some(t) => Basis {
                s: t,
                t: n.cross(t),
                n,
            },
            None => s.frame,
        }
    }

    /// The BSDF of `surface` with textures evaluated and Mitsuba's adapters (normal and bump
    /// maps, masks) applied.
    #[inline(always)]
    pub fn bsdf(&self, surface: &Surface) -> ShadingBsdf {
        if self.has_branches && self.branches[surface.material].is_some() {
            return self.branch_bsdf(surface);
        }
        let material = self.material(surface.material);
        let mut b = &material.bsdf;
        // Once for the normal map and the BSDF under it.
        let footprint = self.texture_footprint(surface);
        if !is_adapter(b) {
            return self.base_bsdf(b, surface, footprint).into();
        }
        let (mut normal, mut opacity) = (None, 1.0f32);
        // Adapters nest; masks multiply, and the outermost normal or bump map shapes the frame
        // (a map under another map is not composed with it).
        loop {
            b = match b {
                BsdfSpec::Mask {
                    opacity: t,
                    cutoff,
                    nested,
                } => {
                    let a = t.eval_1(surface.uv).clamp(0.0, 1.0) * self.vertex_alpha(surface);
                    opacity *= match cutoff {
                        Some(c) => f32::from(u8::from(a >= *c)),
                        None => a,
                    };
                    nested
                }
                BsdfSpec::NormalMap { normals, nested } => {
                    if normal.is_none() {
                        normal = Some(self.normal_mapped(surface, normals, footprint));
                    }
                    nested
                }
                BsdfSpec::BumpMap {
                    height,
                    scale,
                    nested,
                } => {
                    if normal.is_none() {
                        normal = Some(self.bump_mapped(surface, height, *scale));
                    }
                    nested
                }
                _ => break,
            };
        }
        ShadingBsdf::new(
            self.base_bsdf(b, surface, footprint),
            normal.flatten(),
            opacity,
            self.back_black[surface.material],
        )
    }

    /// Material `i`: the scene's, or past them a branch material of a two-branch one.
    #[inline]
    fn material(&self, i: usize) -> &lumo_scene::Material {
        match self.scene.materials.get(i) {
            Some(m) => m,
            None => &self.branch_materials[i - self.scene.materials.len()],
        }
    }

    /// [`RenderScene::bsdf`] of a two-branch material: the branch the hit picks (by the side
    /// the ray arrived from, or a blend's weight against a number drawn from the hit), shaded
    /// as a hit on that branch's material.
    #[inline(never)]
    fn branch_bsdf(&self, surface: &Surface) -> ShadingBsdf {
        let Some(b) = &self.branches[surface.material] else {
            return self.bsdf(surface);
        };
        let second = match &b.pick {
            Pick::Side => surface.back,
            Pick::Blend(weight) => {
                let w = weight.eval_1(surface.uv);
                let w = if w.is_finite() {
                    w.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                hit_uniform(surface) < w
            }
        };
        let mut s = *surface;
        s.material = if second { b.second } else { b.first };
        self.bsdf(&s)
    }

    /// World-space ∂p/∂u and ∂p/∂v of the triangle under `s` from its texture coordinates (as
    /// Mitsuba's meshes; lumo's barycentric uv where the mesh has none); `None` where the uv
    /// map is degenerate.
    pub(super) fn dp_duv(&self, s: &Surface) -> Option<(Vec3, Vec3)> {
        if let Some(shape) = self.shape(s.instance) {
            let sp = shape.surface_at(s.p);
            return Some((sp.dp_du, sp.dp_dv));
        }
        let inst = &self.scene.instances[s.instance as usize];
        let place = &self.placements[s.instance as usize];
        let mesh = &self.scene.meshes[inst.mesh];
        let idx = mesh.indices[s.triangle as usize].map(|i| i as usize);
        let [p0, p1, p2] = idx.map(|i| mesh.positions[i]);
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        let [t0, t1, t2] = mesh.triangle_uvs(s.triangle as usize);
        let (duv0, duv1) = (t1 - t0, t2 - t0);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dp_du = (dp0 * duv1.y - dp1 * duv0.y) / det;
        let dp_dv = (dp1 * duv0.x - dp0 * duv1.x) / det;
        Some(if place.identity {
            (dp_du, dp_dv)
        } else {
            (
                place.to_world.transform_vector3(dp_du),
                place.to_world.transform_vector3(dp_dv),
            )
        })
    }

    /// The shading normal a tangent-space normal map gives `s`, in its shading frame: the
    /// map's RGB in [0, 1] is (x, y, z) in [-1, 1] along the tangent (∂p/∂u made
    /// perpendicular to the normal), the bitangent n × tangent and the normal, as Mitsuba 3
    /// reads it. Where the mesh has tangents (glTF `TANGENT`) they replace ∂p/∂u, and their
    /// w (±1) turns the bitangent, as glTF defines. `None` for an exactly flat texel (no
    /// perturbation). A mip-mapped map is read over `footprint`: its averaged vectors,
    /// renormalised, as renderers with mip-maps read them.
    pub(super) fn normal_mapped(
        &self,
        s: &Surface,
        normals: &Texture,
        footprint: f32,
    ) -> Option<Vec3> {
        let c = normals.eval_at(s.uv, footprint) * 2.0 - Vec3::ONE;
        if c.x == 0.0 && c.y == 0.0 {
            return None;
        }
        let n = s.frame.n;
        let given = self.vertex_tangent(s).and_then(|t| {
            let v = t.truncate();
            (v - n * n.dot(v)).try_normalize().map(|v| (v, t.w))
        });
        let (tangent, hand) = match given {
            Some(t) => t,
            None => (
                self.dp_duv(s)
                    .and_then(|(dp_du, _)| (dp_du - n * n.dot(dp_du)).try_normalize())
                    .unwrap_or(s.frame.s),
                1.0,
            ),
        };
        let bitangent = n.cross(tangent) * hand;
        let world = (tangent * c.x + bitangent * c.y + n * c.z).try_normalize()?;
        s.frame.to_local(world).try_normalize()
    }

    /// The shading normal a height texture gives `s`, in its shading frame: the surface moved
    /// along its normal by `scale`·height, differentiated along u and v (Mitsuba 3's
    /// `bumpmap`), turned to the side of the geometric normal. `None` where the height is
    /// flat.
    pub(super) fn bump_mapped(&self, s: &Surface, height: &Texture, scale: f32) -> Option<Vec3> {
        let grad = height.eval_1_grad(s.uv) * scale;
        if grad == Vec2::ZERO {
            return None;
        }
        let (dp_du, dp_dv) = self.dp_duv(s)?;
        let n = s.frame.n;
        let du = dp_du + n * (grad.x - n.dot(dp_du));
        let dv = dp_dv + n * (grad.y - n.dot(dp_dv));
        let mut bumped = du.cross(dv).try_normalize()?;
        if bumped.dot(s.ng) < 0.0 {
            bumped = -bumped;
        }
        s.frame.to_local(bumped).try_normalize()
    }

    /// A scene BSDF without its adapters, with textures evaluated at `surface` over
    /// `footprint` ([`Self::texture_footprint`]; each material builds itself:
    /// [`Bsdf::at_hit`]).
    #[inline(always)]
    pub(super) fn base_bsdf(&self, bsdf: &BsdfSpec, surface: &Surface, footprint: f32) -> Bsdf {
        let normal_map = |t: &Texture| self.normal_mapped(surface, t, footprint);
        let hit = SpecHit {
            uv: surface.uv,
            footprint,
            color: surface.color,
            prepared: &self.prepared,
            material: surface.material,
            normal_map: &normal_map,
        };
        Bsdf::at_hit(bsdf, &hit)
    }
}

/// Whether `b` is an adapter.
#[inline]
pub(super) fn is_adapter(b: &BsdfSpec) -> bool {
    b.adapted().is_some()
}

/// Whether a mask is among the adapters of `b`.
pub(super) fn has_mask(mut b: &BsdfSpec) -> bool {
    loop {
        match b {
            BsdfSpec::Mask { .. } => return true,
            _ => match b.adapted() {
                Some(nested) => b = nested,
                None => return false,
            },
        }
    }
}
