//! `lumo render --frames A..B --temporal-eval DIR`: the evidence for temporal filtering. Each
//! frame is traced once (at --spp, with the per-frame À-Trous pipeline, which also returns the
//! traced frame); the same traced frame goes through the temporal filter, so both filters see
//! identical input. A converged reference of every frame (--reference-spp, another seed)
//! scores both with FLIP. Written into DIR: `frames.csv` (per frame), `summary.md` (means,
//! flicker, time per stage, fps), `flip.png` (per-frame FLIP plot), `stability.png` (per-frame
//! output change of both filters and of the references) and `strip.png` (frames as 1 spp,
//! À-Trous, temporal, reference).
//!
//! Flicker is the mean absolute frame-to-frame change of the per-pixel FLIP error map,
//! mean_p |E_t(p) − E_{t−1}(p)|: an error that stays put (a smooth bias) does not flicker, one
//! that jumps from frame to frame (noise, boiling blotches) does. "Output change" is the mean
//! absolute frame-to-frame change of the displayed image (sRGB of the clamped linear value, 0–1
//! per channel); on a still camera it should approach the references' own.

use crate::cli_common::{errln, out};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use anyhow::{Context, Result};
use lumo_image::metrics::{flip_map, FlipSettings};
use lumo_image::{linear_to_srgb, read_image, write_image, Image};
use lumo_pipeline::{run_pipeline, Pipeline};
use lumo_render::{RenderScene, RenderSettings};

use super::frames::frame_seed;
use super::job::Job;
use super::sequence::Sequence;
use super::stage_clock::{cpu_clock, Mark};
use super::temporal::TemporalSequence;

/// Frames whose FLIP the summary leaves out: the temporal history is still short (SVGF's
/// blend weight reaches α = 0.2 after 1/α = 5 frames; 8 leaves a margin).
pub const WARM_UP: usize = 8;

/// One frame's scores and times.
#[derive(Clone, Copy, Debug, Default)]
struct Row {
    frame: u32,
    flip_raw: f64,
    flip_atrous: f64,
    flip_temporal: f64,
    /// Flicker of each against the previous frame (0 for the first).
    flicker_atrous: f64,
    flicker_temporal: f64,
    /// Output change of each and of the reference.
    change_atrous: f64,
    change_temporal: f64,
    change_reference: f64,
    /// FLIP summed over each [`PixelClass`] and divided by the pixel count (the classes'
    /// shares of the mean), per-frame À-Trous then temporal.
    by_class: [[f64; 3]; 2],
    update: Duration,
    trace: Duration,
    spatial: Duration,
    motion: Duration,
    reshade: Duration,
    split: Duration,
    /// Of `split`, the shadow ratio's filter.
    split_filter: Duration,
    temporal: Duration,
    /// The whole temporal filtering, wall clock (stages may overlap).
    total: Duration,
}

/// What the previous frame left for the frame-to-frame measures.
struct Previous {
    maps: [Image; 2],
    shown: [Image; 3],
}

/// Runs the evaluation; see the module doc.
pub fn run(
    seq: &Sequence,
    job: &Job,
    mut rs: RenderScene,
    dir: &Path,
    reference_spp: u32,
) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!(
            "--temporal-eval {}: a file of that name exists; name a directory for the results",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir).with_context(|| format!("--temporal-eval {}", dir.display()))?;
    let settings = job.settings;
    let options = job.args.pipeline.options(settings.width, settings.height);
    let scene_id = scene_identity(job.args);
    let mut temporal = TemporalSequence::new(
        seq.animated(),
        (settings.spp == 1).then_some(settings.path),
        super::temporal::splits_direct_light(&settings.path),
    )
    .context("temporal filter")?
    .deforming(seq.deforming_meshes());
    let flip = FlipSettings::default();
    let mut rows = Vec::new();
    let mut prev: Option<Previous> = None;
    let strip_at = strip_frames(seq.frames.count() as usize);
    let mut strip = Vec::new();
    let none = |_: f32| {};
    // Tuning aid: LUMO_TEMPORAL_DUMP=N writes frame N's images into DIR/dump/.
    let dump_at: Option<u32> = std::env::var("LUMO_TEMPORAL_DUMP")
        .ok()
        .and_then(|v| v.parse().ok());
    for (i, frame) in (seq.frames.first..=seq.frames.last).enumerate() {
        let mut row = Row {
            frame,
            ..Row::default()
        };
        if let Some((_, took)) = seq.pose(job, &mut rs, i, frame)? {
            row.update = took;
        }
        // A new sample sequence every frame, as a real-time renderer draws new random numbers:
        // with one seed a still camera would see the same noise every frame, which no
        // temporal filter can average away (and which would not flicker either).
        let traced = RenderSettings {
            seed: frame_seed(settings.seed, frame),
            ..settings
        };
        // On the CPU clock (`LUMO_STAGE_CLOCK=cpu`, timing runs: `--reference-spp 0`, which
        // scores nothing) the trace runs alone, so that its CPU time is the trace's: the
        // pipeline's own timings are wall clock, and the per-frame À-Trous would share its CPU
        // time. The temporal filter gets the same traced frame either way.
        let trace_alone = reference_spp == 0 && cpu_clock();
        let mark = Mark::now();
        let pipeline = if trace_alone {
            Pipeline::None
        } else {
            Pipeline::Atrous
        };
        let out = job
            .pool
            .install(|| run_pipeline(&rs, pipeline, &traced, &options, &none))
            .map_err(crate::pipeline_args::describe_pipeline_error)?;
        if trace_alone {
            row.trace = mark.elapsed();
        } else {
            row.trace = out.timings.trace;
            row.spatial = out.timings.filter + out.timings.compose;
        }
        // The temporal filter's own trace: the same randomisation through the jittered camera
        // (no jitter: the frame above).
        let nominal = rs.scene.camera.clone();
        let (camera, jitter) = temporal.camera(&nominal, settings.width, settings.height, i);
        let jittered = if jitter != [0.0; 2] {
            rs.scene.camera = camera;
            let o = job
                .pool
                .install(|| run_pipeline(&rs, Pipeline::None, &traced, &options, &none));
            rs.scene.camera = nominal.clone();
            Some(o.map_err(crate::pipeline_args::describe_pipeline_error)?)
        } else {
            None
        };
        let tframe = jittered.as_ref().map_or(&out.frame, |o| &o.frame);
        // Tuning (`jm`): the jittered samples accumulate on the unjittered grid (motion from
        // the nominal cameras), so the history converges to the pixel's area average.
        let unjittered_motion = super::temporal::tuned("jm").is_some_and(|v| v != 0.0);
        rs.scene.camera = match jittered {
            Some(_) if !unjittered_motion => {
                camera_for_filter(&nominal, settings.width, settings.height, jitter)
            }
            _ => nominal.clone(),
        };
        let filter_jitter = if unjittered_motion { [0.0; 2] } else { jitter };
        let filtered = job
            .pool
            .install(|| temporal.filter(&rs, tframe, filter_jitter, traced.seed));
        rs.scene.camera = nominal;
        let (filtered, times) =
            filtered.with_context(|| format!("frame {frame}: temporal filter"))?;
        row.motion = times.motion;
        row.reshade = times.reshade;
        row.split = times.split;
        row.split_filter = times.split_filter;
        row.total = times.total;
        row.temporal = times.filter;
        if reference_spp > 0 {
            let reference = RenderSettings {
                spp: reference_spp,
                // Another sample sequence: the 1-spp frame must not be part of its reference.
                seed: settings.seed.wrapping_add(0x5eed_0000 ^ frame),
                ..settings
            };
            // Kept in DIR/references/ and reused by a later run of the same sequence (the
            // references cost far more than everything else). The name carries a hash of
            // everything the image depends on: a name of frame, size and spp alone once
            // scored another scene against this one's references without a word.
            let key = reference_key(&scene_id, &reference, &options, &rs);
            let cached = dir.join("references").join(format!(
                "{frame:06}_{}x{}_{reference_spp}spp_{key:016x}.exr",
                settings.width, settings.height
            ));
            let r = match read_image(&cached) {
                Ok(img) => img,
                Err(_) => {
                    let img = job
                        .pool
                        .install(|| run_pipeline(&rs, Pipeline::None, &reference, &options, &none))
                        .map_err(crate::pipeline_args::describe_pipeline_error)?
                        .image;
                    std::fs::create_dir_all(dir.join("references"))?;
                    write_image(&cached, &img)?;
                    img
                }
            };
            let map = |img: &Image| flip_map(&r, img, &flip).context("FLIP");
            let maps = [map(&out.image)?, map(&filtered)?];
            row.flip_raw = mean(&map(&out.frame.color)?);
            row.flip_atrous = mean(&maps[0]);
            row.flip_temporal = mean(&maps[1]);
            let classes = pixel_classes(&out.frame);
            row.by_class = [0, 1].map(|k| class_means(&maps[k], &classes));
            let shown = [shown(&out.image), shown(&filtered), shown(&r)];
            if let Some(p) = &prev {
                row.flicker_atrous = mean_abs_diff(&maps[0], &p.maps[0]);
                row.flicker_temporal = mean_abs_diff(&maps[1], &p.maps[1]);
                row.change_atrous = mean_abs_diff(&shown[0], &p.shown[0]);
                row.change_temporal = mean_abs_diff(&shown[1], &p.shown[1]);
                row.change_reference = mean_abs_diff(&shown[2], &p.shown[2]);
            }
            if dump_at == Some(frame) {
                let d = dir.join("dump");
                std::fs::create_dir_all(&d)?;
                for (name, img) in [
                    ("noisy", &out.frame.color),
                    ("atrous", &out.image),
                    ("temporal", &filtered),
                    ("reference", &r),
                ] {
                    write_image(&d.join(format!("{frame:06}_{name}.exr")), img)?;
                }
            }
            if strip_at.contains(&i) {
                strip.push([
                    out.frame.color.clone(),
                    out.image.clone(),
                    filtered.clone(),
                    r,
                ]);
            }
            prev = Some(Previous { maps, shown });
        }
        // Without references there is no FLIP to show (zeros read as perfect scores).
        let flip = if reference_spp > 0 {
            format!(
                "FLIP 1 spp {:.4} · À-Trous {:.4} · temporal {:.4}",
                row.flip_raw, row.flip_atrous, row.flip_temporal
            )
        } else {
            "FLIP n/a (--reference-spp 0)".to_string()
        };
        errln!(
            "frame {frame}: {flip} · trace {:.1} ms · update {:.2} ms · spatial {:.1} ms · temporal {:.1} ms (+{:.1} ms motion, +{:.1} ms re-shading, +{:.1} ms direct split)",
            ms(row.trace),
            ms(row.update),
            ms(row.spatial),
            ms(row.temporal),
            ms(row.motion),
            ms(row.reshade),
            ms(row.split)
        );
        rows.push(row);
    }
    std::fs::write(dir.join("frames.csv"), csv(&rows))?;
    let summary = summary(&rows, &settings, reference_spp);
    std::fs::write(dir.join("summary.md"), &summary)?;
    out!("{summary}");
    if reference_spp > 0 {
        write_image(&dir.join("flip.png"), &plot(&rows))?;
        write_image(&dir.join("stability.png"), &stability_plot(&rows))?;
        if !strip.is_empty() {
            write_image(&dir.join("strip.png"), &tile(&strip))?;
        }
    }
    Ok(())
}

/// The camera the temporal filter must see for a frame traced with `jitter`: the jittered one
/// (its motion vectors and instance ids follow the traced pixels).
fn camera_for_filter(
    nominal: &lumo_scene::Camera,
    w: usize,
    h: usize,
    jitter: [f32; 2],
) -> lumo_scene::Camera {
    super::temporal::jittered_camera(nominal, w, h, jitter)
}

/// Where a pixel's error comes from, for the breakdown in the summary: next to a directly
/// seen light (within 2 pixels: the light's aliased border), at a geometric edge (a depth,
/// normal or background step in its 3×3 neighbourhood), or in a flat region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PixelClass {
    LightRim = 0,
    Edge = 1,
    Flat = 2,
}

/// The class of every pixel of a traced frame (from its G-buffer at the pixel centres).
fn pixel_classes(frame: &lumo_render::Frame) -> Vec<PixelClass> {
    let (w, h) = (frame.width(), frame.height());
    let emitter: Vec<bool> = frame
        .emission
        .data
        .chunks_exact(3)
        .map(|e| e.iter().any(|&v| v != 0.0))
        .collect();
    let depth = |i: usize| {
        let d = frame.depth.data[i * frame.depth.channels];
        if d.is_finite() && d > 0.0 {
            d
        } else {
            0.0
        }
    };
    let normal = |i: usize| {
        let n = &frame.normal.data[3 * i..3 * i + 3];
        [n[0], n[1], n[2]]
    };
    let mut out = vec![PixelClass::Flat; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let near = |r: usize, f: &dyn Fn(usize) -> bool| {
                (y.saturating_sub(r)..(y + r + 1).min(h))
                    .any(|yy| (x.saturating_sub(r)..(x + r + 1).min(w)).any(|xx| f(yy * w + xx)))
            };
            if near(2, &|j| emitter[j]) {
                out[i] = PixelClass::LightRim;
                continue;
            }
            let (d, n) = (depth(i), normal(i));
            let step = |j: usize| {
                let (dj, nj) = (depth(j), normal(j));
                if (d == 0.0) != (dj == 0.0) {
                    return true;
                }
                if d == 0.0 {
                    return false;
                }
                let dot = n[0] * nj[0] + n[1] * nj[1] + n[2] * nj[2];
                (d - dj).abs() > 0.05 * d || dot.is_nan() || dot < 0.9
            };
            if near(1, &step) {
                out[i] = PixelClass::Edge;
            }
        }
    }
    out
}

/// A FLIP map's sum over each class, divided by the pixel count.
fn class_means(map: &Image, classes: &[PixelClass]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for (v, c) in map.data.iter().zip(classes) {
        if v.is_finite() {
            s[*c as usize] += *v as f64;
        }
    }
    s.map(|v| v / classes.len().max(1) as f64)
}

/// The seed of frame `frame` of a temporally filtered sequence: a different randomisation of
/// the samples every frame (the multiplier is odd, so frames never share a seed).
/// What names the scene a run renders, for [`reference_key`]: the scene argument, its file's
/// size and modification time where it is a file, and the `-D` definitions.
fn scene_identity(args: &super::args::RenderArgs) -> String {
    let stamp = std::fs::metadata(&args.scene)
        .ok()
        .map(|m| (m.len(), m.modified().ok()));
    format!("{:?} {stamp:?} {:?}", args.scene, args.defines)
}

/// A hash of what a reference frame depends on: the scene (`scene_id`), the reference's
/// settings and pipeline options, and the frame's pose (camera and instance placements).
fn reference_key(
    scene_id: &str,
    reference: &RenderSettings,
    options: &lumo_pipeline::PipelineOptions,
    rs: &RenderScene,
) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    scene_id.hash(&mut h);
    format!("{reference:?} {options:?} {:?}", rs.scene.camera).hash(&mut h);
    for instance in &rs.scene.instances {
        instance.mesh.hash(&mut h);
        for v in instance.transform.to_cols_array() {
            v.to_bits().hash(&mut h);
        }
    }
    h.finish()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn mean(map: &Image) -> f64 {
    let (s, n) = map
        .data
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0f64, 0usize), |(s, n), &v| (s + v as f64, n + 1));
    s / n.max(1) as f64
}

fn mean_abs_diff(a: &Image, b: &Image) -> f64 {
    let (s, n) = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .fold((0.0f64, 0usize), |(s, n), (x, y)| {
            (s + (x - y).abs() as f64, n + 1)
        });
    s / n.max(1) as f64
}

/// The image as displayed: sRGB of the clamped linear value.
fn shown(img: &Image) -> Image {
    let data = img
        .data
        .iter()
        .map(|&v| {
            linear_to_srgb(if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                0.0
            })
        })
        .collect();
    Image::from_vec(img.width, img.height, img.channels, data)
}

/// Up to four frames for the strip: the end of the warm-up, two in between, the last.
fn strip_frames(count: usize) -> Vec<usize> {
    let last = count.saturating_sub(1);
    let mut at = vec![WARM_UP.min(last), last / 3, 2 * last / 3, last];
    at.sort_unstable();
    at.dedup();
    at
}

fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "frame,flip_1spp,flip_atrous,flip_temporal,flicker_atrous,flicker_temporal,change_atrous,change_temporal,change_reference,update_ms,trace_ms,spatial_ms,motion_ms,reshade_ms,split_ms,temporal_ms,frame_ms\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.3},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2}",
            r.frame,
            r.flip_raw,
            r.flip_atrous,
            r.flip_temporal,
            r.flicker_atrous,
            r.flicker_temporal,
            r.change_atrous,
            r.change_temporal,
            r.change_reference,
            ms(r.update),
            ms(r.trace),
            ms(r.spatial),
            ms(r.motion),
            ms(r.reshade),
            ms(r.split),
            ms(r.temporal),
            // The temporal frame's wall clock (its stages partly run side by side).
            ms(r.trace + r.update + r.total)
        );
    }
    s
}

fn summary(rows: &[Row], settings: &RenderSettings, reference_spp: u32) -> String {
    let after: Vec<&Row> = rows.iter().skip(WARM_UP).collect();
    let avg = |f: &dyn Fn(&Row) -> f64, rs: &[&Row]| {
        rs.iter().map(|r| f(r)).sum::<f64>() / rs.len().max(1) as f64
    };
    let all: Vec<&Row> = rows.iter().collect();
    // Frame-to-frame measures from the second frame on (the first has no predecessor).
    let pairs: Vec<&Row> = rows.iter().skip(WARM_UP.max(1)).collect();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} frames at {}x{}, {} spp per frame{}",
        rows.len(),
        settings.width,
        settings.height,
        settings.spp,
        if reference_spp > 0 {
            format!(", references at {reference_spp} spp")
        } else {
            String::new()
        }
    );
    // The frame the averages start at (the rows are frames in order from the range's first).
    let from = after.first().map(|r| r.frame);
    if reference_spp > 0 && from.is_none() {
        let _ = writeln!(
            s,
            "\nNo quality summary: it averages the frames after the first {WARM_UP} (the \
             temporal history's warm-up), and this run has {}; render more frames for it \
             (frames.csv has each frame's scores).",
            rows.len()
        );
    }
    if let (true, Some(from)) = (reference_spp > 0, from) {
        let (fa, ft) = (
            avg(&|r| r.flip_atrous, &after),
            avg(&|r| r.flip_temporal, &after),
        );
        let _ = writeln!(s, "\n| from frame {from} | 1 spp | per-frame À-Trous | temporal | temporal / À-Trous |\n|---|---:|---:|---:|---:|");
        let _ = writeln!(
            s,
            "| mean FLIP | {:.4} | {fa:.4} | {ft:.4} | {:.2} |",
            avg(&|r| r.flip_raw, &after),
            ft / fa
        );
        let (ka, kt) = (
            avg(&|r| r.flicker_atrous, &pairs),
            avg(&|r| r.flicker_temporal, &pairs),
        );
        let _ = writeln!(
            s,
            "| flicker (mean abs. change of the FLIP map) | | {ka:.4} | {kt:.4} | {:.2} |",
            kt / ka
        );
        let _ = writeln!(
            s,
            "| output change (reference: {:.4}) | | {:.4} | {:.4} | |",
            avg(&|r| r.change_reference, &pairs),
            avg(&|r| r.change_atrous, &pairs),
            avg(&|r| r.change_temporal, &pairs)
        );
        let _ = writeln!(
            s,
            "\n| share of the mean FLIP from frame {from} | light rim | edges | flat |\n|---|---:|---:|---:|"
        );
        for (k, name) in ["per-frame À-Trous", "temporal"].iter().enumerate() {
            let c = |j: usize| avg(&|r| r.by_class[k][j], &after);
            let _ = writeln!(s, "| {name} | {:.4} | {:.4} | {:.4} |", c(0), c(1), c(2));
        }
    }
    let t = |f: &dyn Fn(&Row) -> Duration| avg(&|r| ms(f(r)), &all);
    let (trace, update, spatial, motion, reshade, split, temporal) = (
        t(&|r| r.trace),
        t(&|r| r.update),
        t(&|r| r.spatial),
        t(&|r| r.motion),
        t(&|r| r.reshade),
        t(&|r| r.split),
        t(&|r| r.temporal),
    );
    let frame_atrous = trace + update + spatial;
    // Wall clock: the stages above overlap where they run side by side.
    let frame_temporal = trace + update + t(&|r| r.total);
    let _ = writeln!(s, "\n| stage (mean per frame) | ms |\n|---|---:|");
    for (name, v) in [
        ("trace (1 spp, G-buffer)", trace),
        ("BVH update (pose)", update),
        ("spatial filter (per-frame À-Trous)", spatial),
        ("motion vectors (+ instance ids when animated)", motion),
        (
            "re-shading (1 path per 3×3 block, history rejection)",
            reshade,
        ),
        (
            "direct-light split (its rays and the shadow ratio's filter)",
            split,
        ),
        (
            "… of which the shadow ratio's filter",
            t(&|r| r.split_filter),
        ),
        ("temporal filter (SVGF)", temporal),
    ] {
        let _ = writeln!(s, "| {name} | {v:.2} |");
    }
    let _ = writeln!(
        s,
        "| **frame, per-frame À-Trous** | {frame_atrous:.1} ({:.1} fps) |\n| **frame, temporal** | {frame_temporal:.1} ({:.1} fps) |",
        1e3 / frame_atrous,
        1e3 / frame_temporal
    );
    s
}

/// Per-frame FLIP: per-frame À-Trous in red, temporal in blue, the warm-up boundary in grey,
/// on a dark ground with a grid line every 0.05.
fn plot(rows: &[Row]) -> Image {
    plot_series(
        rows,
        &[
            (&|r: &Row| r.flip_atrous, [0.9, 0.1, 0.05]),
            (&|r: &Row| r.flip_temporal, [0.1, 0.3, 1.0]),
        ],
        0.05,
    )
}

/// The temporal-stability plot: the mean frame-to-frame change of the displayed image, per
/// frame, for per-frame À-Trous (red), temporal (blue) and the references (white: the change
/// the motion itself causes), grid every 0.01.
fn stability_plot(rows: &[Row]) -> Image {
    plot_series(
        rows,
        &[
            (&|r: &Row| r.change_reference, [0.8, 0.8, 0.8]),
            (&|r: &Row| r.change_atrous, [0.9, 0.1, 0.05]),
            (&|r: &Row| r.change_temporal, [0.1, 0.3, 1.0]),
        ],
        0.01,
    )
}

/// One line of a plot: its value per frame and its colour.
type Series<'a> = (&'a dyn Fn(&Row) -> f64, [f32; 3]);

/// A line per series over the frames, the warm-up boundary in grey, on a dark ground with a
/// grid line every `step`.
fn plot_series(rows: &[Row], series: &[Series], step: f64) -> Image {
    let (w, h, pad) = (720usize, 300usize, 10usize);
    let mut img = Image::new(w, h, 3, 0.01);
    let top = rows
        .iter()
        .flat_map(|r| series.iter().map(move |(f, _)| f(r)))
        .fold(step, f64::max);
    let top = (top / step).ceil() * step;
    let n = rows.len().max(2);
    let x_of = |i: usize| pad + i * (w - 2 * pad - 1) / (n - 1);
    let y_of =
        |v: f64| h - pad - 1 - ((v / top).clamp(0.0, 1.0) * (h - 2 * pad - 1) as f64) as usize;
    let set = |img: &mut Image, x: usize, y: usize, c: [f32; 3]| {
        if x < w && y < h {
            img.pixel_mut(x, y).copy_from_slice(&c);
        }
    };
    let mut g = 0.0;
    while g <= top + 1e-9 {
        for x in pad..w - pad {
            set(&mut img, x, y_of(g), [0.05; 3]);
        }
        g += step;
    }
    for y in pad..h - pad {
        set(&mut img, x_of(WARM_UP.min(n - 1)), y, [0.15; 3]);
    }
    for &(value, colour) in series {
        for i in 1..rows.len() {
            let (x0, x1) = (x_of(i - 1), x_of(i));
            let (y0, y1) = (y_of(value(&rows[i - 1])), y_of(value(&rows[i])));
            for x in x0..=x1 {
                let t = if x1 > x0 {
                    (x - x0) as f64 / (x1 - x0) as f64
                } else {
                    0.0
                };
                let y = y0 as f64 + t * (y1 as f64 - y0 as f64);
                let (lo, hi) = if x == x1 {
                    (y.min(y1 as f64), y.max(y1 as f64))
                } else {
                    (y, y)
                };
                for yy in lo.round() as usize..=hi.round() as usize {
                    set(&mut img, x, yy, colour);
                    set(&mut img, x, yy + 1, colour);
                }
            }
        }
    }
    img
}

/// Rows of frames, columns 1 spp, per-frame À-Trous, temporal, reference, 2-pixel gaps.
fn tile(rows: &[[Image; 4]]) -> Image {
    let (fw, fh) = (rows[0][0].width, rows[0][0].height);
    let gap = 2;
    let (w, h) = (4 * fw + 3 * gap, rows.len() * fh + (rows.len() - 1) * gap);
    let mut out = Image::new(w, h, 3, 0.0);
    for (r, row) in rows.iter().enumerate() {
        for (c, img) in row.iter().enumerate() {
            for y in 0..fh {
                for x in 0..fw {
                    let p = img.pixel(x, y);
                    out.pixel_mut(c * (fw + gap) + x, r * (fh + gap) + y)
                        .copy_from_slice(&p[..3]);
                }
            }
        }
    }
    out
}
