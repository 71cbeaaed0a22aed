//! `lumo render`: path-trace a built-in scene and write the image (and optionally its AOVs).

use crate::cli_common::{errln, outln};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use lumo_image::{write_image, Image, ImageFormat};
use lumo_pipeline::{run_pipeline, run_pipeline_on_sums, Pipeline};
use lumo_render::camera::PinholeCamera;
use lumo_render::integrators::bdpt::BdptSettings;
use lumo_render::integrators::photon::{scene_warning, KdTree, DEFAULT_MAX_PHOTONS};
use lumo_render::{
    render_bdpt, render_light, render_ppm, Frame, PathSettings, PixelSums, PpmSettings,
    RenderScene, RenderSettings, RenderStats,
};
use lumo_scene::load::{FileSettings, LoadOptions};
use lumo_scene::{builtin_scene, AnimatedScene, Scene, BUILTIN_SCENES};

/// The light-transport algorithm of `lumo render`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderIntegrator {
    /// Path tracing from the camera with next-event estimation (every pipeline, AOVs).
    Path,
    /// Particle tracing from the lights, each vertex splatted onto the film (no pipeline, no
    /// AOVs; environment lights emit nothing).
    Light,
    /// Bidirectional path tracing: camera and light subpaths joined by every strategy with
    /// multiple importance sampling (no pipeline, no AOVs).
    Bdpt,
    /// One-pass progressive photon mapping: photon batches grow a kd-tree while the passes
    /// gather from it at a shrinking radius (no pipeline, no AOVs).
    Ppm,
}

impl RenderIntegrator {
    /// Integrators that write the image without a filtering pipeline or a G-buffer.
    fn unfiltered(self) -> bool {
        self != RenderIntegrator::Path
    }

    /// What its throughput counts, for the closing line.
    pub fn sample_unit(self) -> &'static str {
        match self {
            RenderIntegrator::Path | RenderIntegrator::Bdpt | RenderIntegrator::Ppm => "samples",
            RenderIntegrator::Light => "light paths",
        }
    }
}

/// Arguments of `lumo render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Built-in scene name (see --list) or scene file: Mitsuba 3 .xml, glTF .gltf/.glb, .obj,
    /// .ply (see docs/scenes.md).
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// Set a Mitsuba `$name` parameter (overrides the file's `<default>`); repeatable.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
    /// Treat scene-file warnings (unsupported or approximated features) as errors.
    #[arg(long)]
    pub strict: bool,
    /// glTF: render from camera N (numbered from 0) [default: the first].
    #[arg(long)]
    pub camera: Option<usize>,
    /// glTF: pose the animated nodes at time T seconds [default: the rest pose].
    #[arg(long, value_name = "T", value_parser = parse_time)]
    pub time: Option<f32>,
    /// Render frames A to B (both included) as a numbered sequence, OUT_0000.exr …: an animated
    /// glTF scene is posed at t = frame / --fps; with --orbit the camera turns (see
    /// docs/animation.md).
    #[arg(long, value_name = "A..B", value_parser = crate::sequence::parse_frames, conflicts_with = "time")]
    pub frames: Option<crate::sequence::FrameRange>,
    /// Frames per second of --frames: frame n shows the animation at n / F seconds [default: 24].
    #[arg(long, value_name = "F", value_parser = crate::sequence::parse_fps, requires = "frames")]
    pub fps: Option<f32>,
    /// Turn the camera by DEGREES about the scene's look-at target over the --frames range
    /// (frame i of n at DEGREES·i/n, so 360 loops seamlessly): a camera-motion sequence for
    /// any scene.
    #[arg(long, value_name = "DEGREES", value_parser = crate::sequence::parse_orbit, requires = "frames", allow_hyphen_values = true)]
    pub orbit: Option<f32>,
    /// Filter the --frames sequence with the temporal filter (SVGF): each frame is traced at
    /// --spp as with --pipeline none, and its history is carried from frame to frame with the
    /// motion of the camera and the instances (docs/animation.md).
    #[arg(long, requires = "frames")]
    pub temporal: bool,
    /// Measure temporal filtering on the --frames sequence instead of writing it: per frame,
    /// FLIP of per-frame À-Trous and of --temporal against a converged reference, flicker and
    /// the time per stage; the table, a plot and an image strip go into DIR
    /// (docs/results/temporal.md).
    #[arg(long, value_name = "DIR", requires = "frames", conflicts_with_all = ["temporal", "output", "aovs"])]
    pub temporal_eval: Option<PathBuf>,
    /// --temporal-eval: samples per pixel of each frame's reference (0: time the stages only).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 256,
        requires = "temporal_eval",
        value_parser = crate::cli_common::parse_spp_or_zero
    )]
    pub reference_spp: u32,
    /// List the built-in scenes and exit.
    #[arg(long)]
    pub list: bool,
    /// Samples per pixel [default: the scene file's; else 4 with a filtering pipeline, and with
    /// --pipeline none the scene's, 16 for the built-ins].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Longest path depth, Mitsuba's convention: 1 = emitters only, 2 = direct light,
    /// 3 = one indirect bounce, … [default: the scene's, 8 for the built-ins].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Depth from which Russian roulette may end paths [default: the scene's, 5].
    #[arg(long)]
    pub rr_depth: Option<u32>,
    /// Image size as WIDTHxHEIGHT [default: the scene's, 512x512 for the built-ins].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Random seed; the same seed gives the same image on any number of threads
    /// [default: the scene's, 0].
    #[arg(long, value_parser = crate::cli_common::parse_seed)]
    pub seed: Option<u32>,
    /// Spectral transport: paths carry three hero-rotated wavelengths (RGB inputs upsampled
    /// to smooth spectra, emitters × D65, measured conductors, dispersive glasses) and the
    /// image is accumulated in CIE XYZ, written as linear sRGB. --integrator path or light.
    #[arg(long)]
    pub spectral: bool,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = crate::cli_common::parse_threads)]
    pub threads: Option<usize>,
    /// Output file (.exr float32 RGB, .pfm, .png 8-bit sRGB) [default: SCENE.exr and SCENE.png].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write the AOV planes (color, albedo, normal, position, depth, direct, indirect,
    /// variance) as EXR files into this directory.
    #[arg(long)]
    pub aovs: Option<PathBuf>,
    /// Light transport: path (from the camera), light (from the lights, splatted onto the
    /// film), bdpt (bidirectional) or ppm (progressive photon mapping); light, bdpt and ppm
    /// render without a pipeline or AOVs, and environment lights emit no particles or photons.
    #[arg(long, value_enum, default_value_t = RenderIntegrator::Path)]
    pub integrator: RenderIntegrator,
    /// --integrator ppm: most photons kept in the map (about 72 bytes each); when full, the
    /// map starts over [default: 4194304, about 300 MB].
    #[arg(long, value_name = "N")]
    pub max_photons: Option<usize>,
    /// --integrator ppm: photon paths traced per pass [default: one per pixel].
    #[arg(long, value_name = "N")]
    pub photons_per_pass: Option<u64>,
    /// --integrator ppm: gather radius of the first pass as a fraction of the scene's
    /// bounding-box diagonal at 262144 photon paths per pass (scaled by the square root of
    /// 262144 / paths per pass, so a gather finds as many photons at any image size); later
    /// passes shrink it (α = 2/3) [default: 0.0025].
    #[arg(long, value_name = "FRACTION")]
    pub photon_radius: Option<f32>,
    /// The filtered-GI pipeline and its options.
    #[command(flatten)]
    pub pipeline: crate::pipeline_args::PipelineArgs,
}

/// Most samples per pixel `--spp` accepts: 2^20 is days of rendering at 512x512; beyond,
/// a typo (4294967295) would run for ever.
pub const MAX_SPP: u32 = 1 << 20;

/// Bytes of a photon map holding `photons` photons (tree nodes included).
pub fn ppm_map_bytes(photons: usize) -> u64 {
    photons as u64 * KdTree::BYTES_PER_PHOTON as u64
}

/// Most photons `--max-photons` accepts: 2^30 is 72 GB of map.
pub const MAX_PHOTONS: usize = 1 << 30;

/// The photon-mapping settings of `lumo render`, checked.
fn ppm_settings(args: &RenderArgs) -> Result<PpmSettings> {
    let max_photons = args.max_photons.unwrap_or(DEFAULT_MAX_PHOTONS);
    if max_photons == 0 || max_photons > MAX_PHOTONS {
        bail!("--max-photons {max_photons}: expected 1..={MAX_PHOTONS}");
    }
    if args.photons_per_pass == Some(0) {
        bail!("--photons-per-pass must be at least 1");
    }
    let radius = args.photon_radius.unwrap_or(PpmSettings::default().radius);
    if !(radius > 0.0 && radius <= 1.0) {
        bail!("--photon-radius {radius}: expected a fraction of the scene diagonal in (0, 1]");
    }
    if args.integrator == RenderIntegrator::Ppm {
        crate::cli_common::check_memory(
            ppm_map_bytes(max_photons),
            &format!("a photon map of {max_photons} photons"),
            "use a smaller --max-photons",
        )?;
    }
    Ok(PpmSettings {
        photons_per_pass: args.photons_per_pass.unwrap_or(0),
        max_photons,
        radius,
        ..Default::default()
    })
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let err = || {
        format!("invalid size {s:?}: expected WIDTHxHEIGHT with both in 1..=16384, e.g. 512x512")
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let w: usize = w.trim().parse().map_err(|_| err())?;
    let h: usize = h.trim().parse().map_err(|_| err())?;
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(err());
    }
    Ok((w, h))
}

/// Parses `--time T`: seconds, a finite number (a NaN would reach the animation as a
/// transform that is "not finite", naming an instance instead of the option).
pub fn parse_time(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(t) if t.is_finite() => Ok(t),
        _ => Err(format!(
            "invalid time {s:?}: expected a finite number of seconds, e.g. 0.5"
        )),
    }
}

/// Parses `NAME=VALUE` for `-D`.
pub fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err(format!(
            "invalid definition {s:?}: expected NAME=VALUE, e.g. spp=64"
        )),
    }
}

/// Loads a built-in scene by name, or a scene file with default options.
pub fn load_scene(name: &str) -> Result<Scene> {
    Ok(load_scene_with(name, &LoadOptions::default())?.0)
}

/// Loads a built-in scene by name or a scene file (.xml, .gltf, .glb, .obj, .ply), printing
/// the loader's warnings to stderr; returns the scene and the render settings the file asks for.
pub fn load_scene_with(name: &str, options: &LoadOptions) -> Result<(Scene, FileSettings)> {
    let (scene, settings, _) = load_scene_animated(name, options)?;
    Ok((scene, settings))
}

/// [`load_scene_with`], also returning the scene's node animation (glTF files; `None` for
/// the built-ins and other formats).
pub fn load_scene_animated(
    name: &str,
    options: &LoadOptions,
) -> Result<(Scene, FileSettings, Option<AnimatedScene>)> {
    let path = Path::new(name);
    if names_scene_file(name) {
        if let Err(e) = std::fs::metadata(path) {
            // A link that leads nowhere (a loop, a missing target) was reported as a file
            // that "does not exist", though `ls` shows it.
            if path.symlink_metadata().is_ok() {
                let why = if e.raw_os_error() == Some(40) {
                    "it is part of a loop of symbolic links".to_string()
                } else {
                    lumo_image::describe_io_error(&e)
                };
                bail!(
                    "scene file {name:?} is a symbolic link that cannot be followed: {why}; \
                     point it at a scene file"
                );
            }
            bail!(
                "scene file {name:?} does not exist; built-in scenes: {}",
                builtin_names()
            );
        }
        let loaded = lumo_scene::load::load_scene(path, options)?;
        for w in &loaded.warnings {
            errln!("{w}");
        }
        return Ok((loaded.scene, loaded.settings, loaded.animation));
    }
    let scene = builtin_scene(name)?;
    // The file loader warns about these for non-glTF files; built-ins have one camera and
    // no animation, so say so rather than ignore the options silently.
    if options.camera.is_some() {
        errln!(
            "warning: --camera applies to glTF scenes; the built-in {name} has one camera, ignored"
        );
    }
    if options.time.is_some() {
        errln!("warning: --time applies to animated glTF scenes; the built-in {name} is static, ignored");
    }
    Ok((scene, FileSettings::default(), None))
}

/// Whether a scene argument names a file (it has an extension or a `/`) rather than a
/// built-in scene.
pub fn names_scene_file(name: &str) -> bool {
    Path::new(name).extension().is_some() || name.contains('/')
}

fn builtin_names() -> String {
    BUILTIN_SCENES
        .iter()
        .map(|s| s.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Fails early (before rendering) if `path` cannot be written as an image.
pub fn check_writable(path: &Path) -> Result<()> {
    ImageFormat::from_path(path)?;
    check_output_file(path)
}

/// Fails early (before the work) if the file `path` cannot be written: it is a directory, its
/// directory does not exist or is not writable.
pub fn check_output_file(path: &Path) -> Result<()> {
    // "out.png/" names a directory to the OS but passes Path's extension test: it failed only
    // when written, after the render.
    if path.as_os_str().as_encoded_bytes().ends_with(b"/") {
        bail!(
            "cannot write {}: the name ends in '/', so it names a directory; drop the '/'",
            path.display()
        );
    }
    if path.is_dir() {
        bail!(
            "cannot write {}: it is a directory; name a file in it, e.g. {}",
            path.display(),
            path.join("image.exr").display()
        );
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    // Temporaries of writes killed earlier (Ctrl-C, a crash) are swept here, once per output.
    let swept = lumo_image::sweep_stale_temps(&dir);
    if swept > 0 {
        errln!(
            "note: removed {swept} temporary file(s) .lumo-tmp-* left in {} by interrupted \
             writes",
            dir.display()
        );
    }
    // The probe is the temporary the write will use, so a name too long for the file system
    // fails here, not after the render.
    if let Some(name) = path
        .file_name()
        .filter(|n| n.len() > lumo_image::MAX_NAME_BYTES)
    {
        bail!(
            "cannot write {}: the file name is {} bytes; file systems take at most {}",
            path.display(),
            name.len(),
            lumo_image::MAX_NAME_BYTES
        );
    }
    let probe = lumo_image::temp_path(path);
    // Registered like a write's temporary, so that a signal now removes it too.
    let _in_flight = lumo_image::temps::InFlight::new(&probe);
    std::fs::write(&probe, b"").with_context(|| {
        format!(
            // The cause follows (permission denied, read-only file system, or /proc's "no
            // such file"): "not writable" alone misread the last.
            "cannot write {}: cannot create a file in {}",
            path.display(),
            dir.display()
        )
    })?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

/// Formats a rate with k/M/G prefixes.
pub fn si(v: f64) -> String {
    if v >= 1e9 {
        format!("{:.2} G", v / 1e9)
    } else if v >= 1e6 {
        format!("{:.2} M", v / 1e6)
    } else if v >= 1e3 {
        format!("{:.2} k", v / 1e3)
    } else {
        format!("{v:.1} ")
    }
}

/// Runs `lumo render`.
pub fn run(args: RenderArgs) -> Result<()> {
    if args.list {
        for s in BUILTIN_SCENES {
            outln!("{:<16} {}", s.name, s.description);
        }
        return Ok(());
    }
    let plan = Plan::new(&args)?;
    plan.check_outputs(&args)?;
    let Ready {
        pipeline,
        settings,
        ppm,
        sequence,
        outputs,
        pool,
        rs,
        build,
    } = plan.build(&args, true)?;
    let (width, height) = (settings.width, settings.height);
    let job = Job {
        args: &args,
        pipeline,
        settings,
        pool: &pool,
        outputs,
    };
    if let Some(seq) = sequence {
        if let Some(dir) = &args.temporal_eval {
            return crate::temporal_eval::run(&seq, &job, rs, dir, args.reference_spp);
        }
        return seq.run(&job, rs, build);
    }
    let bar = ProgressBar::new(1000).with_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}%  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    if args.integrator == RenderIntegrator::Ppm {
        let camera = PinholeCamera::new(&rs.scene.camera, width, height);
        if let Some(w) = scene_warning(&rs, &camera, &settings.path) {
            errln!("{w}");
        }
        let (image, stats) = pool.install(|| {
            render_ppm(&rs, &settings, &ppm, &|f| {
                bar.set_position((f * 1000.0) as u64)
            })
        });
        let secs = start.elapsed().as_secs_f64();
        bar.finish_and_clear();
        for o in &job.outputs {
            write_image(o, &image)?;
        }
        let written: Vec<String> = job
            .outputs
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        outln!(
            "done in {secs:.2} s · {}samples/s · {}photon paths/s · {}rays/s · map {} photons (peak {}, {} MB, {} resets) · {:.1} photons/gather → {}",
            si(stats.samples as f64 / secs),
            si(stats.photon_paths as f64 / secs),
            si(stats.rays as f64 / secs),
            stats.photons_stored,
            stats.peak_photons,
            ppm_map_bytes(stats.peak_photons as usize) >> 20,
            stats.generations,
            stats.photons_gathered as f64 / stats.samples.max(1) as f64,
            written.join(", ")
        );
        return Ok(());
    }
    let out = job.render(&rs, &|f| bar.set_position((f * 1000.0) as u64))?;
    let secs = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    job.write(&out, &job.outputs, args.aovs.as_deref())?;
    if let Some(timings) = &out.timings {
        errln!("pipeline {pipeline}: {timings}");
    }
    let written: Vec<String> = job
        .outputs
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let unit = args.integrator.sample_unit();
    outln!(
        "done in {secs:.2} s · {}{unit}/s · {}rays/s → {}{}",
        si(out.stats.samples as f64 / secs),
        si(out.stats.rays as f64 / secs),
        written.join(", "),
        args.aovs
            .as_ref()
            .map(|d| format!(" (AOVs in {})", d.display()))
            .unwrap_or_default()
    );
    Ok(())
}

/// A `lumo render` command line checked and its scene loaded, before anything is written or
/// built: what the command and a distributed render's workers (`lumo-py`) share.
pub struct Plan {
    /// The pipeline (`None` for the unfiltered integrators).
    pub pipeline: Pipeline,
    /// Resolution, samples, seed and path settings.
    pub settings: RenderSettings,
    /// Photon-mapping settings.
    pub ppm: PpmSettings,
    /// With `--frames`, what moves from frame to frame.
    pub sequence: Option<crate::sequence::Sequence>,
    /// The image files.
    pub outputs: Vec<PathBuf>,
    /// The scene, posed at the first frame.
    pub scene: Scene,
}

/// A [`Plan`] with its render scene built and its thread pool.
pub struct Ready {
    /// See [`Plan::pipeline`].
    pub pipeline: Pipeline,
    /// See [`Plan::settings`].
    pub settings: RenderSettings,
    /// See [`Plan::ppm`].
    pub ppm: PpmSettings,
    /// See [`Plan::sequence`].
    pub sequence: Option<crate::sequence::Sequence>,
    /// See [`Plan::outputs`].
    pub outputs: Vec<PathBuf>,
    /// The worker threads.
    pub pool: rayon::ThreadPool,
    /// The scene with its BVH and lights.
    pub rs: RenderScene,
    /// How long building `rs` took.
    pub build: std::time::Duration,
}

impl Plan {
    /// Checks the options of `args` against each other and the scene, loads the scene and works
    /// out the settings; writes nothing.
    pub fn new(args: &RenderArgs) -> Result<Plan> {
        let integrator = args
            .integrator
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_owned());
        let temporal = args.temporal || args.temporal_eval.is_some();
        // The option as typed, for the messages below.
        let temporal_flag = if args.temporal_eval.is_some() {
            "--temporal-eval"
        } else {
            "--temporal"
        };
        let pipeline = match (args.integrator, args.pipeline.pipeline) {
            (i, Some(p)) if i.unfiltered() && p != Pipeline::None => bail!(
                "--integrator {integrator} renders without a filtering pipeline: drop --pipeline {p} (or use --pipeline none)"
            ),
            (i, _) if i.unfiltered() && temporal => bail!(
                "{temporal_flag}: --integrator {integrator} makes no G-buffer for the temporal filter; use --integrator path"
            ),
            (_, Some(p)) if temporal && p != Pipeline::None => bail!(
                "{temporal_flag} filters each frame with the temporal filter itself: drop --pipeline {p}"
            ),
            // Traced without a pipeline; the temporal filter takes its place.
            _ if args.temporal => Pipeline::None,
            (i, _) if i.unfiltered() => Pipeline::None,
            _ => args.pipeline.pipeline(),
        };
        if args.integrator.unfiltered() && args.aovs.is_some() {
            bail!("--aovs: --integrator {integrator} makes no G-buffer; use --integrator path for AOV planes");
        }
        if args.integrator == RenderIntegrator::Ppm && args.aovs.is_some() {
            bail!(
                "--aovs: the photon mapper makes no G-buffer; use --integrator path for AOV planes"
            );
        }
        if args.spectral
            && !matches!(
                args.integrator,
                RenderIntegrator::Path | RenderIntegrator::Light
            )
        {
            bail!("--spectral: spectral transport runs in the path and light tracers; use --integrator path or light (bdpt and ppm transport RGB)");
        }
        if args.spectral {
            // Fitted once per process (about a second on two cores), before the progress bar.
            lumo_spectrum::coefficient_table();
        }
        if args.integrator != RenderIntegrator::Ppm
            && (args.max_photons.is_some()
                || args.photons_per_pass.is_some()
                || args.photon_radius.is_some())
        {
            bail!(
                "--max-photons, --photons-per-pass and --photon-radius apply to --integrator ppm"
            );
        }
        let ppm = ppm_settings(args)?;
        let options = LoadOptions {
            defines: args.defines.clone(),
            strict: args.strict,
            camera: args.camera,
            time: args.time,
        };
        let (mut scene, file, rig) = load_scene_animated(&args.scene, &options)?;
        // With --frames, what moves (checked before anything is written or rendered).
        let sequence = match args.frames {
            Some(frames) => Some(crate::sequence::Sequence::plan(
                args, frames, &mut scene, rig,
            )?),
            None => None,
        };
        let outputs: Vec<PathBuf> = match &args.output {
            Some(p) => vec![p.clone()],
            None => vec![
                PathBuf::from(format!("{}.exr", scene.name)),
                PathBuf::from(format!("{}.png", scene.name)),
            ],
        };
        match args.spp {
            Some(0) => bail!("--spp must be at least 1"),
            Some(n) if n > MAX_SPP => bail!("--spp {n}: at most {MAX_SPP} samples per pixel"),
            _ => {}
        }
        crate::cli_common::check_max_depth(args.max_depth)?;
        crate::cli_common::check_rr_depth(args.rr_depth)?;
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
        if settings.spp > MAX_SPP {
            bail!(
                "the scene asks for {} samples per pixel; at most {MAX_SPP} (use --spp)",
                settings.spp
            );
        }
        let unfiltered = args.integrator.unfiltered().then_some(integrator.as_str());
        args.pipeline.check(pipeline, unfiltered)?;
        Ok(Plan {
            pipeline,
            settings,
            ppm,
            sequence,
            outputs,
            scene,
        })
    }

    /// Checks every output location before the render, which may take hours, and makes the
    /// `--aovs` directory once every other check has passed.
    pub fn check_outputs(&self, args: &RenderArgs) -> Result<()> {
        let (outputs, sequence) = (&self.outputs, &self.sequence);
        // Every output location is checked before the render, which may take hours, and before
        // anything is created: the AOV directory is made only once every other check has passed.
        if let Some(dir) = &args.aovs {
            for o in outputs {
                // In a sequence both the image and the planes' directory carry the frame number.
                let (image, planes) = match &sequence {
                    Some(seq) => (
                        seq.frame_path(o, seq.frames.first),
                        seq.frame_aov_dir(dir, seq.frames.first),
                    ),
                    None => (o.clone(), dir.clone()),
                };
                if let Some(plane) = aov_plane_named_by(&image, &planes) {
                    bail!(
                        "-o {}: the --aovs plane {plane}.exr would overwrite the image; write the \
                         image outside {} or under another name",
                        o.display(),
                        dir.display()
                    );
                }
            }
            if dir.exists() && !dir.is_dir() {
                bail!("--aovs {}: exists and is not a directory", dir.display());
            }
            // `--aovs planes.exr` makes a directory of that name: likely meant as a file.
            let image_like = dir
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["exr", "pfm", "png"].contains(&e.to_ascii_lowercase().as_str()));
            if image_like && !dir.exists() {
                errln!(
                    "warning: --aovs {} names a directory (one file per plane goes into it), \
                     created with an image extension; the image itself is -o",
                    dir.display()
                );
            }
        }
        // Outputs in an AOV directory that does not exist yet are checked once it is made.
        let in_new_aovs = |o: &Path| {
            args.aovs
                .as_ref()
                .is_some_and(|d| !d.exists() && parent_is(o, d))
        };
        let check_output = |o: &Path| -> Result<()> {
            check_writable(o)?;
            if let Some(seq) = &sequence {
                // The numbered name must be writable too (a long name may not be).
                check_writable(&seq.frame_path(o, seq.frames.first))?;
            }
            Ok(())
        };
        let deferred: Vec<&PathBuf> = outputs.iter().filter(|o| in_new_aovs(o)).collect();
        for o in outputs.iter().filter(|o| !in_new_aovs(o)) {
            check_output(o)?;
        }
        if let Some(dir) = &args.aovs {
            std::fs::create_dir_all(dir).with_context(|| {
                format!("--aovs {}: cannot create the directory", dir.display())
            })?;
            // The first frame's planes: DIR itself, or DIR/<frame> in a sequence (made at write
            // time, so only something in its way can fail it).
            let planes = match &sequence {
                Some(seq) => seq.frame_aov_dir(dir, seq.frames.first),
                None => dir.clone(),
            };
            if planes.exists() && !planes.is_dir() {
                bail!(
                    "--aovs {}: {} exists and is not a directory (the first frame's planes go \
                     there)",
                    dir.display(),
                    planes.display()
                );
            }
            let probe = if planes.is_dir() { &planes } else { dir };
            check_writable(&probe.join("color.exr"))
                .with_context(|| format!("--aovs {}", dir.display()))?;
            // Every plane of every frame, not only the first: a directory where one plane goes
            // failed after the render, with half the planes overwritten.
            let frame_dirs: Vec<PathBuf> = match &sequence {
                Some(seq) => (seq.frames.first..=seq.frames.last)
                    .map(|f| seq.frame_aov_dir(dir, f))
                    .collect(),
                None => vec![dir.clone()],
            };
            for planes in &frame_dirs {
                if planes.exists() && !planes.is_dir() {
                    bail!(
                        "--aovs {}: {} exists and is not a directory (a frame's planes go there)",
                        dir.display(),
                        planes.display()
                    );
                }
                if !planes.is_dir() {
                    continue;
                }
                for name in lumo_render::AOV_NAMES
                    .iter()
                    .chain(lumo_pipeline::PLANE_NAMES)
                {
                    let plane = planes.join(format!("{name}.exr"));
                    if plane.symlink_metadata().is_ok() && !plane.is_file() {
                        bail!(
                            "--aovs {}: {} is not a regular file, and the {name} plane is written \
                             there; move it or choose another directory",
                            dir.display(),
                            plane.display()
                        );
                    }
                }
            }
        }
        for o in deferred {
            check_output(o)?;
        }
        Ok(())
    }

    /// Checks the memory the render needs, makes the thread pool and builds the render scene;
    /// with `announce`, says what will be rendered on stderr.
    pub fn build(self, args: &RenderArgs, announce: bool) -> Result<Ready> {
        let Plan {
            pipeline,
            settings,
            ppm,
            sequence,
            outputs,
            scene,
        } = self;
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
        let rs = rs?;
        // Media need the path tracer; the others refuse rather than render them wrong.
        let chosen = format!("{:?}", args.integrator).to_lowercase();
        if let Some(why) = lumo_render::media::refusal(&rs.scene, &chosen) {
            bail!(why);
        }
        let method = match args.integrator {
            // These two ignore --pipeline: they run their own filters per frame.
            RenderIntegrator::Path if args.temporal_eval.is_some() => {
                "per-frame À-Trous beside the temporal filter".to_owned()
            }
            RenderIntegrator::Path if args.temporal => "temporal filter (SVGF)".to_owned(),
            RenderIntegrator::Path => format!("pipeline {pipeline}"),
            RenderIntegrator::Light => format!(
                "light tracer ({} light paths)",
                settings.spp as u64 * (width * height) as u64
            ),
            RenderIntegrator::Bdpt => "bidirectional path tracer".to_owned(),
            RenderIntegrator::Ppm => format!(
                "photon mapping (at most {} photons, {} MB)",
                ppm.max_photons,
                ppm_map_bytes(ppm.max_photons) >> 20
            ),
        };
        if announce {
            errln!(
            "{name}: {tris} triangles (BVH {:.0} ms), {width}x{height}, {} spp, max depth {}, {method}, {threads} threads",
            build.as_secs_f64() * 1e3,
            settings.spp,
            settings.path.max_depth
        );
        }
        if args.integrator == RenderIntegrator::Bdpt && rs.lights.emits_no_particles() {
            errln!("warning: {name}: no light emits particles (environment lights do not): --integrator bdpt runs as a path tracer here");
        }
        Ok(Ready {
            pipeline,
            settings,
            ppm,
            sequence,
            outputs,
            pool,
            rs,
            build,
        })
    }
}

/// What every frame of one `lumo render` shares: the options, the pool and the outputs.
pub struct Job<'a> {
    /// The command line.
    pub args: &'a RenderArgs,
    /// The pipeline (`None` for the light tracer).
    pub pipeline: Pipeline,
    /// Resolution, samples, seed and path settings.
    pub settings: RenderSettings,
    /// The worker threads.
    pub pool: &'a rayon::ThreadPool,
    /// The image files (for a sequence: the names the frame numbers are added to).
    pub outputs: Vec<PathBuf>,
}

/// One rendered image with what goes beside it.
pub struct Rendered {
    /// The final image.
    pub image: Image,
    /// Work counters.
    pub stats: RenderStats,
    /// The path tracer's frame and the pipeline's intermediate planes (for --aovs).
    pub aovs: Option<(Frame, Vec<(&'static str, Image)>)>,
    /// The pipeline's time per stage, formatted.
    pub timings: Option<String>,
}

impl<'a> Job<'a> {
    /// The same job with another seed.
    pub fn with_seed(&self, seed: u32) -> Job<'a> {
        Job {
            args: self.args,
            pipeline: self.pipeline,
            settings: RenderSettings {
                seed,
                ..self.settings
            },
            pool: self.pool,
            outputs: self.outputs.clone(),
        }
    }

    /// Renders `rs` with the job's integrator and pipeline; `progress` gets 0..1.
    pub fn render(&self, rs: &RenderScene, progress: &(dyn Fn(f32) + Sync)) -> Result<Rendered> {
        let settings = &self.settings;
        if matches!(
            self.args.integrator,
            RenderIntegrator::Light | RenderIntegrator::Bdpt
        ) {
            let camera = lumo_render::camera::PinholeCamera::new(
                &rs.scene.camera,
                settings.width,
                settings.height,
            );
            if let Some(what) = camera.unsupported_by_splats() {
                bail!(
                    "{}: --integrator {}: the scene has {what}, which the light tracer and BDPT \
                     (they project light onto a pinhole's film) do not render; use --integrator \
                     path or ppm",
                    rs.scene.name,
                    if self.args.integrator == RenderIntegrator::Light {
                        "light"
                    } else {
                        "bdpt"
                    }
                );
            }
        }
        if self.args.integrator == RenderIntegrator::Light {
            if rs.lights.emits_no_particles() {
                bail!(
                    "{}: --integrator light: no light emits particles (environment lights do not); use --integrator path",
                    rs.scene.name
                );
            }
            let (image, stats) = self.pool.install(|| render_light(rs, settings, progress));
            return Ok(Rendered {
                image,
                stats,
                aovs: None,
                timings: None,
            });
        }
        if self.args.integrator == RenderIntegrator::Ppm {
            let ppm = ppm_settings(self.args)?;
            let (image, stats) = self
                .pool
                .install(|| render_ppm(rs, settings, &ppm, progress));
            return Ok(Rendered {
                image,
                stats: RenderStats {
                    samples: stats.samples,
                    rays: stats.rays,
                },
                aovs: None,
                timings: None,
            });
        }
        if self.args.integrator == RenderIntegrator::Bdpt {
            let bdpt = BdptSettings {
                path: settings.path,
                only: None,
            };
            let (image, stats) = self
                .pool
                .install(|| render_bdpt(rs, settings, &bdpt, progress));
            return Ok(Rendered {
                image,
                stats,
                aovs: None,
                timings: None,
            });
        }
        let out = self
            .pool
            .install(|| {
                run_pipeline(
                    rs,
                    self.pipeline,
                    settings,
                    &self.args.pipeline.options(settings.width, settings.height),
                    progress,
                )
            })
            .map_err(crate::pipeline_args::describe_pipeline_error)?;
        Ok(self.rendered(out))
    }

    /// What [`Job::render`] gives for the path tracer, from the exact sums of every pixel's
    /// samples traced elsewhere (a distributed render's chunks, added up): the same bits.
    pub fn render_sums(&self, rs: &RenderScene, sums: Vec<PixelSums>) -> Result<Rendered> {
        let settings = &self.settings;
        let out = self
            .pool
            .install(|| {
                run_pipeline_on_sums(
                    rs,
                    self.pipeline,
                    settings,
                    &self.args.pipeline.options(settings.width, settings.height),
                    sums,
                )
            })
            .map_err(crate::pipeline_args::describe_pipeline_error)?;
        Ok(self.rendered(out))
    }

    fn rendered(&self, out: lumo_pipeline::PipelineOutput) -> Rendered {
        Rendered {
            image: out.image,
            stats: out.stats,
            timings: (self.pipeline != Pipeline::None).then(|| out.timings.to_string()),
            aovs: Some((out.frame, out.planes)),
        }
    }

    /// Writes the image to `outputs` and, with `aovs`, the AOV planes into that directory.
    pub fn write(&self, out: &Rendered, outputs: &[PathBuf], aovs: Option<&Path>) -> Result<()> {
        for o in outputs {
            write_image(o, &out.image)?;
        }
        if let (Some(dir), Some((frame, planes))) = (aovs, &out.aovs) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("--aovs: cannot create {}", dir.display()))?;
            frame.write_aovs(dir)?;
            for (name, plane) in planes {
                write_image(&dir.join(format!("{name}.exr")), plane)?;
            }
        }
        Ok(())
    }
}

/// The name of the `--aovs` plane that output `o` would be overwritten by: `o` is
/// `<dir>/<plane>.exr` for a plane of the frame or of a pipeline.
fn aov_plane_named_by(o: &Path, dir: &Path) -> Option<&'static str> {
    let exr = o.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let stem = o.file_stem()?.to_str()?;
    if !exr || !parent_is(o, dir) {
        return None;
    }
    lumo_render::AOV_NAMES
        .iter()
        .chain(lumo_pipeline::PLANE_NAMES)
        .find(|&&n| n == stem)
        .copied()
}

/// Whether file `o` lies directly in directory `dir` (compared as canonical paths where both
/// exist, else lexically: `./av` is `av`).
fn parent_is(o: &Path, dir: &Path) -> bool {
    let lexical = |p: &Path| -> PathBuf {
        p.components()
            .filter(|c| !matches!(c, std::path::Component::CurDir))
            .collect()
    };
    let Some(parent) = o.parent() else {
        return false;
    };
    let parent = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    match (parent.canonicalize(), dir.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => lexical(parent) == lexical(dir),
    }
}
