//! `lumo render --frames A..B`: a numbered image sequence. Each frame poses the animated glTF
//! scene at t = frame / fps and updates the render scene in place (BVH refit and re-placed
//! instances, lights recomputed: `RenderScene::pose`) rather than rebuilding it, and/or turns
//! the camera (`--orbit`). See docs/animation.md.

use crate::cli_common::{errln, outln};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use lumo_render::{LightPilot, RenderScene, SceneUpdate};
use lumo_scene::animation::NodeItem;
use lumo_scene::{AnimatedScene, Camera, Scene};

use super::args::RenderArgs;
use super::frames::{frame_digits, frame_file, frame_seed, FrameRange, DEFAULT_FPS};
use super::job::Job;
use super::temporal::TemporalSequence;
use crate::output::si;

/// A planned `--frames` run: what moves and how.
pub struct Sequence {
    /// The frames.
    pub frames: FrameRange,
    /// Frames per second.
    pub fps: f32,
    /// The scene's animation, when it has one.
    rig: Option<AnimatedScene>,
    /// `--orbit`: total angle and the point turned about.
    orbit: Option<(f32, Vec3)>,
    /// The camera before any orbit (at the first frame's pose).
    camera: Camera,
    /// `--light-selection pilot`: the image size the light pilot runs for after each pose
    /// (`None`: the choice by power).
    pub light_pilot: Option<(usize, usize)>,
}

impl Sequence {
    /// Checks the sequence options against the scene and poses `scene` at the first frame.
    /// Refuses a sequence in which nothing would move.
    pub fn plan(
        args: &RenderArgs,
        frames: FrameRange,
        scene: &mut Scene,
        rig: Option<AnimatedScene>,
    ) -> Result<Sequence> {
        let fps = args.fps.unwrap_or(DEFAULT_FPS);
        let is_gltf = rig.is_some();
        // A glTF camera (animated scene or not) has no look-at target: see the orbit below.
        let gltf_camera = rig
            .as_ref()
            .is_some_and(|r| r.items.iter().any(|(_, i)| *i == NodeItem::Camera));
        let rig = rig.filter(AnimatedScene::is_animated);
        let range = format!("--frames {}..{}", frames.first, frames.last);
        // An orbit of 0° moves nothing: the same frames as no orbit at all.
        let orbits = args.orbit.is_some_and(|deg| deg != 0.0);
        if rig.is_none() && args.orbit == Some(0.0) {
            bail!(
                "--orbit 0: scene {:?} has no animation, so every frame would be the same; give \
                 the orbit an angle (e.g. --orbit 360), or drop --frames to render a still",
                scene.name
            );
        }
        if rig.is_none() && args.fps.is_some() && orbits {
            errln!(
                "warning: --fps has no effect: scene {:?} has no animation, and an orbit is \
                 spread over the frames whatever the rate",
                scene.name
            );
        }
        if rig.is_none() && args.orbit.is_none() {
            let why = if is_gltf {
                "the glTF file has no animation clips"
            } else if Path::new(&args.scene).extension().is_some() || args.scene.contains('/') {
                "only glTF files carry animation"
            } else {
                "built-in scenes are static"
            };
            bail!(
                "{range}: scene {:?} has no animation ({why}), so every frame would be the same; \
                 add --orbit DEGREES to turn the camera about the scene (e.g. --orbit 360), or \
                 drop --frames to render a still",
                scene.name
            );
        }
        if let Some(rig) = &rig {
            if args.orbit.is_some() && rig.moves(NodeItem::Camera) {
                bail!(
                    "--orbit: the glTF camera{} is keyframed and moves by itself; drop --orbit, or \
                     choose a camera that stands still with --camera N",
                    args.camera.map(|c| format!(" {c}")).unwrap_or_default()
                );
            }
            rig.pose(scene, Some(frames.first as f32 / fps));
        }
        let orbit = args.orbit.map(|deg| {
            // A glTF camera has no look-at target (the loader puts one a unit ahead): turn about
            // the point of its view axis nearest the scene's centre instead.
            let c = &scene.camera;
            let pivot = if gltf_camera {
                let (lo, hi) = scene.bounds();
                let dir = (c.target - c.origin).normalize_or_zero();
                c.origin + dir * ((lo + hi) * 0.5 - c.origin).dot(dir).max(0.0)
            } else {
                c.target
            };
            (deg, pivot)
        });
        Ok(Sequence {
            frames,
            fps,
            rig,
            orbit,
            camera: scene.camera.clone(),
            light_pilot: None,
        })
    }

    /// Moves the scene to frame `frame` (the `i`-th of the run): poses the animation (not for
    /// the first frame, which [`Sequence::plan`] posed) and turns the orbit. Returns how the
    /// render scene was updated and how long that took, when it was.
    pub fn pose(
        &self,
        job: &Job,
        rs: &mut RenderScene,
        i: usize,
        frame: u32,
    ) -> Result<Option<(SceneUpdate, Duration)>> {
        self.pose_in(job.pool, rs, i, frame, i > 0)
    }

    /// [`Sequence::pose`] in `pool`, posing the animation also at the first frame when
    /// `animate` (a distributed render's worker may render the frames in any order).
    pub fn pose_in(
        &self,
        pool: &rayon::ThreadPool,
        rs: &mut RenderScene,
        i: usize,
        frame: u32,
        animate: bool,
    ) -> Result<Option<(SceneUpdate, Duration)>> {
        let t = frame as f32 / self.fps;
        let mut updated = None;
        if let (Some(rig), true) = (&self.rig, animate) {
            // Timed inside the pool: handing the call to a sleeping worker thread takes
            // longer than the update itself (a few µs vs about 2 ms measured).
            let (kind, took) = pool.install(|| {
                let posing = Instant::now();
                (rs.pose(rig, t), posing.elapsed())
            });
            let kind =
                kind.with_context(|| format!("frame {frame} (t = {t} s): posing the scene"))?;
            updated = Some((kind, took));
        }
        if let Some((deg, pivot)) = self.orbit {
            let count = self.frames.count();
            rs.scene.camera = self.camera.orbited(pivot, deg * i as f32 / count as f32);
        }
        // A new pose or camera: the light pilot measures it afresh (deterministic, so a frame
        // equals a still of its pose whichever frames came before).
        if let (Some((w, h)), true) = (self.light_pilot, updated.is_some() || self.orbit.is_some())
        {
            pool.install(|| rs.select_lights_by_pilot(w, h, &LightPilot::default()));
        }
        Ok(updated)
    }

    /// Whether instances move from frame to frame (an animation; an orbit moves only the
    /// camera).
    pub fn animated(&self) -> bool {
        self.rig.is_some()
    }

    /// The meshes that skins or morph targets deform (indices into the scene's meshes).
    pub fn deforming_meshes(&self) -> Vec<usize> {
        self.rig.as_ref().map_or_else(Vec::new, |rig| {
            rig.deformers.iter().map(|d| d.mesh).collect()
        })
    }

    /// The file of `frame` for output `base`.
    pub fn frame_path(&self, base: &Path, frame: u32) -> PathBuf {
        frame_file(base, frame, frame_digits(self.frames.last))
    }

    /// The directory of `frame`'s AOV planes under `--aovs dir`.
    pub fn frame_aov_dir(&self, dir: &Path, frame: u32) -> PathBuf {
        dir.join(format!("{frame:0w$}", w = frame_digits(self.frames.last)))
    }

    /// Renders every frame of the sequence; `rs` is built at the first frame's pose, which
    /// took `build`.
    pub fn run(self, job: &Job, mut rs: RenderScene, build: Duration) -> Result<()> {
        let count = self.frames.count();
        let bar = ProgressBar::new(count as u64 * 1000).with_style(
            ProgressStyle::with_template(
                "{bar:40} {percent:>3}%  frame {msg}  {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let start = Instant::now();
        let mut update = Duration::ZERO;
        let (mut refits, mut rebuilds) = (0u32, 0u32);
        let (mut samples, mut rays) = (0u64, 0u64);
        let mut temporal = if job.args.temporal {
            let s = &job.settings;
            // Reprojection and motion vectors are a pinhole's.
            if rs.scene.camera.lens != lumo_scene::Lens::Pinhole {
                bail!(
                    "{}: --temporal reprojects frames through a pinhole camera; this scene's \
                     camera is a thin lens or orthographic (render without --temporal)",
                    rs.scene.name
                );
            }
            let reshade = (s.spp == 1).then_some(s.path);
            let split = super::temporal::splits_direct_light(&s.path);
            Some(
                TemporalSequence::new(self.rig.is_some(), reshade, split)
                    .context("--temporal")?
                    .deforming(self.deforming_meshes()),
            )
        } else {
            None
        };
        for (i, frame) in (self.frames.first..=self.frames.last).enumerate() {
            bar.set_message(format!("{frame} ({}/{count})", i + 1));
            if let Some((kind, took)) = self.pose(job, &mut rs, i, frame)? {
                update += took;
                match kind {
                    SceneUpdate::Refitted => refits += 1,
                    SceneUpdate::RebuiltAccel | SceneUpdate::Rebuilt => rebuilds += 1,
                }
            }
            let base = i as u64 * 1000;
            let progress = |f: f32| bar.set_position(base + (f * 1000.0) as u64);
            let mut jitter = [0.0; 2];
            let nominal = rs.scene.camera.clone();
            let seed = frame_seed(job.settings.seed, frame);
            let mut out = match &temporal {
                // New random numbers every frame, for the filter to average, through a camera
                // jittered by a sub-pixel offset, for its anti-aliasing.
                Some(t) => {
                    let (w, h) = (job.settings.width, job.settings.height);
                    let (camera, j) = t.camera(&nominal, w, h, i);
                    jitter = j;
                    rs.scene.camera = camera;
                    job.with_seed(seed).render(&rs, &progress)?
                }
                None => job.render(&rs, &progress)?,
            };
            if let (Some(t), Some((traced, _))) = (&mut temporal, &out.aovs) {
                let (image, _) = job
                    .pool
                    .install(|| t.filter(&rs, traced, jitter, seed))
                    .with_context(|| format!("frame {frame}: temporal filter"))?;
                out.image = image;
            }
            rs.scene.camera = nominal;
            samples += out.stats.samples;
            rays += out.stats.rays;
            let files: Vec<PathBuf> = job
                .outputs
                .iter()
                .map(|o| self.frame_path(o, frame))
                .collect();
            let aovs = job.args.aovs.as_ref().map(|d| self.frame_aov_dir(d, frame));
            job.write(&out, &files, aovs.as_deref())
                .with_context(|| format!("frame {frame}"))?;
        }
        let secs = start.elapsed().as_secs_f64();
        bar.finish_and_clear();
        let updates = refits + rebuilds;
        let motion = match (&self.rig, self.orbit) {
            (Some(_), _) if updates > 0 => format!(
                "scene update {:.2} ms/frame ({refits} refit{}, {rebuilds} BVH rebuild{}; a full \
                 build took {:.1} ms)",
                update.as_secs_f64() * 1e3 / updates as f64,
                if refits == 1 { "" } else { "s" },
                if rebuilds == 1 { "" } else { "s" },
                build.as_secs_f64() * 1e3
            ),
            (Some(_), _) => "one frame: no scene update".to_string(),
            (None, _) => "camera orbit: no scene update".to_string(),
        };
        let first = job
            .outputs
            .first()
            .map(|o| self.frame_path(o, self.frames.first));
        let last = job
            .outputs
            .first()
            .map(|o| self.frame_path(o, self.frames.last));
        let names = match (first, last) {
            (Some(a), Some(b)) if count > 1 => format!("{} … {}", a.display(), b.display()),
            (Some(a), _) => a.display().to_string(),
            _ => String::new(),
        };
        let also = if job.outputs.len() > 1 {
            format!(
                " (and {})",
                job.outputs[1..]
                    .iter()
                    .map(|o| self.frame_path(o, self.frames.first).display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
                    + " …"
            )
        } else {
            String::new()
        };
        let unit = job.args.integrator.info().sample_unit;
        outln!(
            "done: {count} frame{} in {secs:.2} s ({:.3} s/frame) · {motion} · {}{unit}/s · \
             {}rays/s → {names}{also}",
            if count == 1 { "" } else { "s" },
            secs / count as f64,
            si(samples as f64 / secs),
            si(rays as f64 / secs),
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// `lumo render` arguments as the command line gives them.
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        render: RenderArgs,
    }

    fn plan(args: &[&str], drop_clips: bool) -> (Sequence, Scene) {
        let cli = Cli::try_parse_from(std::iter::once("lumo").chain(args.iter().copied())).unwrap();
        let options = lumo_scene::load::LoadOptions::default();
        let (mut scene, _, mut rig) =
            crate::scene_load::load_scene_animated(&cli.render.scene, &options).unwrap();
        if drop_clips {
            if let Some(r) = &mut rig {
                r.animations.clear();
            }
        }
        let frames = cli.render.frames.unwrap();
        let seq = Sequence::plan(&cli.render, frames, &mut scene, rig).unwrap();
        (seq, scene)
    }

    #[test]
    fn a_gltf_camera_orbits_the_scene_not_a_point_a_unit_ahead() {
        let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/animated.gltf");
        // With and without clips: camera 0 is at (0, 3, 8) looking at about (0, 0.8, 0).
        for drop_clips in [false, true] {
            let (seq, scene) = plan(&[file, "--frames", "0..3", "--orbit", "90"], drop_clips);
            let (_, pivot) = seq.orbit.unwrap();
            assert!((pivot - scene.camera.origin).length() > 5.0, "{pivot}");
            assert!(pivot.x.abs() < 1e-3 && pivot.z.abs() < 1.5, "{pivot}");
            assert_eq!(seq.rig.is_some(), !drop_clips);
        }
        // A built-in camera turns about its target.
        let (seq, scene) = plan(&["cornell", "--frames", "0..3", "--orbit", "90"], false);
        assert_eq!(seq.orbit.unwrap().1, scene.camera.target);
    }
}
