//! Every filter's memory is proportional to the pixel count whatever the image's shape
//! (issue 49): a 1×N, N×1 or 2×N image costs about what a square of as many pixels does, and
//! nothing scales with the width squared, the longer side squared or a pyramid of it. A
//! constant image stays constant on every shape. Its own test program: the peak is measured
//! by a counting global allocator, which other tests running beside it would disturb.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Mutex;

use lumo_filter::*;
use lumo_image::Image;

/// Bytes allocated now and the peak since the last [`reset_peak`].
struct Counting;
static NOW: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = NOW.fetch_add(layout.size(), Relaxed) + layout.size();
            PEAK.fetch_max(now, Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) };
        NOW.fetch_sub(layout.size(), Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// One measurement at a time (the counters are global).
static ONE: Mutex<()> = Mutex::new(());

fn reset_peak() -> usize {
    let now = NOW.load(Relaxed);
    PEAK.store(now, Relaxed);
    now
}

/// Constant planes of `w`×`h`: colour 0.25, normal +z, depth 2, albedo 0.5, small variance.
struct Planes {
    color: Image,
    normal: Image,
    position: Image,
    depth: Image,
    albedo: Image,
    variance: Image,
}

fn planes(w: usize, h: usize) -> Planes {
    let mut normal = Image::new(w, h, 3, 0.0);
    for p in normal.data.chunks_exact_mut(3) {
        p[2] = 1.0;
    }
    Planes {
        color: Image::new(w, h, 3, 0.25),
        normal,
        position: Image::new(w, h, 3, 1.0),
        depth: Image::new(w, h, 1, 2.0),
        albedo: Image::new(w, h, 3, 0.5),
        variance: Image::new(w, h, 1, 0.01),
    }
}

/// Peak bytes allocated while `info`'s filter denoises a constant `w`×`h` frame (three
/// frames for the temporal filter), and its output, checked to be the constant.
fn peak(info: &FilterInfo, w: usize, h: usize) -> usize {
    let p = planes(w, h);
    let features = Features {
        normal: Some(&p.normal),
        position: Some(&p.position),
        depth: Some(&p.depth),
        albedo: Some(&p.albedo),
        variance: Some(&p.variance),
    };
    let k = JbuParams::default().factor;
    let low = Image::new(w.div_ceil(k), h.div_ceil(k), 3, 0.25);
    let color = if info.shape == Shape::LowResColor {
        &low
    } else {
        &p.color
    };
    let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
    let mut d = (info.new)();
    let frames = if info.shape == Shape::Sequence { 3 } else { 1 };
    // One thread: with more, the peak depends on how the threads' buffers overlap in time.
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let base = reset_peak();
    one_thread.install(|| peak_of_frames(&mut *d, info, color, &features, frames, w, h));
    PEAK.load(Relaxed) - base
}

/// Runs `d` over `frames` frames, each checked to be the constant.
fn peak_of_frames(
    d: &mut dyn Denoiser,
    info: &FilterInfo,
    color: &Image,
    features: &Features,
    frames: usize,
    w: usize,
    h: usize,
) {
    for _ in 0..frames {
        let out = d
            .denoise(&FilterInput::new(color, *features))
            .unwrap_or_else(|e| panic!("{} on {w}x{h}: {e}", info.name));
        assert_eq!((out.image.width, out.image.height), (w, h), "{}", info.name);
        for v in &out.image.data {
            assert!(
                (v - 0.25).abs() < 1e-4,
                "{} on {w}x{h}: a constant 0.25 came out {v}",
                info.name
            );
        }
    }
}

/// Peaks of every filter on `n`-pixel images of four extreme shapes, against a square of
/// 65,536 pixels; the filters (and shapes) whose peak exceeds twice the square's plus 8 MiB.
fn over_budget(n: usize, filters: &[&str]) -> Vec<String> {
    let mut over = vec![];
    for info in FILTERS.iter().filter(|f| filters.contains(&f.name)) {
        let square = peak(info, 256, 256);
        for (w, h) in [(n, 1), (1, n), (2, n / 2), (n / 2, 2)] {
            let bytes = peak(info, w, h);
            // Twice the square's, plus 8 MiB for per-row or per-column buffers and thread
            // scratch: a buffer of the longer side squared would be 16 GiB.
            if bytes > 2 * square + (8 << 20) {
                over.push(format!(
                    "{} on {w}x{h}: peak {bytes} B against {square} B for 256x256",
                    info.name
                ));
            }
        }
        for (w, h) in [(1, 1), (1, 2), (3, 1)] {
            peak(info, w, h);
        }
    }
    over
}

/// Every filter gives a constant image back on every shape (1×1, 1×N, N×1, 2×N, …) and stays
/// within the bound at 4,096 pixels.
#[test]
fn every_filter_runs_on_extreme_shapes_within_memory() {
    let all: Vec<&str> = FILTERS.iter().map(|f| f.name).collect();
    let over = over_budget(4096, &all);
    assert!(over.is_empty(), "{over:#?}");
}

/// The bound for every filter at 65,536 pixels. Before 6 December 2026 À-Trous (and with it
/// auto and temporal) peaked at 3.2 GB on 1×65,536 and the guided filter at 246 MB on
/// 65,536×1; they now filter such shapes transposed (common/transpose.rs).
#[test]
fn memory_follows_the_pixel_count_on_every_shape() {
    let all: Vec<&str> = FILTERS.iter().map(|f| f.name).collect();
    let over = over_budget(1 << 16, &all);
    assert!(over.is_empty(), "{over:#?}");
}
