//! `lumo render` cut into chunks of samples that any process renders, added up exactly.
//!
//! A distributed render (the Python package's `lumo.ray`) plans the same command line on a
//! driver and on every worker: workers render chunks (frame, samples `first..first + count`)
//! into exact per-pixel sums ([`PixelSums`]) and ship them as bytes; the driver checks each
//! chunk and adds it to its frame's sums as it arrives ([`ChunkedRender::add`]), and once a
//! frame's samples are all in runs the pipeline and the writes of `lumo render` on the sums
//! ([`ChunkedRender::finish`]). Sums are integers, so the result is bit for bit the single-process render's,
//! however the samples were cut and in whatever order the chunks arrive.
//!
//! What cannot be added up per pixel is refused when planning: the light tracer, BDPT and
//! photon mapping (paths splatted across the image or a photon map shared by all passes), the
//! temporal filter (each frame depends on the one before) and the pipelines that trace more
//! than full paths per pixel (guided, jbu, atrous with --subsample).

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use lumo_render::PixelSums;

use crate::render::{Choices, Job, Plan, Ready, RenderArgs};

/// The words after `lumo render`, parsed by the command's own parser.
#[derive(Parser)]
#[command(name = "lumo render", no_binary_name = true)]
struct RenderLine {
    #[command(flatten)]
    args: RenderArgs,
}

/// Which side of a distributed render a plan is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Adds chunks up and writes the outputs: checks them (and makes `--aovs`) when planning.
    Driver,
    /// Renders chunks: writes nothing and checks no output path.
    Worker,
}

/// Samples `first..first + count` of every pixel of frame `frame` (0 for a still).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chunk {
    /// The frame (its number in `--frames`, 0 for a still).
    pub frame: u32,
    /// The first sample index.
    pub first: u32,
    /// Samples per pixel in the chunk.
    pub count: u32,
}

/// A rendered chunk: its exact per-pixel sums.
#[derive(Clone, Debug)]
pub struct ChunkSums {
    /// What was rendered.
    pub chunk: Chunk,
    /// The plan it was rendered for ([`ChunkedRender::plan_id`]).
    pub plan_id: u64,
    /// Per pixel, row-major.
    pub sums: Vec<PixelSums>,
}

/// What [`ChunkedRender::finish`] wrote.
#[derive(Clone, Debug)]
pub struct Finished {
    /// The image files.
    pub files: Vec<PathBuf>,
    /// The AOV directory, with `--aovs`.
    pub aovs: Option<PathBuf>,
    /// Camera samples traced.
    pub samples: u64,
    /// Rays traced.
    pub rays: u64,
}

/// Tag and layout version of a chunk's bytes.
const MAGIC: &[u8; 8] = b"LUMOCHNK";
const FORMAT: u32 = 1;
/// Bytes of a chunk's header before the per-pixel records, past the version string.
const HEADER_TAIL: usize = 8 + 4 * 5;

/// A `lumo render` command line planned for rendering in chunks.
pub struct ChunkedRender {
    args: RenderArgs,
    ready: Ready,
    plan_id: u64,
    /// The frame the render scene is posed at.
    posed: u32,
    /// Frames whose chunks are being added up.
    pending: std::collections::HashMap<u32, FrameSums>,
}

/// A frame's chunks added up so far.
struct FrameSums {
    /// Sample ranges added, in order of arrival.
    ranges: Vec<(u32, u32)>,
    sums: Vec<PixelSums>,
}

impl ChunkedRender {
    /// Plans `lumo render WORDS…` (the words after `render`) with every check of the command;
    /// a [`Role::Driver`] also checks the outputs and makes the `--aovs` directory.
    pub fn new(words: &[String], role: Role) -> Result<ChunkedRender> {
        let args = RenderLine::try_parse_from(words)
            .map_err(|e| anyhow!("{}", e.render().to_string().trim_end()))?
            .args;
        refuse_unaddable(&args)?;
        let plan = Plan::new(&args)?;
        let options = args
            .pipeline
            .options(plan.choices.settings.width, plan.choices.settings.height);
        if !plan.choices.pipeline.takes_sums(&options) {
            bail!(
                "--pipeline {}{}: this pipeline traces more than full paths per pixel (guide \
                 rays, a sparse or subsampled grid), which cannot be cut into sample chunks; \
                 use --pipeline auto, atrous (without --subsample), bilateral or none",
                plan.choices.pipeline,
                if options.subsample > 1 {
                    format!(" --subsample {}", options.subsample)
                } else {
                    String::new()
                }
            );
        }
        if role == Role::Driver {
            plan.check_outputs(&args)?;
        }
        let plan_id = plan_id(words, &args.scene)?;
        let ready = plan.build(&args, role == Role::Driver)?;
        let posed = ready
            .choices
            .sequence
            .as_ref()
            .map_or(0, |s| s.frames.first);
        Ok(ChunkedRender {
            args,
            ready,
            plan_id,
            posed,
            pending: Default::default(),
        })
    }

    /// A fingerprint of the command line, the scene file's bytes and lumo's version: chunks
    /// of another plan (another file at the same path on some node) are refused.
    pub fn plan_id(&self) -> u64 {
        self.plan_id
    }

    /// The frames to render: the `--frames` range, or `[0]` for a still.
    pub fn frames(&self) -> Vec<u32> {
        match &self.ready.choices.sequence {
            Some(s) => (s.frames.first..=s.frames.last).collect(),
            None => vec![0],
        }
    }

    /// Samples per pixel of every frame.
    pub fn spp(&self) -> u32 {
        self.ready.choices.settings.spp
    }

    /// Image width and height.
    pub fn size(&self) -> (usize, usize) {
        (
            self.ready.choices.settings.width,
            self.ready.choices.settings.height,
        )
    }

    /// Every frame cut into chunks of at most `chunk_spp` samples per pixel, frame by frame.
    pub fn chunks(&self, chunk_spp: u32) -> Vec<Chunk> {
        let step = chunk_spp.max(1);
        let spp = self.spp();
        self.frames()
            .into_iter()
            .flat_map(|frame| {
                (0..spp).step_by(step as usize).map(move |first| Chunk {
                    frame,
                    first,
                    count: step.min(spp - first),
                })
            })
            .collect()
    }

    /// Renders one chunk.
    pub fn render_chunk(&mut self, chunk: Chunk) -> Result<ChunkSums> {
        self.check_chunk(&chunk)?;
        self.pose(chunk.frame)?;
        let Ready {
            pool,
            rs,
            choices: Choices { settings, .. },
            ..
        } = &self.ready;
        let sums = pool
            .install(|| lumo_render::render_sums(rs, settings, chunk.first, chunk.count, &|_| {}));
        Ok(ChunkSums {
            chunk,
            plan_id: self.plan_id,
            sums,
        })
    }

    /// Adds a chunk to its frame's sums (the reduction: exact, so the order of arrival does
    /// not matter) and returns what it was. Refused: another plan, a frame or sample range
    /// outside the render, or samples already added.
    pub fn add(&mut self, c: ChunkSums) -> Result<Chunk> {
        if c.plan_id != self.plan_id {
            bail!(
                "a chunk of frame {} (samples {}..{}) was rendered for another plan: another \
                 lumo version, other options, or another file at the scene's path {:?}",
                c.chunk.frame,
                c.chunk.first,
                c.chunk.first + c.chunk.count,
                self.args.scene
            );
        }
        self.check_chunk(&c.chunk)?;
        let Chunk {
            frame,
            first,
            count,
        } = c.chunk;
        let pixels = self.size().0 * self.size().1;
        if c.sums.len() != pixels {
            bail!("a chunk of {} pixels for {pixels}", c.sums.len());
        }
        let acc = self.pending.entry(frame).or_insert_with(|| FrameSums {
            ranges: Vec::new(),
            sums: vec![PixelSums::default(); pixels],
        });
        if let Some(&(a, b)) = acc
            .ranges
            .iter()
            .find(|&&(a, b)| first < b && a < first + count)
        {
            bail!(
                "frame {frame}: samples {}..{} are given twice (chunk {first}..{} overlaps \
                 {a}..{b})",
                first.max(a),
                (first + count).min(b),
                first + count
            );
        }
        acc.ranges.push((first, first + count));
        for (a, b) in acc.sums.iter_mut().zip(&c.sums) {
            a.merge(b);
        }
        Ok(c.chunk)
    }

    /// Runs the pipeline on `frame`'s added-up sums, which must cover samples `0..spp`, and
    /// writes what `lumo render` writes for that frame.
    pub fn finish(&mut self, frame: u32) -> Result<Finished> {
        if !self.frames().contains(&frame) {
            bail!("frame {frame} is not one of this render's frames");
        }
        let spp = self.spp();
        let mut ranges = self
            .pending
            .get(&frame)
            .map(|f| f.ranges.clone())
            .unwrap_or_default();
        ranges.sort_unstable();
        let mut next = 0;
        for (a, b) in ranges.into_iter().chain([(spp, spp)]) {
            if a > next {
                bail!(
                    "frame {frame}: samples {next}..{a} are missing (chunks must cover 0..{spp})"
                );
            }
            next = b;
        }
        let sums = self
            .pending
            .remove(&frame)
            .map(|f| f.sums)
            .unwrap_or_default();
        self.pose(frame)?;
        let Ready {
            pool,
            rs,
            choices:
                Choices {
                    settings,
                    pipeline,
                    outputs,
                    sequence,
                    ..
                },
            ..
        } = &self.ready;
        let job = Job {
            args: &self.args,
            pipeline: *pipeline,
            settings: *settings,
            pool,
            outputs: outputs.clone(),
        };
        let out = job.render_sums(rs, sums)?;
        let (files, aovs): (Vec<PathBuf>, Option<PathBuf>) = match sequence {
            Some(seq) => (
                outputs.iter().map(|o| seq.frame_path(o, frame)).collect(),
                self.args.aovs.as_ref().map(|d| seq.frame_aov_dir(d, frame)),
            ),
            None => (outputs.clone(), self.args.aovs.clone()),
        };
        job.write(&out, &files, aovs.as_deref())
            .with_context(|| format!("frame {frame}"))?;
        Ok(Finished {
            files,
            aovs,
            samples: out.stats.samples,
            rays: out.stats.rays,
        })
    }

    /// Reads a chunk's bytes ([`ChunkSums::to_bytes`]) and checks them against this plan:
    /// lumo's version, the plan, the frame, the sample range and the image size.
    pub fn read_chunk(&self, bytes: &[u8]) -> Result<ChunkSums> {
        let c = ChunkSums::from_bytes(bytes, self.size())?;
        if c.plan_id != self.plan_id {
            bail!(
                "rendered for another plan: other options or another file at the scene's path \
                 {:?} (each node must read the same scene file)",
                self.args.scene
            );
        }
        self.check_chunk(&c.chunk)?;
        Ok(c)
    }

    fn check_chunk(&self, c: &Chunk) -> Result<()> {
        if !self.frames().contains(&c.frame) {
            bail!("frame {} is not one of this render's frames", c.frame);
        }
        if c.count == 0 || c.first.checked_add(c.count).is_none_or(|e| e > self.spp()) {
            bail!(
                "samples {}..+{} are not within 0..{} of this render",
                c.first,
                c.count,
                self.spp()
            );
        }
        Ok(())
    }

    fn pose(&mut self, frame: u32) -> Result<()> {
        if self.posed == frame {
            return Ok(());
        }
        if let Some(seq) = &self.ready.choices.sequence {
            let i = (frame - seq.frames.first) as usize;
            seq.pose_in(&self.ready.pool, &mut self.ready.rs, i, frame, true)?;
        }
        self.posed = frame;
        Ok(())
    }
}

/// Refuses what cannot be added up per pixel, naming the option.
fn refuse_unaddable(args: &RenderArgs) -> Result<()> {
    if args.list {
        bail!("--list: run `lumo render --list` to see the built-in scenes");
    }
    if !args.integrator.caps().gbuffer {
        use lumo_render::Integrator;
        bail!(
            "--integrator {}: a distributed render adds up camera samples per pixel; {} splat \
             paths across the image or share a photon map between passes. Render them with \
             `lumo render`, or use --integrator {}",
            args.integrator.name(),
            Integrator::names_where(|c| !c.gbuffer, "and"),
            Integrator::names_where(|c| c.gbuffer, "or")
        );
    }
    if args.temporal || args.temporal_eval.is_some() {
        bail!(
            "--temporal: the temporal filter carries each frame's history into the next, so \
             its frames cannot be rendered apart; render them with `lumo render --temporal`"
        );
    }
    Ok(())
}

/// FNV-1a of the words, the scene file's bytes (built-in scenes have none) and lumo's version.
/// `--threads` is left out: each node may use its own number of threads, which changes
/// nothing in the image.
fn plan_id(words: &[String], scene: &str) -> Result<u64> {
    let mut h = Fnv::default();
    h.write(env!("CARGO_PKG_VERSION").as_bytes());
    let mut skip = false;
    for w in words {
        if std::mem::take(&mut skip) {
            continue;
        }
        if w == "--threads" {
            skip = true;
            continue;
        }
        if w.starts_with("--threads=") {
            continue;
        }
        h.write(w.as_bytes());
        h.write(&[0]);
    }
    let path = std::path::Path::new(scene);
    if path.is_file() {
        let bytes = std::fs::read(path).with_context(|| format!("reading scene file {scene:?}"))?;
        h.write(&bytes);
    }
    Ok(h.0)
}

/// 64-bit FNV-1a: stable across builds and platforms, unlike std's hasher.
struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

impl ChunkSums {
    /// The chunk as bytes: a tagged header (format, lumo's version, plan, chunk, image size)
    /// and one fixed-size record per pixel.
    pub fn to_bytes(&self, (width, height): (usize, usize)) -> Vec<u8> {
        let version = env!("CARGO_PKG_VERSION").as_bytes();
        let mut out = Vec::with_capacity(
            MAGIC.len()
                + 5
                + version.len()
                + HEADER_TAIL
                + self.sums.len() * PixelSums::RECORD_BYTES,
        );
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT.to_le_bytes());
        out.push(version.len() as u8);
        out.extend_from_slice(version);
        out.extend_from_slice(&self.plan_id.to_le_bytes());
        for v in [
            self.chunk.frame,
            self.chunk.first,
            self.chunk.count,
            width as u32,
            height as u32,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for s in &self.sums {
            s.to_bytes(&mut out);
        }
        out
    }

    /// Reads [`ChunkSums::to_bytes`]'s bytes for an image of `size`, refusing anything else
    /// with what is wrong: not a chunk, another format or lumo version, another size, a
    /// truncated or damaged record.
    pub fn from_bytes(b: &[u8], size: (usize, usize)) -> Result<ChunkSums> {
        if b.len() < MAGIC.len() + 5 || &b[..8] != MAGIC {
            bail!("not a lumo chunk (no LUMOCHNK tag)");
        }
        let u32_at = |i: usize| -> Result<u32> {
            b.get(i..i + 4)
                .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
                .ok_or_else(|| anyhow!("truncated chunk header"))
        };
        let format = u32_at(8)?;
        if format != FORMAT {
            bail!("chunk format {format}, this lumo reads format {FORMAT}");
        }
        let vlen = b[12] as usize;
        let version = b
            .get(13..13 + vlen)
            .ok_or_else(|| anyhow!("truncated chunk header"))?;
        let ours = env!("CARGO_PKG_VERSION");
        if version != ours.as_bytes() {
            bail!(
                "rendered by lumo {}, this is lumo {ours}: install the same lumo on every node",
                String::from_utf8_lossy(version)
            );
        }
        let at = 13 + vlen;
        let mut id = [0u8; 8];
        id.copy_from_slice(
            b.get(at..at + 8)
                .ok_or_else(|| anyhow!("truncated chunk header"))?,
        );
        let [frame, first, count, w, h] = [0, 1, 2, 3, 4].map(|k| u32_at(at + 8 + 4 * k));
        let (w, h) = (w? as usize, h? as usize);
        if (w, h) != size {
            bail!("a {w}x{h} chunk for a {}x{} image", size.0, size.1);
        }
        let records = &b[at + HEADER_TAIL..];
        if records.len() != w * h * PixelSums::RECORD_BYTES {
            bail!(
                "{} bytes of pixel sums where a {w}x{h} chunk has {}",
                records.len(),
                w * h * PixelSums::RECORD_BYTES
            );
        }
        let count = count?;
        let mut sums = Vec::with_capacity(w * h);
        for (i, r) in records.chunks_exact(PixelSums::RECORD_BYTES).enumerate() {
            let s = PixelSums::from_bytes(r)
                .filter(|s| s.count == count)
                .ok_or_else(|| anyhow!("pixel {} of the chunk is damaged", i))?;
            sums.push(s);
        }
        Ok(ChunkSums {
            chunk: Chunk {
                frame: frame?,
                first: first?,
                count,
            },
            plan_id: u64::from_le_bytes(id),
            sums,
        })
    }
}

/// Renders `lumo render WORDS…` (a still, any integrator and pipeline) in this process and
/// returns the image instead of writing it: the Python package's render for what cannot be
/// cut into chunks (the light tracer, BDPT, photon mapping).
pub fn render_image(words: &[String]) -> Result<lumo_image::Image> {
    let args = RenderLine::try_parse_from(words)
        .map_err(|e| anyhow!("{}", e.render().to_string().trim_end()))?
        .args;
    if args.frames.is_some() {
        bail!("--frames: render one frame at a time here (--time T poses an animation)");
    }
    let ready = Plan::new(&args)?.build(&args, false)?;
    let job = Job {
        args: &args,
        pipeline: ready.choices.pipeline,
        settings: ready.choices.settings,
        pool: &ready.pool,
        outputs: Vec::new(),
    };
    Ok(job.render(&ready.rs, &|_| {})?.image)
}

/// The samples per pixel and `(width, height)` that `lumo render WORDS…` would use, from the
/// options and the scene file, without building the scene's BVH: what the Python package
/// reports as a scene's defaults before its first render.
pub fn planned_defaults(words: &[String]) -> Result<(u32, (usize, usize))> {
    let args = RenderLine::try_parse_from(words)
        .map_err(|e| anyhow!("{}", e.render().to_string().trim_end()))?
        .args;
    let plan = Plan::new(&args)?;
    Ok((
        plan.choices.settings.spp,
        (plan.choices.settings.width, plan.choices.settings.height),
    ))
}
