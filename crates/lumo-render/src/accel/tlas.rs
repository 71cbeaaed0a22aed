//! Traversal of the instance tree (obvhs's binary BVH over the placements) with both children
//! of a node tested in one 8-lane AVX slab test.
//!
//! obvhs's `ray_traverse_dynamic` tests the two children one after the other in 4-lane SSE;
//! on the atrium (44 instances) that walk was 18 % of a render's instructions. This walk visits
//! the same nodes in the same order and takes the same decisions (the near child first, a leaf
//! tested as soon as its box is entered, no re-test of popped nodes), so the leaves are called
//! in the same order with the same ray and the hits are the same. The entry distances are the
//! same numbers: the slab arithmetic is obvhs's (`(min − o)·inv`, lane-wise min/max, the
//! largest entry and smallest exit of x, y, z), only two boxes at a time.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};

/// Most levels a tree may have to be walked here (its stack lives in the frame).
pub(super) const MAX_DEPTH: usize = 32;

/// Walks `tree` (no deeper than [`MAX_DEPTH`] levels, not empty) as obvhs's
/// `ray_traverse_dynamic` does, calling `leaf` on each leaf whose box the ray enters (it may
/// shorten the ray; returning false stops the walk).
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
pub(super) unsafe fn traverse_avx(
    tree: &Bvh2,
    mut ray: Ray,
    hit: &mut RayHit,
    leaf: &mut impl FnMut(&Bvh2Node, &mut Ray, &mut RayHit) -> bool,
) {
    let nodes = &tree.nodes;
    let root = &nodes[0];
    if root.aabb().intersect_ray(&ray) >= ray.tmax {
        return;
    }
    if root.is_leaf() {
        leaf(root, &mut ray, hit);
        return;
    }
    let mut stack = [0u32; MAX_DEPTH];
    let mut depth = 0usize;
    let mut current = root.first_index as usize;
    let (o, inv) = {
        let o: __m128 = ray.origin.into();
        let inv: __m128 = ray.inv_direction.into();
        (_mm256_set_m128(o, o), _mm256_set_m128(inv, inv))
    };
    loop {
        let (mut near, mut far) = (&nodes[current], &nodes[current + 1]);
        // SAFETY: AVX is enabled in this function.
        let (mut near_t, mut far_t) = unsafe { pair_entry(near, far, o, inv) };
        if near_t > far_t {
            std::mem::swap(&mut near_t, &mut far_t);
            std::mem::swap(&mut near, &mut far);
        }
        let Some(go_near) = descend(near, near_t, &mut ray, hit, leaf) else {
            return;
        };
        // After the near leaf, which may have shortened the ray.
        let Some(go_far) = descend(far, far_t, &mut ray, hit, leaf) else {
            return;
        };
        current = match (go_near, go_far) {
            (true, true) => {
                stack[depth] = far.first_index;
                depth += 1;
                near.first_index as usize
            }
            (true, false) => near.first_index as usize,
            (false, true) => far.first_index as usize,
            (false, false) => {
                if depth == 0 {
                    hit.t = ray.tmax;
                    return;
                }
                depth -= 1;
                stack[depth] as usize
            }
        };
    }
}

/// Whether the walk goes down into `node`, entered at `t`: an entered leaf is handed to `leaf`
/// at once and not descended into. `None`: `leaf` asked to stop the walk.
#[inline(always)]
fn descend(
    node: &Bvh2Node,
    t: f32,
    ray: &mut Ray,
    hit: &mut RayHit,
    leaf: &mut impl FnMut(&Bvh2Node, &mut Ray, &mut RayHit) -> bool,
) -> Option<bool> {
    let entered = t < ray.tmax;
    if entered && node.is_leaf() {
        return leaf(node, ray, hit).then_some(false);
    }
    Some(entered)
}

/// The entry distances of the ray (origin `o`, inverse direction `inv`, each repeated in both
/// halves) into the boxes of `a` and `b`, infinite where it misses one — obvhs's
/// `Aabb::intersect_ray` for both at once.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn pair_entry(a: &Bvh2Node, b: &Bvh2Node, o: __m256, inv: __m256) -> (f32, f32) {
    let (ab, bb) = (a.aabb(), b.aabb());
    let lo = _mm256_set_m128(bb.min.into(), ab.min.into());
    let hi = _mm256_set_m128(bb.max.into(), ab.max.into());
    let t1 = _mm256_mul_ps(_mm256_sub_ps(lo, o), inv);
    let t2 = _mm256_mul_ps(_mm256_sub_ps(hi, o), inv);
    let tmin = _mm256_min_ps(t1, t2);
    let tmax = _mm256_max_ps(t1, t2);
    // Largest of x, y, z into lane 0 of each half (lane 3, the padding, stays out).
    let enter = _mm256_max_ps(
        _mm256_max_ps(tmin, _mm256_permute_ps::<YZX>(tmin)),
        _mm256_permute_ps::<ZXY>(tmin),
    );
    let exit = _mm256_min_ps(
        _mm256_min_ps(tmax, _mm256_permute_ps::<YZX>(tmax)),
        _mm256_permute_ps::<ZXY>(tmax),
    );
    let enter_a = _mm_cvtss_f32(_mm256_castps256_ps128(enter));
    let exit_a = _mm_cvtss_f32(_mm256_castps256_ps128(exit));
    let enter_b = _mm_cvtss_f32(_mm256_extractf128_ps::<1>(enter));
    let exit_b = _mm_cvtss_f32(_mm256_extractf128_ps::<1>(exit));
    (slab(enter_a, exit_a), slab(enter_b, exit_b))
}

/// Lane order (y, z, x, w) of each half, for `_mm256_permute_ps`.
#[cfg(target_arch = "x86_64")]
const YZX: i32 = 0b11_00_10_01;
/// Lane order (z, x, y, w) of each half.
#[cfg(target_arch = "x86_64")]
const ZXY: i32 = 0b11_01_00_10;

/// obvhs's verdict on a slab test: the entry distance, or infinity for a miss.
#[inline(always)]
fn slab(enter: f32, exit: f32) -> f32 {
    if exit >= enter && exit >= 0.0 {
        enter
    } else {
        f32::INFINITY
    }
}
