//! Ray queries over a two-level BVH: one wide SIMD BVH per mesh (8-wide with AVX2, else
//! 4-wide: [`crate::accel::blas`]), one binary BVH over instances. Both can be refitted when
//! vertices or instance transforms change.
//!
//! obvhs builds the per-mesh binary trees with PLOC + reinsertion rather than the binned SAH of
//! the guided-filter paper; its trees are of comparable SAH quality and it builds in parallel.
//! Traversal uses lumo's own 8- or 4-wide collapse of them.

use glam::{Mat4, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::faststack::StackStack;
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;

use crate::accel::blas::WideBlas;
use crate::accel::bvh8::Bvh8;
use crate::accel::packet::{RayPacket, LANES};
use crate::accel::wide::{TriHit, EMPTY};

use lumo_scene::{AnalyticKind, Scene};

use analytic::Shape;

pub(crate) mod analytic;
pub(crate) mod blas;
mod bvh4;
pub(crate) mod bvh8;
mod flat;
mod median;
pub mod packet;
mod ploc_stall;
mod robust;
pub(crate) mod stack;
#[cfg(test)]
mod tests;
mod tlas;
pub(crate) mod wide;

/// The nearest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug, Default)]
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

impl Hit {
    /// The hit's fields as bits, for tests that compare two queries' hits bit for bit.
    #[cfg(test)]
    pub(crate) fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32, u32)> {
        h.map(|h| {
            (
                h.t.to_bits(),
                h.instance,
                h.triangle,
                h.u.to_bits(),
                h.v.to_bits(),
            )
        })
    }
}

/// How [`Accel::refit_instances`] or [`Accel::refit_meshes`] brought the trees up to date.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelUpdate {
    /// Boxes refitted and instances re-placed; no tree was rebuilt.
    Refitted,
    /// Rebuilt from scratch: an instance joined or left the identity transform, so the
    /// merged BVH of identity instances changed its triangles.
    Rebuilt,
}

/// The BVH of one mesh, in object space.
struct MeshBvh {
    /// Binary tree kept for refitting; its leaves hold one triangle each.
    bvh2: Bvh2,
    /// Wide tree used for traversal, regenerated from `bvh2` after a refit.
    wide: WideBlas,
}

impl MeshBvh {
    fn build(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let boxes: Vec<Aabb> = indices
            .iter()
            .map(|&t| triangle_box(positions, t))
            .collect();
        let bvh2 = robust::build_bvh2(
            &boxes,
            robust::BuildOptions {
                search_depth_threshold: 3,
                reinsertion: 0.05,
            },
        );
        let wide = WideBlas::build(&bvh2, positions, indices);
        MeshBvh { bvh2, wide }
    }

    /// Moves vertices without changing the tree's topology (fast; quality degrades with
    /// large deformations, when a rebuild is better).
    fn refit(&mut self, positions: &[Vec3], indices: &[[u32; 3]]) {
        robust::refit_leaves(&mut self.bvh2, |p| triangle_box(positions, indices[p]));
        self.wide = WideBlas::build(&self.bvh2, positions, indices);
    }
}

/// The bounding box of triangle `t`.
fn triangle_box(positions: &[Vec3], t: [u32; 3]) -> Aabb {
    let p = |i: u32| Vec3A::from(positions[i as usize]);
    RtTriangle::new(p(t[0]), p(t[1]), p(t[2])).aabb()
}

/// What a TLAS leaf points at.
#[derive(Clone, Copy)]
enum Target {
    /// The merged BVH of all instances with the identity transform.
    Static,
    /// Instance `instance` of mesh `mesh`, through its transform.
    Instance { instance: u32, mesh: u32 },
    /// Instance `instance` of an analytic shape, through its transform times the shape's.
    Analytic { instance: u32, kind: AnalyticKind },
}

/// One TLAS leaf.
#[derive(Clone, Copy)]
struct Placement {
    target: Target,
    to_local: Mat4,
    identity: bool,
}

/// The scene's acceleration structure.
///
/// Instances with the identity transform (most of a static scene) are merged into one BVH,
/// which saves a TLAS level and per-instance ray transforms for them; each other instance
/// points at its mesh's BVH (shared between instances of one mesh).
pub struct Accel {
    /// Per mesh: its BVH if some non-identity instance uses it.
    meshes: Vec<Option<MeshBvh>>,
    /// Merged BVH of the identity instances, with the source of each triangle.
    static_bvh: Option<(MeshBvh, Vec<(u32, u32)>)>,
    placements: Vec<Placement>,
    tlas: Bvh2,
    /// Levels of `tlas` (its nodes' largest depth), which bounds its traversal stack.
    tlas_depth: usize,
    /// Walk `tlas` with the AVX pair test ([`tlas::traverse_avx`]): the CPU has AVX and
    /// `LUMO_SIMD` allows it.
    tlas_avx: bool,
    /// Each placement's world box where the scene is the static BVH and a few exact shapes,
    /// whose rays skip `tlas` ([`flat`], [`Accel::flat`]); empty otherwise.
    flat_boxes: Vec<Aabb>,
}

/// Gathers the triangles of identity instances into one mesh; returns it and each triangle's
/// (instance, triangle) origin.
/// Merged geometry of the identity-transform instances: positions, triangles, and for each
/// triangle its (instance, triangle) origin.
type StaticGeometry = (Vec<Vec3>, Vec<[u32; 3]>, Vec<(u32, u32)>);

fn gather_static(scene: &Scene) -> StaticGeometry {
    let (mut positions, mut indices, mut origin) = (vec![], vec![], vec![]);
    for (ii, inst) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[inst.mesh];
        if inst.transform != Mat4::IDENTITY || mesh.analytic.is_some() {
            continue;
        }
        let base = positions.len() as u32;
        positions.extend_from_slice(&mesh.positions);
        for (t, tri) in mesh.indices.iter().enumerate() {
            indices.push(tri.map(|i| i + base));
            origin.push((ii as u32, t as u32));
        }
    }
    (positions, indices, origin)
}

impl Accel {
    /// Builds BVHs for every mesh and the instance tree. The scene must be validated.
    pub fn build(scene: &Scene) -> Self {
        use rayon::prelude::*;
        // One pass over the instances (a search per mesh was quadratic: 100,000 glTF
        // primitives, each its own mesh and instance, took 32.6 s).
        let mut moving = vec![false; scene.meshes.len()];
        for i in &scene.instances {
            if i.transform != Mat4::IDENTITY && scene.meshes[i.mesh].analytic.is_none() {
                moving[i.mesh] = true;
            }
        }
        let meshes: Vec<Option<MeshBvh>> = scene
            .meshes
            .par_iter()
            .zip(moving.par_iter())
            .map(|(m, &moving)| {
                (moving && !m.indices.is_empty()).then(|| MeshBvh::build(&m.positions, &m.indices))
            })
            .collect();
        let (positions, indices, origin) = gather_static(scene);
        let static_bvh =
            (!indices.is_empty()).then(|| (MeshBvh::build(&positions, &indices), origin));
        let mut placements = vec![];
        if static_bvh.is_some() {
            placements.push(Placement {
                target: Target::Static,
                to_local: Mat4::IDENTITY,
                identity: true,
            });
        }
        for (ii, inst) in scene.instances.iter().enumerate() {
            if let Some(a) = &scene.meshes[inst.mesh].analytic {
                placements.push(Placement {
                    target: Target::Analytic {
                        instance: ii as u32,
                        kind: a.kind,
                    },
                    to_local: Shape::new(a, inst.transform).to_local,
                    identity: false,
                });
                continue;
            }
            if inst.transform != Mat4::IDENTITY && !scene.meshes[inst.mesh].indices.is_empty() {
                placements.push(Placement {
                    target: Target::Instance {
                        instance: ii as u32,
                        mesh: inst.mesh as u32,
                    },
                    to_local: inst.transform.inverse(),
                    identity: false,
                });
            }
        }
        let mut accel = Accel {
            meshes,
            static_bvh,
            placements,
            tlas: Bvh2::default(),
            tlas_depth: 0,
            tlas_avx: lumo_simd::Isa::detect() >= lumo_simd::Isa::Avx2,
            flat_boxes: vec![],
        };
        let boxes = accel.placement_boxes(scene);
        if flat::applies(&accel.placements) {
            accel.flat_boxes = boxes.clone();
        }
        accel.tlas = robust::build_bvh2(
            &boxes,
            robust::BuildOptions {
                search_depth_threshold: 1,
                reinsertion: 0.0,
            },
        );
        accel.tlas_depth = tree_depth(&accel.tlas);
        accel
    }

    fn blas(&self, target: Target) -> Option<&MeshBvh> {
        match target {
            Target::Static => self.static_bvh.as_ref().map(|(b, _)| b),
            Target::Instance { mesh, .. } => self.meshes.get(mesh as usize)?.as_ref(),
            Target::Analytic { .. } => None,
        }
    }

    fn placement_boxes(&self, scene: &Scene) -> Vec<Aabb> {
        self.placements
            .iter()
            .map(|p| {
                let (lb, transform) = if let Target::Analytic { kind, .. } = p.target {
                    // Padded: the transform is the inverse of the inverse, to rounding.
                    let (lo, hi) = Shape::local_bounds(kind);
                    let (lo, hi) = (lo - Vec3::splat(1e-4), hi + Vec3::splat(1e-4));
                    (Aabb::new(lo.into(), hi.into()), p.to_local.inverse())
                } else {
                    let Some(blas) = self.blas(p.target) else {
                        return Aabb::new(Vec3A::splat(f32::MAX), Vec3A::splat(f32::MAX));
                    };
                    let transform = match p.target {
                        Target::Instance { instance, .. } => {
                            scene.instances[instance as usize].transform
                        }
                        _ => Mat4::IDENTITY,
                    };
                    (*blas.bvh2.nodes[0].aabb(), transform)
                };
                let (lo, hi) =
                    lumo_scene::transformed_box(lb.min.into(), lb.max.into(), &transform);
                Aabb::new(lo.into(), hi.into())
            })
            .collect()
    }

    /// Updates the trees after `scene.meshes[mesh]` moved its vertices (same triangles): the
    /// mesh's BVH and, if it is placed with the identity transform, the merged static BVH are
    /// refitted, then the instance tree.
    pub fn refit_mesh(&mut self, scene: &Scene, mesh: usize) -> AccelUpdate {
        self.refit_meshes(scene, &[mesh])
    }

    /// [`Accel::refit_mesh`] for several meshes at once: the merged static BVH and the
    /// instance tree are refitted once, not once per mesh. Indices out of range are ignored.
    pub fn refit_meshes(&mut self, scene: &Scene, meshes: &[usize]) -> AccelUpdate {
        let mut changed = vec![false; scene.meshes.len()];
        for &mesh in meshes {
            let Some(m) = scene.meshes.get(mesh) else {
                continue;
            };
            if let Some(Some(bvh)) = self.meshes.get_mut(mesh) {
                bvh.refit(&m.positions, &m.indices);
            }
            changed[mesh] = true;
        }
        // One pass over the instances, not one per changed mesh.
        let in_static = scene
            .instances
            .iter()
            .any(|i| changed.get(i.mesh) == Some(&true) && i.transform == Mat4::IDENTITY);
        if in_static {
            let (positions, indices, _) = gather_static(scene);
            if let Some((bvh, _)) = &mut self.static_bvh {
                bvh.refit(&positions, &indices);
            }
        }
        self.refit_instances(scene)
    }

    /// Updates the instance tree after instance transforms changed (no rebuild). An instance
    /// that leaves or joins the identity transform changes the merged static BVH, which
    /// needs a rebuild: that case rebuilds everything (and says so).
    pub fn refit_instances(&mut self, scene: &Scene) -> AccelUpdate {
        let static_count = scene
            .instances
            .iter()
            .filter(|i| {
                let mesh = &scene.meshes[i.mesh];
                i.transform == Mat4::IDENTITY && !mesh.indices.is_empty() && mesh.analytic.is_none()
            })
            .count();
        let was_static = self
            .static_bvh
            .as_ref()
            .map(|(_, o)| {
                let mut seen: Vec<u32> = o.iter().map(|(i, _)| *i).collect();
                seen.dedup();
                seen.len()
            })
            .unwrap_or(0);
        let moved_static = self.static_bvh.as_ref().is_some_and(|(_, o)| {
            o.iter()
                .any(|(i, _)| scene.instances[*i as usize].transform != Mat4::IDENTITY)
        });
        if moved_static || static_count != was_static {
            *self = Accel::build(scene);
            return AccelUpdate::Rebuilt;
        }
        for p in &mut self.placements {
            match p.target {
                Target::Instance { instance, .. } => {
                    let t = scene.instances[instance as usize].transform;
                    p.to_local = t.inverse();
                    p.identity = false;
                }
                Target::Analytic { instance, .. } => {
                    let inst = &scene.instances[instance as usize];
                    if let Some(a) = &scene.meshes[inst.mesh].analytic {
                        p.to_local = Shape::new(a, inst.transform).to_local;
                    }
                }
                Target::Static => {}
            }
        }
        let boxes = self.placement_boxes(scene);
        robust::refit_leaves(&mut self.tlas, |p| boxes[p]);
        if self.flat() {
            self.flat_boxes = boxes;
        }
        AccelUpdate::Refitted
    }

    /// The ray `origin + t·dir` in placement `p`'s object space.
    #[inline]
    fn local_ray(&self, p: &Placement, origin: Vec3, dir: Vec3) -> (Vec3, Vec3) {
        if p.identity {
            (origin, dir)
        } else {
            // The direction is not renormalised, so t stays the world-space ray parameter.
            (
                p.to_local.transform_point3(origin),
                p.to_local.transform_vector3(dir),
            )
        }
    }

    /// Maps a BLAS hit in placement `pi` to the scene's instance and triangle.
    #[inline]
    fn scene_hit(&self, pi: usize, h: TriHit) -> Option<Hit> {
        let (instance, triangle) = match self.placements[pi].target {
            Target::Static => self.static_bvh.as_ref()?.1[h.triangle as usize],
            // An analytic hit's `triangle` is 0 (see `intersect_placement`).
            Target::Instance { instance, .. } | Target::Analytic { instance, .. } => {
                (instance, h.triangle)
            }
        };
        Some(Hit {
            t: h.t,
            instance,
            triangle,
            u: h.u,
            v: h.v,
        })
    }

    /// Nearest hit of the world ray `origin + t·dir` with placement `p`'s geometry.
    #[inline]
    fn intersect_placement(
        &self,
        p: &Placement,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> Option<TriHit> {
        let (o, d) = self.local_ray(p, origin, dir);
        if let Target::Analytic { kind, .. } = p.target {
            let t = analytic::intersect(kind, o, d, tmin, tmax)?;
            return Some(TriHit {
                t,
                triangle: 0,
                u: 0.0,
                v: 0.0,
            });
        }
        self.blas(p.target)?.wide.intersect(o, d, tmin, tmax)
    }

    /// Whether placement `p`'s geometry blocks the world ray `origin + t·dir`.
    #[inline]
    fn occluded_placement(
        &self,
        p: &Placement,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
    ) -> bool {
        let (o, d) = self.local_ray(p, origin, dir);
        if let Target::Analytic { kind, .. } = p.target {
            return analytic::intersect(kind, o, d, tmin, tmax).is_some();
        }
        self.blas(p.target)
            .is_some_and(|b| b.wide.occluded(o, d, tmin, tmax))
    }

    /// Nearest hit along `origin + t·dir` for t in (tmin, tmax).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        if self.tlas.nodes.is_empty() {
            return None;
        }
        if self.placements.len() == 1 {
            // A single placement (typically the merged static scene): skip the instance tree.
            let h = self.intersect_placement(&self.placements[0], origin, dir, tmin, tmax)?;
            return self.scene_hit(0, h);
        }
        if self.flat() {
            return self.intersect_flat(origin, dir, tmin, tmax);
        }
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        let mut best: Option<(usize, TriHit)> = None;
        let mut hit = RayHit::none();
        // Each primitive of a leaf is tested in order and shortens the ray (obvhs's
        // `ray_traverse` does the same, but zeroes a 96-entry stack per call: 2 % of the
        // atrium's instructions).
        let mut leaf = |node: &Bvh2Node, r: &mut Ray, hit: &mut RayHit| {
            for id in node.first_index..node.first_index + node.prim_count {
                let pi = self.tlas.primitive_indices[id as usize] as usize;
                let p = &self.placements[pi];
                if let Some(h) = self.intersect_placement(p, origin, dir, r.tmin, r.tmax) {
                    if h.t < r.tmax {
                        best = Some((pi, h));
                        hit.primitive_id = id;
                        hit.t = h.t;
                        r.tmax = h.t;
                    }
                }
            }
            true
        };
        self.traverse_tlas(ray, &mut hit, &mut leaf);
        let (pi, h) = best?;
        self.scene_hit(pi, h)
    }

    /// The tree packets can traverse: the 8-wide BVH of a scene that is one placement with
    /// the identity transform (the merged static scene), or that and a few exact shapes
    /// ([`flat`]: each ray of the packet then tests the shapes). Otherwise packets go ray by
    /// ray.
    fn packet_tree(&self) -> Option<&Bvh8> {
        match self.placements.as_slice() {
            [p] if p.identity => self.blas(p.target)?.wide.eight(),
            [p, ..] if self.flat() && matches!(p.target, Target::Static) => {
                self.blas(p.target)?.wide.eight()
            }
            _ => None,
        }
    }

    /// Nearest hits of the first `rays.count` rays of a packet: `out[i]` is what
    /// [`Accel::intersect`] returns for ray `i`, bit for bit.
    #[inline]
    pub fn intersect_packet(&self, rays: &RayPacket, out: &mut [Option<Hit>; LANES]) {
        let n = rays.count;
        if n >= MIN_PACKET_RAYS {
            if let Some(tree) = self.packet_tree() {
                let h = tree.intersect_packet(rays);
                // `scene_hit` for placement 0, its target matched once per packet.
                let ids: Option<&[(u32, u32)]> = match self.placements[0].target {
                    Target::Static => self.static_bvh.as_ref().map(|s| s.1.as_slice()),
                    _ => None,
                };
                for (i, o) in out.iter_mut().enumerate().take(n) {
                    let hit = TriHit {
                        t: h.t[i],
                        triangle: h.id[i],
                        u: h.u[i],
                        v: h.v[i],
                    };
                    *o = match ids {
                        _ if h.id[i] == EMPTY => None,
                        Some(ids) => {
                            ids.get(hit.triangle as usize)
                                .map(|&(instance, triangle)| Hit {
                                    t: hit.t,
                                    instance,
                                    triangle,
                                    u: hit.u,
                                    v: hit.v,
                                })
                        }
                        None => self.scene_hit(0, hit),
                    };
                }
                if self.flat() {
                    self.shapes_closest_packet(rays, out);
                }
                return;
            }
        }
        for (i, o) in out.iter_mut().enumerate().take(n) {
            let (origin, dir) = lane_ray(rays, i);
            *o = self.intersect(origin, dir, rays.tmin[i], rays.tmax[i]);
        }
    }

    /// Bit `i` set if something blocks ray `i` of the packet ([`Accel::occluded`] per ray).
    pub fn occluded_packet(&self, rays: &RayPacket) -> u32 {
        if rays.count >= MIN_PACKET_RAYS {
            if let Some(tree) = self.packet_tree() {
                let blocked = tree.occluded_packet(rays);
                return if self.flat() {
                    self.shapes_occlude_packet(rays, blocked)
                } else {
                    blocked
                };
            }
        }
        let mut out = 0;
        for i in 0..rays.count {
            let (origin, dir) = lane_ray(rays, i);
            out |= (self.occluded(origin, dir, rays.tmin[i], rays.tmax[i]) as u32) << i;
        }
        out
    }

    /// True if anything blocks `origin + t·dir` for t in (tmin, tmax) (any-hit query).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        if self.tlas.nodes.is_empty() {
            return false;
        }
        if self.placements.len() == 1 {
            return self.occluded_placement(&self.placements[0], origin, dir, tmin, tmax);
        }
        if self.flat() {
            return self.occluded_flat(origin, dir, tmin, tmax);
        }
        let ray = Ray::new(origin.into(), dir.into(), tmin, tmax);
        let mut blocked = false;
        let mut leaf = |node: &Bvh2Node, r: &mut Ray, _: &mut RayHit| {
            for id in node.first_index..node.first_index + node.prim_count {
                let p = &self.placements[self.tlas.primitive_indices[id as usize] as usize];
                if self.occluded_placement(p, origin, dir, r.tmin, r.tmax) {
                    blocked = true;
                    // Ends the traversal.
                    return false;
                }
            }
            true
        };
        self.traverse_tlas(ray, &mut RayHit::none(), &mut leaf);
        blocked
    }

    /// Walks the instance tree with `leaf` called on every leaf the ray reaches (it returns
    /// false to stop), on a small stack where the tree is shallow enough for it.
    #[inline]
    fn traverse_tlas(
        &self,
        ray: Ray,
        hit: &mut RayHit,
        leaf: &mut impl FnMut(&Bvh2Node, &mut Ray, &mut RayHit) -> bool,
    ) {
        // obvhs's fixed stack saturates instead of growing: only a tree no deeper than its
        // size may use it.
        if self.tlas_depth < tlas::MAX_DEPTH {
            #[cfg(target_arch = "x86_64")]
            if self.tlas_avx {
                // SAFETY: `tlas_avx` is set only where the CPU has AVX2 (so AVX); the tree is
                // not empty (both callers return first) and shallow enough (tested above).
                unsafe { tlas::traverse_avx(&self.tlas, ray, hit, leaf) };
                return;
            }
            let mut stack = StackStack::<u32, { tlas::MAX_DEPTH }>::default();
            self.tlas.ray_traverse_dynamic(&mut stack, ray, hit, leaf);
        } else {
            let mut stack = Vec::with_capacity(self.tlas_depth + 1);
            self.tlas.ray_traverse_dynamic(&mut stack, ray, hit, leaf);
        }
    }
}

/// The number of levels of `tree` (1 for a lone leaf, 0 for an empty tree); refits keep it.
fn tree_depth(tree: &Bvh2) -> usize {
    let mut deepest = 0;
    let mut todo = Vec::new();
    if !tree.nodes.is_empty() {
        todo.push((0usize, 1usize));
    }
    while let Some((i, depth)) = todo.pop() {
        deepest = deepest.max(depth);
        let node = &tree.nodes[i];
        if !node.is_leaf() {
            let left = node.first_index as usize;
            todo.push((left, depth + 1));
            todo.push((left + 1, depth + 1));
        }
    }
    deepest
}

/// Packets with fewer rays go ray by ray: a packet's tests cost sixteen lanes whatever the
/// number of rays in it (a pixel rendered alone at 1 spp traces packets of one ray).
const MIN_PACKET_RAYS: usize = 4;

/// Origin and direction of lane `i` of a packet.
#[inline]
fn lane_ray(rays: &RayPacket, i: usize) -> (Vec3, Vec3) {
    (
        Vec3::new(rays.o[0][i], rays.o[1][i], rays.o[2][i]),
        Vec3::new(rays.d[0][i], rays.d[1][i], rays.d[2][i]),
    )
}
