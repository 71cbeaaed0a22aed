//! `lumo denoise`: filter an image from any renderer with one of lumo-filter's screen-space
//! filters, steered by whichever G-buffer planes are given.

use crate::cli_common::{errln, outln};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use lumo_filter::{
    missing_pixels, AtrousDenoiser, AtrousParams, AutoDenoiser, AutoParams, BilateralDenoiser,
    BilateralParams, Denoiser, DepthNorm, EmitterMask, EmitterParams, Features, FilterInput,
    FilterKind, Filtered, GuideKind, GuidedDenoiser, GuidedParams, Shape, FILTERS,
};
use lumo_image::{read_image, write_image, Image};

/// `--filter`: the filters of `lumo_filter::FILTERS` that filter one image on its own, with
/// their names and descriptions from that list (the one list of filters).
fn filter_parser() -> impl TypedValueParser<Value = FilterKind> {
    let values = FILTERS
        .iter()
        .filter(|f| f.shape == Shape::Image)
        .map(|f| PossibleValue::new(f.name).help(f.description));
    PossibleValuesParser::new(values).map(|name| {
        FilterKind::from_name(&name).expect("every possible value is a name from FILTERS")
    })
}

/// Where the À-Trous colour weight gets its noise estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum VarianceSource {
    /// The eroded 3×3 luminance variance of the colour image (`lumo_filter::spatial_variance`).
    Spatial,
    /// The variance plane given with --variance (or variance.exr in --input-dir).
    Plane,
    /// No noise estimate: a fixed colour σ (--sigma-color × mean luminance), off by default.
    None,
}

/// The words after `lumo denoise`, parsed by the command's own parser.
#[derive(clap::Parser)]
#[command(name = "lumo denoise", no_binary_name = true)]
struct DenoiseLine {
    #[command(flatten)]
    args: DenoiseArgs,
}

/// Runs `lumo denoise WORDS…` (the words after `denoise`): the Python package's `lumo.denoise`,
/// which writes its arrays as planes first, so that they get every check of the command.
pub fn run_words(words: &[String]) -> anyhow::Result<()> {
    use clap::Parser;
    let args = DenoiseLine::try_parse_from(words)
        .map_err(|e| anyhow::anyhow!("{}", e.render().to_string().trim_end()))?
        .args;
    run(args)
}

/// Arguments of `lumo denoise`.
#[derive(clap::Args, Debug)]
pub struct DenoiseArgs {
    /// Noisy colour image (EXR, PFM or PNG).
    #[arg(long)]
    pub color: Option<PathBuf>,
    /// Albedo plane; enables demodulation unless --no-demodulate.
    #[arg(long)]
    pub albedo: Option<PathBuf>,
    /// World-space normals in [-1, 1].
    #[arg(long)]
    pub normal: Option<PathBuf>,
    /// World-space positions.
    #[arg(long)]
    pub position: Option<PathBuf>,
    /// Camera distance (1 channel or 3 equal ones); 0 or Inf = background.
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// Per-pixel luminance variance of the pixel mean (used with --variance-source plane).
    #[arg(long)]
    pub variance: Option<PathBuf>,
    /// Emitted radiance seen directly (lights, environment; Blender's Emit pass): pixels where
    /// it is non-zero are left unfiltered and give no weight to their neighbours.
    #[arg(long)]
    pub emission: Option<PathBuf>,
    /// Light of point, spot and directional lights at each sample's first hit, exact (`lumo
    /// render --aovs` writes it as `dirac` for scenes with such lights): left out of the
    /// filter's input and added back unfiltered, so their sharp shadows are not blurred.
    #[arg(long)]
    pub dirac: Option<PathBuf>,
    /// What steers the À-Trous colour weight: a spatial noise estimate from the colour image
    /// itself (robust; works for any renderer), the --variance plane, or nothing (colour weight
    /// off unless --sigma-color is given).
    #[arg(long, value_enum, default_value = "spatial")]
    pub variance_source: VarianceSource,
    /// Read color/albedo/normal/position/depth/variance/emission.exr (or .pfm) from this
    /// directory, whichever exist; explicit flags override.
    #[arg(long)]
    pub input_dir: Option<PathBuf>,
    /// The filter.
    #[arg(long, value_parser = filter_parser(), default_value = "auto")]
    pub filter: FilterKind,
    /// Output image: .exr / .pfm (float32) or .png (sRGB, clamped).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// À-Trous levels [default: 5].
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Colour σ: À-Trous σ_l (× the local noise std-dev of --variance-source; 16 spatial, 8
    /// plane) or, with --variance-source none, × mean luminance (default off); bilateral:
    /// × mean luminance (default off). 0 = off.
    #[arg(long)]
    pub sigma_color: Option<f32>,
    /// Normal σ; 0 = off [default: À-Trous 0.3, bilateral 0.3].
    #[arg(long)]
    pub sigma_normal: Option<f32>,
    /// Position σ as a fraction of the scene extent; 0 = off [default: À-Trous 0.1; bilateral off].
    #[arg(long)]
    pub sigma_position: Option<f32>,
    /// Bilateral relative depth σ; 0 = off [default: 0.2].
    #[arg(long)]
    pub sigma_depth: Option<f32>,
    /// Bilateral spatial σ in pixels [default: radius / 2].
    #[arg(long)]
    pub sigma_spatial: Option<f32>,
    /// Window radius for guided / bilateral [default: 8 for both].
    #[arg(long)]
    pub radius: Option<usize>,
    /// Guided filter ε on normal dimensions [default: 0.001; auto: 0.0001].
    #[arg(long)]
    pub eps_normal: Option<f32>,
    /// Guided filter ε on the depth dimension [default: 0.001; auto: 0.00001].
    #[arg(long)]
    pub eps_depth: Option<f32>,
    /// Guide dimensions for the guided filter: 1 (grey normal), 3 (normal), 4 (normal + depth)
    /// [default: 4 with --depth, else 3].
    #[arg(long)]
    pub guide_dims: Option<usize>,
    /// Fast guided filter: compute coefficients on a grid sub-sampled by s [default: 1 = exact].
    #[arg(long, default_value_t = 1)]
    pub fast_subsample: usize,
    /// Depth normalisation for the guide: divide by this constant [default: the finite depth
    /// range of the image].
    #[arg(long)]
    pub depth_scale: Option<f32>,
    /// auto: the candidate guided filters' radii, comma-separated [default:
    /// 2,4,8,12,16,24,32].
    #[arg(long, value_delimiter = ',')]
    pub auto_radii: Option<Vec<usize>>,
    /// auto: radii of the candidates with a flatter model (ε = --auto-flat-eps on every guide
    /// dimension), comma-separated; "" or the flag alone = none [default: 16,32].
    #[arg(long, num_args = 0..=1, default_missing_value = "")]
    pub auto_flat_radii: Option<RadiusList>,
    /// auto: ε of the flat candidates' guide [default: 0.01].
    #[arg(long)]
    pub auto_flat_eps: Option<f32>,
    /// auto: radius of the window its error estimates are averaged over [default: 12].
    #[arg(long)]
    pub auto_error_radius: Option<usize>,
    /// auto: candidates of this radius and larger run the fast guided filter on a grid twice
    /// as coarse; 0 = none [default: 12].
    #[arg(long)]
    pub auto_coarse_from: Option<usize>,
    /// auto: blend softness; a candidate whose error exceeds the best one's by this fraction
    /// gets e⁻¹ of its weight [default: 0.01].
    #[arg(long)]
    pub auto_softness: Option<f32>,
    /// auto: leave the À-Trous out of the candidates.
    #[arg(long)]
    pub no_auto_atrous: bool,
    /// auto: calibration of the unfiltered input as a candidate (its error 2σ̂², σ̂² this
    /// factor × a directional second-difference noise estimate, e.g. 6.6); 0 = not a
    /// candidate [default: 0].
    #[arg(long)]
    pub auto_input_noise: Option<f32>,
    /// auto: firefly threshold k; a pixel brighter than k × its neighbourhood's mean
    /// (demodulated luminance) is clamped before filtering and its excess spread over a wide,
    /// geometry-guided window; 0 = off [default: 16].
    #[arg(long)]
    pub auto_fireflies: Option<f32>,
    /// auto: radius of the guided filter that spreads the fireflies' excess [default: 64].
    #[arg(long)]
    pub auto_firefly_spread: Option<usize>,
    /// Demodulate by albedo (default when --albedo is given).
    #[arg(long, conflicts_with = "no_demodulate")]
    pub demodulate: bool,
    /// Do not demodulate even when an albedo plane is given.
    #[arg(long)]
    pub no_demodulate: bool,
    /// Same as --variance-source none.
    #[arg(long)]
    pub no_variance: bool,
    /// Sparse input for À-Trous: only every n-th pixel (n = 2 or 4) in x and y is valid.
    #[arg(long, default_value_t = 1)]
    pub subsample: usize,
    /// Without an emission plane, do not look for lights in the frame (by default pixels that
    /// are noise-free and far brighter than albedo × their surroundings explain are passed
    /// through, as an emission plane would mark them).
    #[arg(long)]
    pub no_detect_emitters: bool,
    /// Also write what the light search found (no --emission plane): 1 where pixels were taken
    /// for a light and passed through unfiltered, 0.5 on the ring around them (passed through
    /// too), 0 elsewhere; any image format by extension. To see why a bright area kept its noise.
    #[arg(long, value_name = "FILE", conflicts_with = "no_detect_emitters")]
    pub light_mask: Option<PathBuf>,
    /// Print the time of each stage (read, filter, write) in ms.
    #[arg(long)]
    pub timings: bool,
    /// Run the filter this many times in one process (for benchmarks: with --timings the
    /// filter line is the median, as peers timed in-process are measured warm; a
    /// `filter-min` line gives the fastest run).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
}

/// The input planes, as read.
struct Inputs {
    color: (PathBuf, Image),
    albedo: Option<(PathBuf, Image)>,
    normal: Option<(PathBuf, Image)>,
    position: Option<(PathBuf, Image)>,
    depth: Option<(PathBuf, Image)>,
    variance: Option<(PathBuf, Image)>,
    emission: Option<(PathBuf, Image)>,
    dirac: Option<(PathBuf, Image)>,
    /// Colour pixels with a value beyond ±[`MAX_COLOR`], set to NaN (missing).
    huge: usize,
}

/// Largest colour magnitude the filters take: their window sums of squared values (625 of
/// them in `auto`'s error windows) stay far from f32's 3.4e38, where a value of 1e37 or more
/// made every output pixel NaN, Inf or 0 without a word.
const MAX_COLOR: f32 = 1e15;

/// Marks the pixels of `img` with a finite value beyond ±[`MAX_COLOR`] as missing (NaN, as
/// the filters treat non-finite pixels) and returns how many there were.
fn drop_huge_values(img: &mut Image) -> usize {
    let mut count = 0;
    for p in img.data.chunks_exact_mut(img.channels) {
        if p.iter().any(|v| v.is_finite() && v.abs() > MAX_COLOR) {
            p.fill(f32::NAN);
            count += 1;
        }
    }
    count
}

/// The explicit path, else `<dir>/<name>.exr` or `.pfm` if it exists.
fn pick(explicit: &Option<PathBuf>, dir: &Option<PathBuf>, name: &str) -> Option<PathBuf> {
    if let Some(p) = explicit {
        return Some(p.clone());
    }
    let dir = dir.as_ref()?;
    ["exr", "pfm"]
        .iter()
        .map(|ext| dir.join(format!("{name}.{ext}")))
        .find(|p| p.is_file())
}

fn read(path: &Path) -> anyhow::Result<(PathBuf, Image)> {
    // The image error names the path itself: say it once.
    let img = read_image(path).map_err(|e| anyhow::anyhow!("cannot read {e}"))?;
    Ok((path.to_path_buf(), img))
}

fn read_inputs(a: &DenoiseArgs) -> anyhow::Result<Inputs> {
    if let Some(d) = &a.input_dir {
        if !d.is_dir() {
            bail!("--input-dir {}: not a directory", d.display());
        }
    }
    let color_path = pick(&a.color, &a.input_dir, "color").ok_or_else(|| match &a.input_dir {
        Some(d) => anyhow::anyhow!(
            "no color.exr or color.pfm in {} (or give --color)",
            d.display()
        ),
        None => anyhow::anyhow!("give --color FILE or --input-dir DIR"),
    })?;
    let opt =
        |explicit: &Option<PathBuf>, name: &str| -> anyhow::Result<Option<(PathBuf, Image)>> {
            pick(explicit, &a.input_dir, name)
                .map(|p| read(&p))
                .transpose()
        };
    let mut color = read(&color_path)?;
    color.1 = match color.1.channels {
        1 | 3 => color.1.to_channels(3),
        4 => color.1.to_channels(3),
        n => bail!("{}: {n} channels; expected 1, 3 or 4", color_path.display()),
    };
    let huge = drop_huge_values(&mut color.1);
    let mut inputs = Inputs {
        color,
        albedo: opt(&a.albedo, "albedo")?,
        normal: opt(&a.normal, "normal")?,
        position: opt(&a.position, "position")?,
        depth: opt(&a.depth, "depth")?,
        variance: opt(&a.variance, "variance")?,
        emission: opt(&a.emission, "emission")?,
        dirac: opt(&a.dirac, "dirac")?,
        huge,
    };
    let (cp, c) = &inputs.color;
    for (what, plane, min_ch) in [
        ("albedo", &inputs.albedo, 1),
        ("normal", &inputs.normal, 3),
        ("position", &inputs.position, 3),
        ("depth", &inputs.depth, 1),
        ("variance", &inputs.variance, 1),
        ("emission", &inputs.emission, 1),
        ("dirac", &inputs.dirac, 3),
    ] {
        if let Some((p, img)) = plane {
            c.check_same_size(&cp.display().to_string(), img, &p.display().to_string())?;
            if img.channels < min_ch {
                bail!(
                    "{}: the {what} plane has {} channel(s); expected {min_ch} or more",
                    p.display(),
                    img.channels
                );
            }
            if what == "depth" {
                lumo_filter::check_depth_plane(img).with_context(|| p.display().to_string())?;
            }
        }
    }
    // The Dirac lights' exact light skips the filter: out of the colour here, back in
    // `filter_inputs`.
    if let Some((_, d)) = &inputs.dirac {
        inputs.color.1.add_scaled_finite(d, -1.0);
    }
    Ok(inputs)
}

/// `Some(σ)` from an option: 0 switches the weight off, absent takes the default.
fn sigma(v: Option<f32>, default: Option<f32>) -> anyhow::Result<Option<f32>> {
    match v {
        Some(0.0) => Ok(None),
        Some(s) if s > 0.0 => Ok(Some(s)),
        Some(s) => bail!("sigma {s} must be ≥ 0 (0 = off)"),
        None => Ok(default),
    }
}

/// Default parameters (see docs/filters.md for the sweep that chose them).
mod defaults {
    pub const ATROUS_SIGMA_COLOR: Option<f32> = None;
    pub const ATROUS_SIGMA_COLOR_SPATIAL: f32 = lumo_filter::DEFAULT_SIGMA_LUMINANCE;
    pub const ATROUS_SIGMA_COLOR_PLANE: f32 = 8.0;
    pub const ATROUS_SIGMA_NORMAL: f32 = 0.3;
    pub const ATROUS_SIGMA_POSITION: f32 = 0.1;
    pub const BILATERAL_SIGMA_NORMAL: f32 = 0.3;
    pub const BILATERAL_SIGMA_DEPTH: f32 = 0.2;
    // Smaller than the guided paper's r = 24 and ε = 0.003 (which the guided *pipeline* keeps):
    // on whole path-traced frames, direct light included, r = 8 halves the relMSE.
    pub const GUIDED_RADIUS: usize = 8;
    pub const BILATERAL_RADIUS: usize = 8;
    pub const EPS: f32 = 0.001;
}

fn plane(p: &Option<(PathBuf, Image)>) -> Option<&Image> {
    p.as_ref().map(|(_, i)| i)
}

/// Pixels whose emission plane is non-zero (any channel; NaN counts as emitting).
fn emitting(emission: &Image) -> Vec<bool> {
    (0..emission.pixel_count())
        .map(|i| {
            let px = &emission.data[i * emission.channels..(i + 1) * emission.channels];
            px.iter().any(|&v| !(v == 0.0))
        })
        .collect()
}

/// Emitter pixels (and their rims) found in the colour by `lumo_filter::detect_emitters`.
fn detect(inp: &Inputs) -> anyhow::Result<EmitterMask> {
    lumo_filter::detect_emitters(
        &inp.color.1,
        &feature_planes(inp),
        &EmitterParams::default(),
    )
    .context("detecting emitters")
}

/// The geometry and albedo planes read, for the light search and the emission plane's rim.
fn feature_planes(inp: &Inputs) -> Features<'_> {
    Features {
        normal: plane(&inp.normal),
        position: plane(&inp.position),
        depth: plane(&inp.depth),
        albedo: plane(&inp.albedo),
        variance: None,
    }
}

/// Where the noise estimate comes from, after `--no-variance`.
fn variance_source(a: &DenoiseArgs) -> VarianceSource {
    if a.no_variance {
        VarianceSource::None
    } else {
        a.variance_source
    }
}

/// Whether the filter is given a variance plane: only À-Trous reads a noise estimate; the
/// guided and bilateral filters would compute the spatial one for nothing (a fifth of a 512²
/// guided run's instructions).
fn gets_variance(a: &DenoiseArgs) -> bool {
    match variance_source(a) {
        VarianceSource::None => false,
        VarianceSource::Plane => true,
        VarianceSource::Spatial => a.filter == FilterKind::Atrous,
    }
}

/// The denoiser `--filter` names, with its parameters from the flags and from which planes
/// were given. Errors name the flags to fix.
fn configure(a: &DenoiseArgs, inp: &Inputs) -> anyhow::Result<Box<dyn Denoiser>> {
    if variance_source(a) == VarianceSource::Plane && inp.variance.is_none() {
        bail!(
            "--variance-source plane needs a variance plane: --variance FILE (or variance.exr \
             in --input-dir)"
        );
    }
    let has_variance = gets_variance(a);
    let (normal, position, depth) = (plane(&inp.normal), plane(&inp.position), plane(&inp.depth));
    if a.demodulate && inp.albedo.is_none() {
        bail!("--demodulate needs an albedo plane: --albedo FILE (or albedo.exr in --input-dir)");
    }
    let demod = inp.albedo.is_some() && !a.no_demodulate;
    let auto_flags = a.auto_radii.is_some()
        || a.auto_flat_radii.is_some()
        || a.auto_flat_eps.is_some()
        || a.auto_error_radius.is_some()
        || a.auto_coarse_from.is_some()
        || a.auto_softness.is_some()
        || a.no_auto_atrous
        || a.auto_input_noise.is_some()
        || a.auto_fireflies.is_some()
        || a.auto_firefly_spread.is_some();
    if auto_flags && a.filter != FilterKind::Auto {
        bail!(
            "--auto-radii, --auto-flat-radii, --auto-flat-eps, --auto-error-radius, --auto-coarse-from, \
             --auto-softness, --no-auto-atrous, --auto-input-noise, \
             --auto-fireflies and --auto-firefly-spread apply to --filter auto only (this run uses --filter {})",
            a.filter.name()
        );
    }
    // Options another filter reads: say so in one line each instead of ignoring them silently.
    if a.iterations.is_some() && a.filter != FilterKind::Atrous {
        errln!(
            "warning: --iterations applies to --filter atrous; --filter {} ignores it",
            a.filter.name()
        );
    }
    if a.radius.is_some() && !matches!(a.filter, FilterKind::Guided | FilterKind::Bilateral) {
        errln!(
            "warning: --radius applies to --filter guided and bilateral; --filter {} ignores it{}",
            a.filter.name(),
            if a.filter == FilterKind::Auto {
                " (its radii: --auto-radii)"
            } else {
                ""
            }
        );
    }
    Ok(match a.filter {
        FilterKind::Atrous => {
            let needs = |flag: &str, has: bool, feat: &str| -> anyhow::Result<()> {
                if !has {
                    bail!(
                        "the À-Trous {flag} weight needs a {feat} plane: --{feat} FILE (or {feat}.exr \
                         in --input-dir), or switch it off with --{flag} 0"
                    );
                }
                Ok(())
            };
            let sn = sigma(a.sigma_normal, None)?;
            let sx = sigma(a.sigma_position, None)?;
            if let Some(_s) = sn {
                needs("sigma-normal", normal.is_some(), "normal")?;
            }
            if let Some(_s) = sx {
                needs("sigma-position", position.is_some(), "position")?;
            }
            if normal.is_none() && position.is_none() {
                errln!(
                    "warning: no --normal or --position: À-Trous is steered by colour only and will \
                     blur geometry edges"
                );
            }
            // --sigma-color sets σ_l when a variance plane steers the colour weight, else the
            // fixed colour σ.
            let var_default = match variance_source(a) {
                VarianceSource::Plane => Some(defaults::ATROUS_SIGMA_COLOR_PLANE),
                _ => Some(defaults::ATROUS_SIGMA_COLOR_SPATIAL),
            };
            let (sc, sl) = if has_variance {
                (None, sigma(a.sigma_color, var_default)?)
            } else {
                (sigma(a.sigma_color, defaults::ATROUS_SIGMA_COLOR)?, None)
            };
            Box::new(AtrousDenoiser::new(AtrousParams {
                iterations: a.iterations.unwrap_or(5),
                sigma_color: sc,
                sigma_luminance: sl,
                sigma_normal: normal.and(sn.or(Some(defaults::ATROUS_SIGMA_NORMAL))),
                sigma_position: position.and(sx.or(Some(defaults::ATROUS_SIGMA_POSITION))),
                sparse: a.subsample,
                demodulate: demod,
                use_variance: has_variance,
            }))
        }
        FilterKind::Guided => {
            if a.subsample != 1 {
                bail!("--subsample (sparse input) is only supported by --filter atrous");
            }
            let dims = a.guide_dims.unwrap_or(if depth.is_some() { 4 } else { 3 });
            let kind = match dims {
                1 => GuideKind::Grey,
                3 => GuideKind::Normal,
                4 => GuideKind::NormalDepth,
                d => {
                    bail!("--guide-dims {d}: use 1 (grey normal), 3 (normal) or 4 (normal + depth)")
                }
            };
            let mut missing = Vec::new();
            if normal.is_none() {
                missing.push("--normal FILE (normal.exr)");
            }
            if kind == GuideKind::NormalDepth && depth.is_none() {
                missing.push("--depth FILE (depth.exr)");
            }
            if !missing.is_empty() {
                bail!(
                    "the guided filter with a {dims}-dimensional guide needs {}",
                    missing.join(" and ")
                );
            }
            let depth_norm = match a.depth_scale {
                Some(s) if s > 0.0 && s.is_finite() => DepthNorm::Scale(s),
                Some(s) => bail!("--depth-scale {s} must be > 0"),
                None => DepthNorm::Range,
            };
            Box::new(GuidedDenoiser {
                guide: kind,
                depth_norm,
                eps_normal: a.eps_normal.unwrap_or(defaults::EPS),
                eps_depth: a.eps_depth.unwrap_or(defaults::EPS),
                params: GuidedParams {
                    radius: a.radius.unwrap_or(defaults::GUIDED_RADIUS),
                    fast_subsample: a.fast_subsample,
                },
                demodulate: demod,
            })
        }
        FilterKind::Bilateral => {
            if a.subsample != 1 {
                bail!("--subsample (sparse input) is only supported by --filter atrous");
            }
            if normal.is_none() && depth.is_none() && position.is_none() {
                bail!(
                    "the cross bilateral filter needs at least one of --normal, --depth, --position \
                     (normal.exr, depth.exr, position.exr)"
                );
            }
            let radius = a.radius.unwrap_or(defaults::BILATERAL_RADIUS);
            Box::new(BilateralDenoiser {
                params: BilateralParams {
                    radius,
                    sigma_spatial: a.sigma_spatial.unwrap_or((radius as f32 / 2.0).max(0.5)),
                    sigma_normal: sigma(a.sigma_normal, Some(defaults::BILATERAL_SIGMA_NORMAL))?,
                    sigma_depth: sigma(a.sigma_depth, Some(defaults::BILATERAL_SIGMA_DEPTH))?,
                    sigma_position: sigma(a.sigma_position, None)?,
                    sigma_color: sigma(a.sigma_color, None)?,
                },
                demodulate: demod,
            })
        }
        FilterKind::Auto => {
            // Said here, in the command's terms: the library names a plane, not the option.
            if normal.is_none() {
                bail!(
                    "the auto filter needs a normal plane: --normal FILE (or normal.exr in \
                     --input-dir); without one, use --filter atrous"
                );
            }
            let d = AutoParams::default();
            Box::new(AutoDenoiser {
                params: AutoParams {
                    radii: a.auto_radii.clone().unwrap_or(d.radii),
                    flat_radii: a.auto_flat_radii.clone().map_or(d.flat_radii, |r| r.0),
                    flat_eps: a.auto_flat_eps.unwrap_or(d.flat_eps),
                    eps_normal: a.eps_normal.unwrap_or(d.eps_normal),
                    eps_depth: a.eps_depth.unwrap_or(d.eps_depth),
                    error_radius: a.auto_error_radius.unwrap_or(d.error_radius),
                    coarse_from: a.auto_coarse_from.unwrap_or(d.coarse_from),
                    softness: a.auto_softness.unwrap_or(d.softness),
                    demodulate: demod,
                    atrous: !a.no_auto_atrous,
                    firefly_k: a.auto_fireflies.unwrap_or(d.firefly_k),
                    firefly_radius: d.firefly_radius,
                    firefly_spread: a.auto_firefly_spread.unwrap_or(d.firefly_spread),
                    input_noise: a.auto_input_noise.unwrap_or(d.input_noise),
                },
            })
        }
        // A filter with no flags of its own runs with the library's defaults, so a filter
        // added to `lumo_filter::FILTERS` needs nothing here. (`filter_parser` offers only
        // filters of one full-resolution image: not JBU or the temporal filter.)
        _ => (a.filter.info().new)(),
    })
}

/// Filters `color` once with `denoiser` (which keeps its working memory between `--repeat`
/// runs, as a renderer filtering frame after frame would).
fn run_filter(
    a: &DenoiseArgs,
    inp: &Inputs,
    color: &Image,
    denoiser: &mut dyn Denoiser,
) -> anyhow::Result<Filtered> {
    let spatial;
    let variance = match variance_source(a) {
        _ if !gets_variance(a) => None,
        VarianceSource::Spatial => {
            spatial = lumo_filter::spatial_variance(color);
            Some(&spatial)
        }
        _ => plane(&inp.variance),
    };
    let features = Features {
        normal: plane(&inp.normal),
        position: plane(&inp.position),
        depth: plane(&inp.depth),
        albedo: plane(&inp.albedo),
        variance,
    };
    Ok(denoiser.denoise(&FilterInput::new(color, features))?)
}

/// Filters the read inputs `args.repeat` times as `lumo denoise` does (emitters from the
/// emission plane or found in the frame, then the configured filter); returns the last result
/// and the sorted times of the runs.
fn filter_inputs(
    args: &DenoiseArgs,
    inputs: &Inputs,
) -> anyhow::Result<(Filtered, Vec<std::time::Duration>, Option<EmitterMask>)> {
    let (w, h) = (inputs.color.1.width, inputs.color.1.height);
    if let Some(r) = args.radius {
        if r == 0 || r > w.max(h) {
            bail!(
                "--radius {r}: use 1 to {} (the image's larger side)",
                w.max(h)
            );
        }
    }
    // Emitted light seen directly is noise-free and far brighter than what surrounds it: it is
    // kept out of the filter (missing for its neighbours) and put back unchanged. Without an
    // emission plane it is found in the frame itself (`lumo_filter::detect_emitters`), inside
    // the timed loop: it is part of the filter's cost.
    // A given plane's lights get the light search's one-pixel rim too
    // (`EmitterMask::from_emission`: the plane marks a light's edge pixels only where their
    // centre sees it).
    let given = inputs
        .emission
        .as_ref()
        .map(|(_, e)| {
            EmitterMask::from_emission(e, &feature_planes(inputs), EmitterParams::default().dilate)
        })
        .transpose()
        .context("reading the emission plane")?;
    let mut denoiser = configure(args, inputs)?;
    let mut times = Vec::new();
    let mut filtered = None;
    let mut detected = None;
    for _ in 0..args.repeat {
        let t1 = Instant::now();
        let color = &inputs.color.1;
        detected = match &given {
            None if !args.no_detect_emitters => Some(detect(inputs)?),
            _ => None,
        };
        let mut run = |c: &Image| run_filter(args, inputs, c, denoiser.as_mut());
        filtered = Some(match (&given, &detected) {
            (Some(given), _) => given.filter(color, plane(&inputs.albedo), run)?,
            (None, Some(found)) => found.filter(color, plane(&inputs.albedo), run)?,
            (None, None) => run(color)?,
        });
        times.push(t1.elapsed());
    }
    times.sort();
    let mut filtered = filtered.context("the filter did not run")?;
    if let Some((_, d)) = &inputs.dirac {
        filtered.image.add_scaled_finite(d, 1.0);
    }
    Ok((filtered, times, detected))
}

/// The light search's mask as an image: 1 for lights, 0.5 for their rims, 0 elsewhere.
fn light_mask_image(mask: &EmitterMask, w: usize, h: usize) -> Image {
    let data = (0..w * h)
        .flat_map(|i| {
            let v = if mask.light[i] {
                1.0
            } else if mask.rim[i] {
                0.5
            } else {
                0.0
            };
            [v; 3]
        })
        .collect();
    Image::from_vec(w, h, 3, data)
}

/// Denoises the planes in `dir` (`color`, `albedo`, … as `--input-dir` reads them) with
/// `filter` and every other setting at `lumo denoise`'s defaults, exactly as
/// `lumo denoise --input-dir DIR --filter FILTER` would; for benchmarks. Returns the image and
/// the filter time (the emitter search included).
pub fn denoise_dir(dir: &Path, filter: FilterKind) -> anyhow::Result<(Image, std::time::Duration)> {
    #[derive(clap::Parser)]
    struct Wrapper {
        #[command(flatten)]
        args: DenoiseArgs,
    }
    use clap::Parser as _;
    let dir_arg = dir.as_os_str().to_owned();
    let w = Wrapper::try_parse_from([
        "denoise".into(),
        "--input-dir".into(),
        dir_arg,
        "--filter".into(),
        filter.name().into(),
        "-o".into(),
        "unused.pfm".into(),
    ])
    .context("building the default denoise arguments")?;
    let inputs = read_inputs(&w.args)?;
    let (filtered, times, _) = filter_inputs(&w.args, &inputs)?;
    Ok((filtered.image, times[0]))
}

/// Refuses outputs that would overwrite an input plane or each other (`--light-mask` once
/// overwrote the denoised image with a black mask, `-o` an input plane, without a word).
fn check_outputs_spare_inputs(a: &DenoiseArgs, inputs: &Inputs) -> anyhow::Result<()> {
    use crate::cli_common::same_file;
    let planes = [
        ("color", Some(&inputs.color)),
        ("albedo", inputs.albedo.as_ref()),
        ("normal", inputs.normal.as_ref()),
        ("position", inputs.position.as_ref()),
        ("depth", inputs.depth.as_ref()),
        ("variance", inputs.variance.as_ref()),
        ("emission", inputs.emission.as_ref()),
        ("dirac", inputs.dirac.as_ref()),
    ];
    let outputs = [
        ("-o", Some(&a.output)),
        ("--light-mask", a.light_mask.as_ref()),
    ];
    for (option, out) in outputs {
        let Some(out) = out else { continue };
        for (what, plane) in planes {
            if let Some((path, _)) = plane.filter(|(p, _)| same_file(p, out)) {
                bail!(
                    "{option} {}: that is the {what} plane being read ({}); write to another file",
                    out.display(),
                    path.display()
                );
            }
        }
    }
    if let Some(mask) = a.light_mask.as_ref().filter(|m| same_file(m, &a.output)) {
        bail!(
            "--light-mask {}: the same file as -o; the mask would replace the denoised image",
            mask.display()
        );
    }
    Ok(())
}

/// Refuses a variance plane with values no variance has, and warns when the albedo or the
/// emission plane passes most pixels through unfiltered: each used to switch filtering off
/// without a word (a variance of +∞, NaN or −1 read as 0, noise-free; an all-zero albedo from
/// another renderer, or an all-NaN emission plane, left every pixel as it was).
fn check_plane_values(a: &DenoiseArgs, inputs: &Inputs) -> anyhow::Result<()> {
    // A colour plane with nothing to filter: every pixel NaN or infinite (all treated as
    // missing), or no light at all but negative values (the filters clamp at 0). Each wrote
    // a black image with exit 0.
    let (path, color) = &inputs.color;
    let finite = |px: &&[f32]| px.iter().all(|v| v.is_finite());
    let pixels = || color.data.chunks_exact(color.channels.max(1));
    if !pixels().any(|px| finite(&px)) {
        bail!(
            "{}: every pixel of the colour plane is NaN or infinite; there is nothing to \
             denoise (check the renderer's output)",
            path.display()
        );
    }
    let positive = pixels()
        .filter(finite)
        .any(|px| px.iter().any(|&v| v > 0.0));
    let negative = pixels()
        .filter(finite)
        .any(|px| px.iter().any(|&v| v < 0.0));
    if negative && !positive {
        bail!(
            "{}: every value of the colour plane is zero or negative; the filters take light \
             as ≥ 0 and would write black (was the image inverted or offset?)",
            path.display()
        );
    }
    if let Some((path, v)) = &inputs.variance {
        let bad = |x: f32| !x.is_finite() || x < 0.0;
        let first = v.data.iter().position(|&x| bad(x));
        if let Some(at) = first {
            let count = v.data.iter().filter(|&&x| bad(x)).count();
            let pixel = at / v.channels;
            bail!(
                "{}: the variance plane has {count} value(s) that are negative, NaN or infinite \
                 (first at pixel ({}, {}): {}); a variance must be finite and ≥ 0",
                path.display(),
                pixel % v.width,
                pixel / v.width,
                v.data[at]
            );
        }
    }
    let total = inputs.color.1.pixel_count().max(1);
    let share = |n: usize| n as f64 / total as f64;
    if let Some((path, albedo)) = inputs.albedo.as_ref().filter(|_| !a.no_demodulate) {
        let passed = (0..albedo.pixel_count())
            .filter(|&i| lumo_filter::albedo_passes_through(albedo, i))
            .count();
        if share(passed) > 0.5 {
            errln!(
                "warning: {}: {passed} of {total} albedo pixels are black (below {:e}) or not \
                 finite; demodulation passes them through unfiltered (if the plane is not a \
                 real albedo, drop it or add --no-demodulate)",
                path.display(),
                lumo_filter::ALBEDO_EPS
            );
        }
    }
    if let Some((path, normal)) = &inputs.normal {
        // Unit normals, or zero where nothing was hit (lumo's own planes); an 8-bit normal map
        // (0..1 encoding) or a NaN plane steers the filters by nonsense.
        let (mut set, mut off) = (0usize, 0usize);
        for px in normal.data.chunks_exact(normal.channels) {
            let n = &px[..3.min(px.len())];
            let len2: f32 = n.iter().map(|v| v * v).sum();
            if len2 == 0.0 {
                continue;
            }
            set += 1;
            if !len2.is_finite() || !(0.5625..=1.5625).contains(&len2) {
                off += 1;
            }
        }
        if set == 0 || off * 2 > set {
            errln!(
                "warning: {}: {} of {total} normals are not unit vectors (zero, NaN or of \
                 another length); the filters expect world-space unit normals with components \
                 in [-1, 1], not an encoded normal map",
                path.display(),
                if set == 0 { total } else { off }
            );
        }
    }
    if let Some((path, emission)) = &inputs.emission {
        let lit = emitting(emission).iter().filter(|&&e| e).count();
        if share(lit) > 0.5 {
            errln!(
                "warning: {}: {lit} of {total} pixels count as emitting (any channel non-zero \
                 or NaN) and are passed through unfiltered; an emission plane is zero except on \
                 lights seen directly",
                path.display()
            );
        }
    }
    Ok(())
}

/// Bytes per pixel the filters may allocate beyond their inputs: the most any filter needs
/// (`auto`: lumo-pipeline's estimate of 660 for its pipeline less the 220 of the render) and
/// the output.
const DENOISE_BYTES_PER_PIXEL: u64 = 480;

/// Runs `lumo denoise`.
pub fn run(args: DenoiseArgs) -> anyhow::Result<()> {
    // Named as the command line spells them: the filter's own error calls --subsample
    // "sparse".
    if ![1, 2, 4].contains(&args.subsample) {
        bail!("--subsample {}: use 1, 2 or 4", args.subsample);
    }
    crate::output::check_writable(&args.output).context("-o")?;
    if let Some(path) = &args.light_mask {
        crate::output::check_writable(path).context("--light-mask")?;
    }
    let t0 = Instant::now();
    let inputs = read_inputs(&args)?;
    if args.light_mask.is_some() && inputs.emission.is_some() {
        bail!(
            "--light-mask: an emission plane was given, so no light search runs (the plane marks \
             the lights); drop --light-mask or the emission plane"
        );
    }
    check_outputs_spare_inputs(&args, &inputs)?;
    check_plane_values(&args, &inputs)?;
    let t_read = t0.elapsed();
    let missing = missing_pixels(&inputs.color.1) - inputs.huge;
    if missing > 0 {
        errln!(
            "warning: {missing} pixel(s) of {} are NaN or infinite; treated as missing",
            inputs.color.0.display()
        );
    }
    if inputs.huge > 0 {
        errln!(
            "warning: {} pixel(s) of {} have a value beyond ±{MAX_COLOR:e}, more than the \
             filters' sums of squares can hold; treated as missing (scale the image down if \
             they are real light)",
            inputs.huge,
            inputs.color.0.display()
        );
    }
    let (w, h) = (inputs.color.1.width as u64, inputs.color.1.height as u64);
    crate::cli_common::check_memory(
        (w * h).saturating_mul(DENOISE_BYTES_PER_PIXEL),
        &format!("denoising {w}x{h} pixels"),
        "denoise a smaller image (crop it)",
    )?;
    let (filtered, times, detected) = filter_inputs(&args, &inputs)?;
    let t_filter = times[times.len() / 2];
    let t2 = Instant::now();
    write_image(&args.output, &filtered.image)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    let t_write = t2.elapsed();
    if let (Some(path), Some(mask)) = (&args.light_mask, &detected) {
        let (w, h) = (inputs.color.1.width, inputs.color.1.height);
        write_image(path, &light_mask_image(mask, w, h))
            .with_context(|| format!("cannot write {}", path.display()))?;
        let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
        errln!(
            "light search: {} pixel(s) taken for lights, {} on their rims → {}",
            count(&mask.light),
            count(&mask.rim),
            path.display()
        );
    }
    if args.timings {
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        outln!("read {:.3} ms", ms(t_read));
        outln!("filter {:.3} ms", ms(t_filter));
        if times.len() > 1 {
            // On a shared machine the fastest run is the least disturbed one: A/B
            // comparisons of two builds are steadier on it than on the median.
            outln!("filter-min {:.3} ms", ms(times[0]));
        }
        outln!("write {:.3} ms", ms(t_write));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::ffi::OsStr;

    use super::*;

    /// `--filter` offers exactly the one-image filters of `lumo_filter::FILTERS` (the values it
    /// always had), and each value parses to the filter of that name.
    #[test]
    fn filter_values_come_from_the_list_and_round_trip() {
        let cmd = clap::Command::new("denoise");
        let parser = filter_parser();
        let offered: Vec<String> = parser
            .possible_values()
            .expect("a list of values")
            .map(|v| v.get_name().to_string())
            .collect();
        assert_eq!(offered, ["atrous", "guided", "bilateral", "auto"]);
        for info in FILTERS {
            let got = parser.parse_ref(&cmd, None, OsStr::new(info.name));
            if info.shape == Shape::Image {
                assert_eq!(got.unwrap(), info.kind);
                assert_eq!(info.kind.name(), info.name);
            } else {
                assert!(got.is_err(), "{} is not a filter of one image", info.name);
            }
        }
        assert!(parser.parse_ref(&cmd, None, OsStr::new("none")).is_err());
    }
}

/// A comma-separated list of window radii where the empty string is the empty list (clap's
/// own list parsing reads `""` as one value that is no number).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RadiusList(pub Vec<usize>);

impl std::str::FromStr for RadiusList {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim().is_empty() {
            return Ok(RadiusList(Vec::new()));
        }
        s.split(',')
            .map(|r| {
                r.trim().parse::<usize>().map_err(|_| {
                    format!(
                        "'{r}' is not a radius: give whole numbers separated by commas \
                         (e.g. 16,32), or \"\" for none"
                    )
                })
            })
            .collect::<Result<_, _>>()
            .map(RadiusList)
    }
}
