//! The command line of `lumo render`.

use std::path::PathBuf;

use crate::arguments::{parse_define, parse_size, parse_time};

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
    #[arg(long, value_name = "A..B", value_parser = super::frames::parse_frames, conflicts_with = "time")]
    pub frames: Option<super::frames::FrameRange>,
    /// Frames per second of --frames: frame n shows the animation at n / F seconds [default: 24].
    #[arg(long, value_name = "F", value_parser = super::frames::parse_fps, requires = "frames")]
    pub fps: Option<f32>,
    /// Turn the camera by DEGREES about the scene's look-at target over the --frames range
    /// (frame i of n at DEGREES·i/n, so 360 loops seamlessly): a camera-motion sequence for
    /// any scene.
    #[arg(long, value_name = "DEGREES", value_parser = super::frames::parse_orbit, requires = "frames", allow_hyphen_values = true)]
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
    /// Read mip-mapped textures (glTF samplers with a `*_MIPMAP_*` or unset minFilter) at
    /// full resolution, as Cycles and Mitsuba do, instead of over each sample's footprint.
    #[arg(long)]
    pub no_mipmaps: bool,
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
    /// Light transport, one of lumo-render's integrator table (docs/integrators.md); all but
    /// path render without a pipeline or AOVs, and environment lights emit no particles or
    /// photons.
    #[arg(long, value_parser = crate::integrator_arg::integrators(), default_value = "path")]
    pub integrator: lumo_render::Integrator,
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
    /// How next-event estimation chooses among the lights: `pilot` traces a short
    /// deterministic pass of camera paths first (a 64-path grid, 3 vertices) and mixes the
    /// light each group delivered, shadows included, with power (20 % power, so no light
    /// with power is left out); `power` chooses by power alone (docs/renderer.md, "Light
    /// selection").
    #[arg(long, value_enum, default_value_t = LightSelection::Pilot)]
    pub light_selection: LightSelection,
    /// The filtered-GI pipeline and its options.
    #[command(flatten)]
    pub pipeline: crate::pipeline_args::PipelineArgs,
}

/// `--light-selection`: the light choice of next-event estimation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LightSelection {
    /// By power alone.
    Power,
    /// By a light pilot's measured shares mixed with power.
    Pilot,
}
