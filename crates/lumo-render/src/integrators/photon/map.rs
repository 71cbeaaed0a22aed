//! The photon map shared by photon writers and camera-sample readers: a [`KdTree`] and the
//! number of photon paths behind it, under a readers–writer lock (the paper's §3.4), with
//! counters that measure how often either side had to wait.
//!
//! Memory is bounded by a photon capacity. When a batch would overflow it, the map starts a
//! new *generation*: it drops every photon and its path count and takes the batch alone.
//! Each camera sample divides by the paths of the generation it reads, so every pass stays
//! an unbiased estimate at its radius, just a noisier one right after a reset; with the
//! radius schedule of [`super::radius`] the average over passes still converges (its variance
//! bound needs only at least one batch of paths in every pass's map).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard, TryLockError};
use std::time::Instant;

use glam::Vec3;

use super::kdtree::KdTree;
use super::trace::PhotonBatch;

/// The map's contents: what a gather reads.
#[derive(Clone, Debug)]
pub struct MapState {
    /// The photons.
    pub tree: KdTree,
    /// Photon paths traced into this generation (including those that stored nothing): the
    /// density estimate's denominator.
    pub paths: u64,
    /// Times the map was emptied to stay within its capacity.
    pub generation: u32,
    /// Most photons kept.
    pub capacity: usize,
}

impl MapState {
    /// An empty map over the scene box `lo..hi` holding at most `capacity` photons.
    pub fn new(lo: Vec3, hi: Vec3, capacity: usize) -> Self {
        MapState {
            tree: KdTree::new(lo, hi),
            paths: 0,
            generation: 0,
            capacity,
        }
    }

    /// Adds a batch: starts a new generation first if the batch would not fit, and if the
    /// batch alone exceeds the capacity keeps its longest prefix of whole paths that fits
    /// (counting only those paths).
    pub fn add(&mut self, batch: &PhotonBatch) {
        let (lo, hi) = self.tree.bounds();
        self.add_ordered(batch, &morton_order(batch, lo, hi));
    }

    /// [`MapState::add`] with the batch's insertion order already computed by
    /// [`morton_order`] (so the shared map sorts outside its lock).
    fn add_ordered(&mut self, batch: &PhotonBatch, order: &[u32]) {
        if self.tree.len() + batch.photons.len() > self.capacity && self.paths > 0 {
            self.tree.clear();
            self.paths = 0;
            self.generation += 1;
        }
        let room = self.capacity.saturating_sub(self.tree.len());
        let fit = batch.path_end.partition_point(|&e| e as usize <= room);
        let end = if fit == 0 {
            0
        } else {
            batch.path_end[fit - 1] as usize
        };
        self.tree.reserve(end, self.capacity);
        // The kept prefix of paths is the photons before `end`, in the batch's Morton order.
        for &i in order {
            if (i as usize) < end {
                self.tree.insert(batch.photons[i as usize]);
            }
        }
        self.paths += fit as u64;
    }
}

/// The order in which a batch's photons enter a map over the box `lo..hi`: by Morton code of
/// their positions (ties by index). Inserting in this order puts photons of one leaf next to
/// each other in the array (leaf lists then walk nearby memory) and makes successive descents
/// share their path: a 128×128, 16-pass Cornell render on one thread ran 2.6× faster than
/// with photons in path order. A function of the batch alone, so maps stay deterministic.
pub fn morton_order(batch: &PhotonBatch, lo: Vec3, hi: Vec3) -> Vec<u32> {
    let mut keyed: Vec<(u64, u32)> = batch
        .photons
        .iter()
        .enumerate()
        .map(|(i, ph)| (morton(ph.p, lo, hi), i as u32))
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// The 63-bit Morton code of `p` quantised to 2²¹ steps per axis of the box `lo..hi`.
fn morton(p: Vec3, lo: Vec3, hi: Vec3) -> u64 {
    let q = ((p - lo) / (hi - lo).max(Vec3::splat(1e-20))).clamp(Vec3::ZERO, Vec3::ONE)
        * ((1u32 << 21) - 1) as f32;
    // Spreads the low 21 bits of v to every third bit.
    let spread = |v: f32| {
        let mut x = v as u64 & 0x1f_ffff;
        x = (x | (x << 32)) & 0x1f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x1f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        (x | (x << 2)) & 0x1249_2492_4924_9249
    };
    spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
}

/// How often the lock made a side wait.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LockStats {
    /// Read locks taken (one per camera sample).
    pub reads: u64,
    /// Of those, the ones that found a writer and waited.
    pub read_waits: u64,
    /// Nanoseconds readers spent waiting.
    pub read_wait_ns: u64,
    /// Write locks taken (one per photon batch).
    pub writes: u64,
    /// Of those, the ones that found readers or a writer and waited.
    pub write_waits: u64,
    /// Nanoseconds writers spent waiting.
    pub write_wait_ns: u64,
    /// Nanoseconds writers held the lock (inserting).
    pub write_hold_ns: u64,
}

#[derive(Default)]
struct Counters {
    reads: AtomicU64,
    read_waits: AtomicU64,
    read_wait_ns: AtomicU64,
    writes: AtomicU64,
    write_waits: AtomicU64,
    write_wait_ns: AtomicU64,
    write_hold_ns: AtomicU64,
}

/// The shared photon map.
pub struct PhotonMap {
    state: RwLock<MapState>,
    /// The tree's box (fixed), so batches are ordered before the lock is taken.
    bounds: (Vec3, Vec3),
    counters: Counters,
}

impl PhotonMap {
    /// An empty map over the scene box `lo..hi` holding at most `capacity` photons.
    pub fn new(lo: Vec3, hi: Vec3, capacity: usize) -> Self {
        PhotonMap {
            state: RwLock::new(MapState::new(lo, hi, capacity)),
            bounds: (lo, hi),
            counters: Counters::default(),
        }
    }

    /// Read access for gathering. A panicked writer leaves a consistent tree (inserts only
    /// link fully written photons), so a poisoned lock is still read.
    pub fn read(&self) -> RwLockReadGuard<'_, MapState> {
        let c = &self.counters;
        c.reads.fetch_add(1, Ordering::Relaxed);
        match self.state.try_read() {
            Ok(g) => g,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
            Err(TryLockError::WouldBlock) => {
                let t = Instant::now();
                let g = self.state.read().unwrap_or_else(|e| e.into_inner());
                c.read_waits.fetch_add(1, Ordering::Relaxed);
                c.read_wait_ns
                    .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                g
            }
        }
    }

    fn write(&self) -> RwLockWriteGuard<'_, MapState> {
        let c = &self.counters;
        c.writes.fetch_add(1, Ordering::Relaxed);
        match self.state.try_write() {
            Ok(g) => g,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
            Err(TryLockError::WouldBlock) => {
                let t = Instant::now();
                let g = self.state.write().unwrap_or_else(|e| e.into_inner());
                c.write_waits.fetch_add(1, Ordering::Relaxed);
                c.write_wait_ns
                    .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                g
            }
        }
    }

    /// Adds a batch (see [`MapState::add`]) under the write lock. Photon tracing and the
    /// batch's sort happen before, outside the lock: only the insertions block readers.
    pub fn add(&self, batch: &PhotonBatch) {
        let order = morton_order(batch, self.bounds.0, self.bounds.1);
        let mut g = self.write();
        let t = Instant::now();
        g.add_ordered(batch, &order);
        self.counters
            .write_hold_ns
            .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
    }

    /// The lock's counters so far.
    pub fn lock_stats(&self) -> LockStats {
        let c = &self.counters;
        let l = |a: &AtomicU64| a.load(Ordering::Relaxed);
        LockStats {
            reads: l(&c.reads),
            read_waits: l(&c.read_waits),
            read_wait_ns: l(&c.read_wait_ns),
            writes: l(&c.writes),
            write_waits: l(&c.write_waits),
            write_wait_ns: l(&c.write_wait_ns),
            write_hold_ns: l(&c.write_hold_ns),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::photon::kdtree::Photon;

    fn batch(paths: &[usize]) -> PhotonBatch {
        let mut b = PhotonBatch::default();
        for &n in paths {
            for _ in 0..n {
                b.photons.push(Photon {
                    p: Vec3::splat(0.5),
                    wi: Vec3::Z,
                    ng: Vec3::Z,
                    power: Vec3::ONE,
                    depth: 2,
                });
            }
            b.path_end.push(b.photons.len() as u32);
        }
        b
    }

    #[test]
    fn capacity_starts_generations_and_counts_whole_paths() {
        let mut m = MapState::new(Vec3::ZERO, Vec3::ONE, 10);
        m.add(&batch(&[2, 0, 3]));
        assert_eq!((m.tree.len(), m.paths, m.generation), (5, 3, 0));
        m.add(&batch(&[1, 1]));
        assert_eq!((m.tree.len(), m.paths, m.generation), (7, 5, 0));
        // 7 + 4 > 10: a new generation holding this batch alone.
        m.add(&batch(&[4]));
        assert_eq!((m.tree.len(), m.paths, m.generation), (4, 1, 1));
        // A batch larger than the map keeps its whole paths that fit.
        m.add(&batch(&[3, 0, 6, 5]));
        assert_eq!((m.tree.len(), m.paths, m.generation), (9, 3, 2));
        let shared = PhotonMap::new(Vec3::ZERO, Vec3::ONE, 100);
        shared.add(&batch(&[1, 2]));
        assert_eq!(shared.read().paths, 2);
        let s = shared.lock_stats();
        assert_eq!(
            (s.reads, s.writes, s.read_waits, s.write_waits),
            (1, 1, 0, 0)
        );
    }
}
