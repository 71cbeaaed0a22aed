//! Ray queries over a two-level BVH: one compressed wide BVH (obvhs CWBVH) per mesh, one binary
//! BVH over instances. Both can be refitted when vertices or instance transforms change.
//!
//! obvhs builds with PLOC + reinsertion rather than the binned SAH of the guided-filter paper;
//! its trees are of comparable SAH quality and it builds in parallel.

use glam::{Mat4, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::{bvh2_to_cwbvh::bvh2_to_cwbvh, CwBvh};
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;

use lumo_scene::Scene;

/// The nearest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter of the hit (distance when the direction is unit length).
    pub t: f32,
    /// Index into the scene's instances.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub triangle: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub u: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub v: f32,
}

/// The BVH of one mesh, in object space.
struct MeshBvh {
    /// Binary tree kept for refitting; its leaves hold one triangle each.
    bvh2: Bvh2,
    /// Wide tree used for traversal, regenerated from `bvh2` after a refit.
    cwbvh: CwBvh,
    /// Triangles in CWBVH leaf order, so traversal reads them without indirection.
    tris: Vec<RtTriangle>,
    /// For each entry of `tris`, the mesh's triangle index.
    ids: Vec<u32>,
}

impl MeshBvh {
    fn build(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let tris: Vec<RtTriangle> = indices
            .iter()
            .map(|t| {
                let p = |i: u32| Vec3A::from(positions[i as usize]);
                RtTriangle::new(p(t[0]), p(t[1]), p(t[2]))
            })
            .collect();
        let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
            PlocSearchDistance::Medium,
            &tris,
            (0..tris.len() as u32).collect(),
            SortPrecision::U64,
            3,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, 0.05, None);
        let mut mesh = MeshBvh {
            bvh2,
            cwbvh: CwBvh::default(),
            tris: vec![],
            ids: vec![],
        };
        mesh.finish(&tris);
        mesh
    }

    /// Converts the binary tree into the traversal tree and lays triangles out in its order.
    fn finish(&mut self, tris: &[RtTriangle]) {
        self.cwbvh = bvh2_to_cwbvh(&self.bvh2, 3, true, false);
        self.ids = self.cwbvh.primitive_indices.clone();
        self.tris = self.ids.iter().map(|&i| tris[i as usize]).collect();
    }

    /// Moves vertices without changing the tree's topology (fast; quality degrades with
    /// large deformations, when a rebuild is better).
    fn refit(&mut self, positions: &[Vec3], indices: &[[u32; 3]]) {
        let tris: Vec<RtTriangle> = indices
            .iter()
            .map(|t| {
                let p = |i: u32| Vec3A::from(positions[i as usize]);
                RtTriangle::new(p(t[0]), p(t[1]), p(t[2]))
            })
            .collect();
        self.bvh2.init_primitives_to_nodes_if_uninit();
        for (prim, tri) in tris.iter().enumerate() {
            let node = self.bvh2.primitives_to_nodes[prim] as usize;
            self.bvh2.nodes[node].set_aabb(tri.aabb());
        }
        self.bvh2.refit_all();
        self.finish(&tris);
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut hit = RayHit::none();
        if self
            .cwbvh
            .ray_traverse(*ray, &mut hit, |r, id| self.tris[id].intersect(r))
        {
            Some((hit.t, hit.primitive_id))
        } else {
            None
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        !self
            .cwbvh
            .ray_traverse_miss(*ray, |r, id| self.tris[id].intersect(r))
    }
}

/// One placed mesh.
#[derive(Clone, Copy)]
struct Placement {
    mesh: u32,
    to_local: Mat4,
    identity: bool,
}

/// The scene's acceleration structure.
pub struct Accel {
    meshes: Vec<Option<MeshBvh>>,
    placements: Vec<Placement>,
    tlas: Bvh2,
}

impl Accel {
    /// Builds BVHs for every mesh and the instance tree. The scene must be validated.
    pub fn build(scene: &Scene) -> Self {
        use rayon::prelude::*;
        let meshes: Vec<Option<MeshBvh>> = scene
            .meshes
            .par_iter()
            .map(|m| (!m.indices.is_empty()).then(|| MeshBvh::build(&m.positions, &m.indices)))
            .collect();
        let placements = scene
            .instances
            .iter()
            .map(|inst| Placement {
                mesh: inst.mesh as u32,
                to_local: inst.transform.inverse(),
                identity: inst.transform == Mat4::IDENTITY,
            })
            .collect();
        let mut accel = Accel {
            meshes,
            placements,
            tlas: Bvh2::default(),
        };
        let boxes = accel.instance_boxes(scene);
        accel.tlas = PlocBuilder::with_capacity(boxes.len()).build(
            PlocSearchDistance::Medium,
            &boxes,
            (0..boxes.len() as u32).collect(),
            SortPrecision::U64,
            1,
        );
        accel
    }

    fn instance_boxes(&self, scene: &Scene) -> Vec<Aabb> {
        scene
            .instances
            .iter()
            .map(|inst| {
                let mut b = Aabb::empty();
                if let Some(Some(mesh)) = self.meshes.get(inst.mesh) {
                    let lb = mesh.bvh2.nodes[0].aabb();
                    for i in 0..8 {
                        let corner = Vec3::new(
                            if i & 1 == 0 { lb.min.x } else { lb.max.x },
                            if i & 2 == 0 { lb.min.y } else { lb.max.y },
                            if i & 4 == 0 { lb.min.z } else { lb.max.z },
                        );
                        b.extend(Vec3A::from(inst.transform.transform_point3(corner)));
                    }
                } else {
                    // An empty mesh: a degenerate box far away that no ray reaches.
                    b = Aabb::new(Vec3A::splat(f32::MAX), Vec3A::splat(f32::MAX));
                }
                b
            })
            .collect()
    }

    /// Updates the tree after `scene.meshes[mesh]` moved its vertices (same triangles) and/or
    /// instance transforms changed; call [`Accel::refit_instances`] afterwards if the mesh is
    /// instanced elsewhere too (it is done here for all instances).
    pub fn refit_mesh(&mut self, scene: &Scene, mesh: usize) {
        if let Some(Some(m)) = self.meshes.get_mut(mesh) {
            m.refit(&scene.meshes[mesh].positions, &scene.meshes[mesh].indices);
        }
        self.refit_instances(scene);
    }

    /// Updates the instance tree after instance transforms changed (no rebuild).
    pub fn refit_instances(&mut self, scene: &Scene) {
        for (p, inst) in self.placements.iter_mut().zip(&scene.instances) {
            p.to_local = inst.transform.inverse();
            p.identity = inst.transform == Mat4::IDENTITY;
        }
        let boxes = self.instance_boxes(scene);
        self.tlas.init_primitives_to_nodes_if_uninit();
        for (prim, b) in boxes.iter().enumerate() {
            let node = self.tlas.primitives_to_nodes[prim] as usize;
            self.tlas.nodes[node].set_aabb(*b);
        }
        self.tlas.refit_all();
    }

    #[inline]
    fn local_ray(&self, p: &Placement, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Ray {
        if p.identity {
            Ray::new(origin.into(), dir.into(), tmin, tmax)
        } else {
            // The direction is not renormalised, so t stays the world-space ray parameter.
            Ray::new(
                p.to_local.transform_point3(origin).into(),
                p.to_local.transform_vector3(dir).into(),
                tmin,
                tmax,
            )
        }
    }

    /// Nearest hit along `origin + t·dir` for t in (tmin, tmax).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        if self.tlas.nodes.is_empty() {
            return None;
        }
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        let mut best: Option<(u32, u32, Ray)> = None;
        let mut hit = RayHit::none();
        self.tlas.ray_traverse(ray, &mut hit, |r, id| {
            let inst = self.tlas.primitive_indices[id];
            let p = &self.placements[inst as usize];
            let Some(Some(mesh)) = self.meshes.get(p.mesh as usize) else {
                return f32::INFINITY;
            };
            let local = self.local_ray(p, origin, dir, r.tmin, r.tmax);
            match mesh.intersect(&local) {
                Some((t, slot)) => {
                    best = Some((inst, slot, local));
                    t
                }
                None => f32::INFINITY,
            }
        });
        let (instance, slot, local) = best?;
        let p = &self.placements[instance as usize];
        let mesh = self.meshes[p.mesh as usize].as_ref()?;
        let tri = &mesh.tris[slot as usize];
        let bary = tri.compute_barycentric(&local);
        Some(Hit {
            t: hit.t,
            instance,
            triangle: mesh.ids[slot as usize],
            u: bary.x,
            v: bary.y,
        })
    }

    /// True if anything blocks `origin + t·dir` for t in (tmin, tmax) (any-hit query).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.tlas.nodes.is_empty() {
            return false;
        }
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        !self.tlas.ray_traverse_miss(ray, |r, id| {
            let inst = self.tlas.primitive_indices[id];
            let p = &self.placements[inst as usize];
            match self.meshes.get(p.mesh as usize) {
                Some(Some(mesh))
                    if mesh.occluded(&self.local_ray(p, origin, dir, r.tmin, r.tmax)) =>
                {
                    0.0f32.max(r.tmin)
                }
                _ => f32::INFINITY,
            }
        })
    }
}
