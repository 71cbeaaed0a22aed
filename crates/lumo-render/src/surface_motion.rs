//! Where each pixel's surface point was one frame ago on meshes that deform (skins, morph
//! targets): a rigid instance's point is carried back by its transform alone, but a deforming
//! mesh's point must be found again by its triangle and barycentric coordinates in the
//! previous frame's vertex positions.

use crate::accel::Hit;
use crate::camera::PinholeCamera;
use crate::RenderScene;
use glam::{Mat4, Vec3};
use lumo_scene::Scene;

/// The first surface each pixel centre's camera ray hits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelHit {
    /// Index into the scene's instances; [`PixelHit::NONE`]'s `u32::MAX` where the ray
    /// hits nothing.
    pub instance: u32,
    /// Triangle index within the instance's mesh (meaningless on analytic shapes).
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertices.
    pub uv: [f32; 2],
}

impl PixelHit {
    /// A pixel whose ray hits nothing.
    pub const NONE: PixelHit = PixelHit {
        instance: u32::MAX,
        triangle: 0,
        uv: [0.0; 2],
    };
}

/// The first hit of each pixel centre's camera ray, row-major: the same rays as
/// [`crate::instance_ids`], with the triangle and barycentrics kept (traced in packets by
/// [`crate::camera_hits`]).
pub fn pixel_hits(
    rs: &RenderScene,
    camera: &PinholeCamera,
    width: usize,
    height: usize,
) -> Vec<PixelHit> {
    crate::camera_hits(rs, camera, width, height)
        .iter()
        .map(PixelHit::from)
        .collect()
}

impl From<&Option<Hit>> for PixelHit {
    /// The hit's instance, triangle and barycentrics; [`PixelHit::NONE`] for a miss.
    fn from(hit: &Option<Hit>) -> Self {
        hit.map_or(PixelHit::NONE, |hit| PixelHit {
            instance: hit.instance,
            triangle: hit.triangle,
            uv: [hit.u, hit.v],
        })
    }
}

/// The vertex positions of the meshes that deform, and every instance's transform, at one
/// frame: what the next frame needs to find where its deforming surface points were.
#[derive(Clone, Debug, Default)]
pub struct MeshPoses {
    /// (mesh index, its positions at this frame), for each deforming mesh.
    meshes: Vec<(usize, Vec<Vec3>)>,
    /// Instance transforms (object → world).
    transforms: Vec<Mat4>,
}

impl MeshPoses {
    /// The positions of `deforming` (mesh indices; those out of range are skipped) and the
    /// instance transforms of `scene` as they are now.
    pub fn capture(scene: &Scene, deforming: &[usize]) -> Self {
        Self {
            meshes: deforming
                .iter()
                .filter_map(|&m| Some((m, scene.meshes.get(m)?.positions.clone())))
                .collect(),
            transforms: scene.instances.iter().map(|i| i.transform).collect(),
        }
    }

    /// Whether no mesh deforms (then [`deformation_back`] has nothing to do).
    pub fn is_empty(&self) -> bool {
        self.meshes.is_empty()
    }

    /// Whether a deforming mesh of `scene` has other vertex positions than these (it was
    /// re-posed since they were captured).
    pub fn deformed_since(&self, scene: &Scene) -> bool {
        self.meshes.iter().any(|(m, p)| {
            scene
                .meshes
                .get(*m)
                .is_some_and(|mesh| mesh.positions != *p)
        })
    }

    fn positions(&self, mesh: usize) -> Option<&[Vec3]> {
        self.meshes
            .iter()
            .find(|(m, _)| *m == mesh)
            .map(|(_, p)| p.as_slice())
    }
}

/// Where a point on a deforming mesh was at an earlier pose and where it is now (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformedPoint {
    /// The point at the earlier pose ([`MeshPoses`]' positions and transform).
    pub then: Vec3,
    /// The same triangle and barycentrics under the scene's positions and transform now.
    pub now: Vec3,
}

/// `hit`'s triangle point (its triangle and barycentrics) under `then`'s vertex positions and
/// transform and under `scene`'s as they are now, if `hit` lies on a mesh that `then` holds
/// and that still has as many vertices; `None` otherwise (no hit, a rigid or analytic mesh, a
/// changed mesh, an instance that did not exist then). The one evaluation both directions use:
/// [`deformation_back`] (a pixel of this frame, carried back) and the temporal filter's
/// re-shading (a pixel of the previous frame, carried forward).
pub fn deformed_point(scene: &Scene, hit: &PixelHit, then: &MeshPoses) -> Option<DeformedPoint> {
    let point = |positions: &[Vec3], indices: [u32; 3], uv: [f32; 2], m: &Mat4| {
        let [a, b, c] = indices.map(|i| positions.get(i as usize).copied());
        let (a, b, c) = (a?, b?, c?);
        Some(m.transform_point3(a * (1.0 - uv[0] - uv[1]) + b * uv[0] + c * uv[1]))
    };
    let i = hit.instance as usize;
    let inst = scene.instances.get(i)?;
    let before = then.positions(inst.mesh)?;
    let mesh = scene.meshes.get(inst.mesh)?;
    if before.len() != mesh.positions.len() || mesh.analytic.is_some() {
        return None;
    }
    let tri = *mesh.indices.get(hit.triangle as usize)?;
    Some(DeformedPoint {
        then: point(before, tri, hit.uv, then.transforms.get(i)?)?,
        now: point(&mesh.positions, tri, hit.uv, &inst.transform)?,
    })
}

/// Per pixel, the world-space step from where its surface point is now back to where it was
/// at `then`, for pixels whose hit (`hits`, this frame's [`pixel_hits`]) lies on a mesh that
/// deformed; NaN elsewhere (no hit, a rigid mesh, a mesh whose vertex or triangle count
/// changed, an instance that did not exist then): those pixels keep the rigid motion.
///
/// The step is the hit's triangle point (same barycentrics) under then's positions and
/// transform minus the same under now's ([`deformed_point`]), so it includes the instance's
/// own motion.
pub fn deformation_back(scene: &Scene, hits: &[PixelHit], then: &MeshPoses) -> Vec<Vec3> {
    hits.iter()
        .map(|h| deformed_point(scene, h, then).map_or(Vec3::NAN, |d| d.then - d.now))
        .collect()
}

#[cfg(test)]
mod tests;
