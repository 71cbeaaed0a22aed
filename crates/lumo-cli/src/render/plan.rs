//! A `lumo render` command line planned: its options checked, its scene loaded and its
//! settings worked out ([`Plan`]), then its render scene and thread pool built ([`Ready`]).

use crate::cli_common::errln;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Result};
use lumo_pipeline::Pipeline;
use lumo_render::camera::PinholeCamera;
use lumo_render::{Integrator, LightPilot, PathSettings, PpmSettings, RenderScene, RenderSettings};
use lumo_scene::load::LoadOptions;
use lumo_scene::Scene;

use super::args::RenderArgs;
use super::sequence::Sequence;
use super::validate::{validate, Valid};
use crate::arguments::{ppm_map_bytes, MAX_SPP};
use crate::scene_load::load_scene_animated;

/// What a plan decided, carried unchanged from [`Plan`] to [`Ready`].
pub struct Choices {
    /// The pipeline (`None` for the unfiltered integrators).
    pub pipeline: Pipeline,
    /// Resolution, samples, seed and path settings.
    pub settings: RenderSettings,
    /// Photon-mapping settings.
    pub ppm: PpmSettings,
    /// With `--frames`, what moves from frame to frame.
    pub sequence: Option<Sequence>,
    /// The image files.
    pub outputs: Vec<PathBuf>,
}

/// A `lumo render` command line checked and its scene loaded, before anything is written or
/// built: what the command and a distributed render's workers (`lumo-py`) share.
pub struct Plan {
    /// What the plan decided.
    pub choices: Choices,
    /// The scene, posed at the first frame.
    pub scene: Scene,
}

/// A [`Plan`] with its render scene built and its thread pool.
pub struct Ready {
    /// What the plan decided.
    pub choices: Choices,
    /// The worker threads.
    pub pool: rayon::ThreadPool,
    /// The scene with its BVH and lights.
    pub rs: RenderScene,
    /// How long building `rs` took.
    pub build: std::time::Duration,
}

impl Plan {
    /// Checks the options of `args` ([`validate`]), then plans: loads the scene and works out
    /// the settings; writes nothing.
    pub fn new(args: &RenderArgs) -> Result<Plan> {
        Plan::from_valid(args, validate(args)?)
    }

    /// Loads the scene of options already checked and works out the settings; writes nothing.
    pub fn from_valid(args: &RenderArgs, valid: Valid) -> Result<Plan> {
        let Valid {
            pipeline,
            ppm,
            temporal,
        } = valid;
        let options = LoadOptions {
            defines: args.defines.clone(),
            strict: args.strict,
            camera: args.camera,
            time: args.time,
        };
        let (mut scene, file, rig) = load_scene_animated(&args.scene, &options)?;
        // With --frames, what moves (checked before anything is written or rendered).
        let mut sequence = match args.frames {
            Some(frames) => Some(Sequence::plan(args, frames, &mut scene, rig)?),
            None => None,
        };
        let outputs: Vec<PathBuf> = match &args.output {
            Some(p) => vec![p.clone()],
            None => vec![
                PathBuf::from(format!("{}.exr", scene.name)),
                PathBuf::from(format!("{}.png", scene.name)),
            ],
        };
        // Command-line options win over the scene file's settings, which win over the defaults.
        let (width, height) = args
            .size
            .or(file.size)
            .unwrap_or((scene.defaults.width, scene.defaults.height));
        let settings = RenderSettings {
            width,
            height,
            spp: args
                .spp
                .or(file.spp)
                .unwrap_or(if pipeline == Pipeline::None && !temporal {
                    scene.defaults.spp
                } else {
                    crate::pipeline_args::FILTERED_DEFAULT_SPP
                }),
            seed: args.seed.or(file.seed).unwrap_or(0),
            path: PathSettings {
                max_depth: args
                    .max_depth
                    .or(file.max_depth)
                    .unwrap_or(scene.defaults.max_depth),
                rr_depth: args.rr_depth.or(file.rr_depth).unwrap_or(5),
                spectral: args.spectral,
                ..Default::default()
            },
        };
        // Each frame of a sequence runs the light pilot on its own pose and camera, as a
        // still of that frame does (so that the two are the same image).
        if let Some(seq) = &mut sequence {
            seq.light_pilot = (args.light_selection == super::args::LightSelection::Pilot)
                .then_some((settings.width, settings.height));
        }
        if settings.spp > MAX_SPP {
            bail!(
                "the scene asks for {} samples per pixel; at most {MAX_SPP} (use --spp)",
                settings.spp
            );
        }
        Ok(Plan {
            choices: Choices {
                pipeline,
                settings,
                ppm,
                sequence,
                outputs,
            },
            scene,
        })
    }

    /// Checks the memory the render needs, makes the thread pool and builds the render scene;
    /// with `announce`, says what will be rendered on stderr.
    pub fn build(self, args: &RenderArgs, announce: bool) -> Result<Ready> {
        let Plan { choices, scene } = self;
        let Choices {
            pipeline,
            settings,
            ppm,
            ..
        } = &choices;
        let pipeline = *pipeline;
        let (width, height) = (settings.width, settings.height);
        let per_pixel = pipeline.bytes_per_pixel();
        crate::cli_common::check_memory(
            (width as u64 * height as u64).saturating_mul(per_pixel),
            &format!(
                "a {width}x{height} render with --pipeline {} (about {per_pixel} bytes per pixel)",
                pipeline
            ),
            "use a smaller --size",
        )?;
        let pool = crate::cli_common::worker_pool(args.threads)?;
        let threads = pool.current_num_threads();
        let tris = scene.triangle_count();
        let name = scene.name.clone();
        // Timed inside the pool, like a sequence's per-frame updates (see sequence.rs).
        let (rs, build) = pool.install(|| {
            let build_start = Instant::now();
            (RenderScene::new(scene), build_start.elapsed())
        });
        let mut rs = rs?;
        // Mip-mapped textures are read over one sample's footprint at this size and count.
        if !args.no_mipmaps {
            rs.set_texture_footprint(width, height, settings.spp);
        }
        // The light pilot sees the render's own view (its aspect) before any frame is traced.
        let pilot = (args.light_selection == super::args::LightSelection::Pilot).then(|| {
            pool.install(|| rs.select_lights_by_pilot(width, height, &LightPilot::default()))
        });
        // Media need an integrator that transports light through them; photon mapping
        // refuses rather than render them wrong.
        let integrator = args.integrator;
        if let Some(why) = integrator.media_refusal(&rs.scene) {
            bail!(why);
        }
        let info = integrator.info();
        let method = match integrator {
            // These two ignore --pipeline: they run their own filters per frame.
            _ if info.caps.gbuffer && args.temporal_eval.is_some() => {
                "per-frame À-Trous beside the temporal filter".to_owned()
            }
            _ if info.caps.gbuffer && args.temporal => "temporal filter (SVGF)".to_owned(),
            _ if info.caps.gbuffer => format!("pipeline {pipeline}"),
            Integrator::Light => format!(
                "{} ({} {})",
                info.label,
                settings.spp as u64 * (width * height) as u64,
                info.sample_unit
            ),
            Integrator::Ppm => format!(
                "{} (at most {} photons, {} MB)",
                info.label,
                ppm.max_photons,
                ppm_map_bytes(ppm.max_photons) >> 20
            ),
            _ => info.label.to_owned(),
        };
        if announce {
            errln!(
            "{name}: {tris} triangles (BVH {:.0} ms), {width}x{height}, {} spp, max depth {}, {method}, {threads} threads",
            build.as_secs_f64() * 1e3,
            settings.spp,
            settings.path.max_depth
        );
            if let Some(p) = pilot.as_ref().filter(|p| p.applied) {
                // The groups' probabilities where they fit on a line.
                let pmf: Vec<String> = p.group_pmf.iter().map(|q| format!("{q:.3}")).collect();
                let groups = if pmf.len() <= 8 {
                    format!("[{}]", pmf.join(", "))
                } else {
                    format!("({} groups)", pmf.len())
                };
                errln!(
                    "light pilot: {:.1} ms, light groups chosen with {groups}",
                    p.time.as_secs_f64() * 1e3
                );
            }
        }
        let camera = PinholeCamera::new(&rs.scene.camera, width, height);
        if let Some(warning) = integrator.scene_warning(&rs, &camera, &settings.path) {
            errln!("{warning}");
        }
        Ok(Ready {
            choices,
            pool,
            rs,
            build,
        })
    }
}
