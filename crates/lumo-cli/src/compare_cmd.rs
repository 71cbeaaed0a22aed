//! `lumo compare REF IMG [IMG…]`: error metrics of images against a reference, as a table or
//! JSON, and optionally false-colour error images.

use crate::cli_common::{errln, outln};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lumo_image::metrics::{
    compare, false_colour, CompareSettings, DiffMetric, MetricError, Metrics, FLIP_DEFAULT_PPD,
    RELMSE_EPSILON, SMAPE_EPSILON, SSIM_K1, SSIM_K2, SSIM_SIGMA, SSIM_WINDOW, TONE_MAP_DESCRIPTION,
};
use lumo_image::{read_image, write_image, Image};
use serde_json::json;

/// Which per-pixel error `--diff` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DiffKind {
    /// Per-pixel FLIP, linear from 0 (black) to 1 (pale yellow).
    Flip,
    /// Per-pixel relMSE, log scale from 1e-4 (black) to 1 (pale yellow).
    Relmse,
}

impl From<DiffKind> for DiffMetric {
    fn from(k: DiffKind) -> Self {
        match k {
            DiffKind::Flip => DiffMetric::Flip,
            DiffKind::Relmse => DiffMetric::RelMse,
        }
    }
}

/// Arguments of `lumo compare`.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// Reference image (EXR, PFM or PNG).
    pub reference: PathBuf,
    /// Images to score against the reference.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write a false-colour error image here; with several images, `-1`, `-2`, … (in argument
    /// order) is added before the extension.
    #[arg(long, value_name = "OUT.png")]
    pub diff: Option<PathBuf>,
    /// Per-pixel error shown by --diff.
    #[arg(long, value_enum, default_value = "flip")]
    pub diff_metric: DiffKind,
    /// Exposure in stops (×2^stops) applied before tone mapping for PSNR, SSIM and FLIP.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Pixels per degree of visual angle assumed by FLIP [default: 67.02, a 0.7 m wide 4K
    /// monitor at 0.7 m].
    // Negative numbers parse as values, so `--ppd -5` gets the range message, not clap's
    // advice to write `-- -5` (which would pass -5 as an image).
    #[arg(long, allow_negative_numbers = true)]
    pub ppd: Option<f32>,
}

/// One scored image.
struct Row {
    path: PathBuf,
    metrics: Metrics,
    diff: Option<PathBuf>,
}

/// Most stops `--exposure` accepts either way.
const MAX_EXPOSURE: f32 = 64.0;

/// Most pixels per degree `--ppd` accepts. FLIP's filters are as wide as a fixed visual
/// angle, so their size in pixels grows with the ppd (1e30 would allocate without end);
/// 1000 ppd is beyond any display viewed by a person (FLIP's default, 67, is a 0.7 m
/// viewing distance from a 24-inch 4K monitor).
pub const MAX_PPD: f32 = 1000.0;

/// Fewest pixels per degree `--ppd` accepts: below it FLIP's filters are narrower than a
/// pixel and its score was NaN (`--ppd 1e-30`).
pub const MIN_PPD: f32 = 1.0;

/// Bytes per pixel the metrics and a diff image need beyond the images themselves (measured:
/// peak resident memory of `lumo compare --diff` on a 2048² RGB pair, less its inputs).
const COMPARE_BYTES_PER_PIXEL: u64 = 128;

/// The metric settings of `--exposure` and `--ppd`, checked (also `lumo.compare`'s in Python).
pub fn compare_settings(exposure: f32, ppd: Option<f32>) -> Result<CompareSettings> {
    // f32 spans 2^±127: beyond ±64 stops every pixel of any real image is 0 or 1 after the
    // clamp, and PSNR, SSIM and FLIP then report a perfect match of two blank images.
    if !(exposure.is_finite() && exposure.abs() <= MAX_EXPOSURE) {
        bail!("--exposure {exposure}: use a finite number of stops from -{MAX_EXPOSURE} to {MAX_EXPOSURE}");
    }
    let ppd = ppd.unwrap_or(FLIP_DEFAULT_PPD);
    if !(ppd.is_finite() && ppd > 0.0) {
        bail!("--ppd must be a positive number");
    }
    if ppd < MIN_PPD {
        bail!("--ppd {ppd:e}: use at least {MIN_PPD} pixel per degree (FLIP's default is {FLIP_DEFAULT_PPD})");
    }
    if ppd > MAX_PPD {
        bail!("--ppd {ppd:e}: use at most {MAX_PPD} pixels per degree (FLIP's default is {FLIP_DEFAULT_PPD})");
    }
    Ok(CompareSettings {
        exposure,
        flip_ppd: ppd,
    })
}

/// Runs `lumo compare`.
pub fn run(args: CompareArgs) -> Result<()> {
    let settings = compare_settings(args.exposure, args.ppd)?;
    // The diff images are the only outputs: check where they go before reading anything.
    if let Some(out) = &args.diff {
        let inputs: Vec<&Path> = std::iter::once(args.reference.as_path())
            .chain(args.images.iter().map(|p| p.as_path()))
            .collect();
        for i in 0..args.images.len() {
            let diff = diff_path(out, i, args.images.len());
            crate::output::check_writable(&diff).context("--diff")?;
            // Writing a diff over an input would destroy it (it once replaced the reference).
            if let Some(input) = inputs
                .iter()
                .find(|p| crate::cli_common::same_file(p, &diff))
            {
                bail!(
                    "--diff {}: the diff image would overwrite the input {}; name another file",
                    diff.display(),
                    input.display()
                );
            }
        }
    }
    let reference = read_image(&args.reference)?;
    // Every image is held at once, and the metrics work on planes of their own: refuse what
    // cannot fit before reading the rest (an 11585² PNG of 400 KB aborted at 7.4 GB).
    let pixels = (reference.width * reference.height) as u64;
    let image_bytes = pixels * reference.channels as u64 * 4;
    crate::cli_common::check_memory(
        (args.images.len() as u64)
            .saturating_mul(image_bytes)
            .saturating_add(pixels.saturating_mul(COMPARE_BYTES_PER_PIXEL)),
        &format!(
            "comparing {} image(s) of {}x{} pixels",
            args.images.len(),
            reference.width,
            reference.height
        ),
        "compare fewer or smaller images",
    )?;

    // Read and check every image before printing anything, so that a bad argument fails fast
    // and never leaves half a table.
    let mut tests = Vec::with_capacity(args.images.len());
    for path in &args.images {
        let img = read_image(path)?;
        check_comparable(&args.reference, &reference, path, &img)?;
        tests.push(img);
    }

    let mut rows = Vec::with_capacity(tests.len());
    for (i, (path, img)) in args.images.iter().zip(&tests).enumerate() {
        let metrics =
            compare(&reference, img, &settings).map_err(|e| describe(&args.reference, path, e))?;
        let diff = match &args.diff {
            Some(out) => {
                let out = diff_path(out, i, args.images.len());
                let metric = DiffMetric::from(args.diff_metric);
                let map = metric
                    .map(&reference, img, &settings)
                    .map_err(|e| describe(&args.reference, path, e))?;
                write_image(&out, &false_colour(&map, metric))
                    .with_context(|| format!("writing the diff image for {}", path.display()))?;
                Some(out)
            }
            None => None,
        };
        rows.push(Row {
            path: path.clone(),
            metrics,
            diff,
        });
    }

    let all: Vec<&Image> = std::iter::once(&reference).chain(&tests).collect();
    for row in rows.iter().filter(|r| r.metrics.clipped_alike()) {
        errln!(
            "warning: {}: {}",
            row.path.display(),
            clipped_note(&settings, &all, row.metrics.mse)
        );
    }
    if args.json {
        outln!(
            "{}",
            serde_json::to_string_pretty(&to_json(&args, &reference, &settings, &rows))?
        );
    } else {
        print_table(&args, &reference, &settings, &rows);
    }
    Ok(())
}

/// Why PSNR, SSIM and FLIP are not shown for images of MSE `mse` that are
/// [`Metrics::clipped_alike`](lumo_image::metrics::Metrics::clipped_alike), with an exposure
/// that puts the brightest value of `images` at display white.
pub fn clipped_note(settings: &CompareSettings, images: &[&Image], mse: f64) -> String {
    let brightest = images
        .iter()
        .flat_map(|i| i.data.iter())
        .filter(|v| v.is_finite())
        .fold(0.0f32, |m, &v| m.max(v));
    let hint = if brightest > 0.0 {
        let e = (-brightest.log2())
            .clamp(-MAX_EXPOSURE, MAX_EXPOSURE)
            .floor();
        format!("compare at a lower exposure, e.g. --exposure {e} (the brightest value at white)")
    } else {
        "they differ only in negative values, which every exposure shows as black".to_string()
    };
    format!(
        "the images differ (MSE {:.4e}) but are identical after tone mapping at --exposure {}: \
         every differing pixel clips to white or black, so PSNR, SSIM and FLIP cannot see the \
         difference and are not reported; {hint}",
        mse, settings.exposure
    )
}

/// A one-line error naming both images when `test` cannot be compared with `reference`.
pub fn check_comparable(
    ref_path: &Path,
    reference: &Image,
    path: &Path,
    test: &Image,
) -> Result<()> {
    if (reference.width, reference.height) != (test.width, test.height) {
        bail!(
            "size mismatch: {} is {}x{} but {} is {}x{}",
            ref_path.display(),
            reference.width,
            reference.height,
            path.display(),
            test.width,
            test.height
        );
    }
    if reference.channels != test.channels {
        bail!(
            "channel mismatch: {} has {} channels but {} has {}",
            ref_path.display(),
            reference.channels,
            path.display(),
            test.channels
        );
    }
    Ok(())
}

/// A metric error with the two file names in front.
fn describe(ref_path: &Path, path: &Path, e: MetricError) -> anyhow::Error {
    anyhow::anyhow!("{} vs {}: {e}", ref_path.display(), path.display())
}

/// `out` itself for a single image, else `stem-N.ext` with N counted from 1.
fn diff_path(out: &Path, index: usize, count: usize) -> PathBuf {
    if count == 1 {
        return out.to_path_buf();
    }
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match out.extension() {
        Some(ext) => format!("{stem}-{}.{}", index + 1, ext.to_string_lossy()),
        None => format!("{stem}-{}", index + 1),
    };
    out.with_file_name(name)
}

/// What each column means, printed above the table so a pasted table carries its conventions.
fn conventions(settings: &CompareSettings) -> Vec<(&'static str, String)> {
    vec![
        (
            "MSE",
            "mean (x-r)^2 over pixels and channels, linear values".into(),
        ),
        (
            "relMSE",
            format!("mean (x-r)^2/(r^2+eps), eps = {RELMSE_EPSILON}"),
        ),
        (
            "SMAPE",
            format!("mean |x-r|/(|x|+|r|+eps), eps = {SMAPE_EPSILON}"),
        ),
        (
            "PSNR",
            format!(
                "10 log10(1/MSE) in dB of tone-mapped values: {TONE_MAP_DESCRIPTION}, exposure \
                 {} stops",
                settings.exposure
            ),
        ),
        (
            "SSIM",
            format!(
                "tone-mapped Rec.709 luminance, {SSIM_WINDOW}x{SSIM_WINDOW} Gaussian \
                 sigma={SSIM_SIGMA}, K1={SSIM_K1}, K2={SSIM_K2}"
            ),
        ),
        (
            "FLIP",
            format!(
                "LDR-FLIP of the tone-mapped sRGB image (exposure {} stops), {:.2} ppd",
                settings.exposure, settings.flip_ppd
            ),
        ),
    ]
}

fn print_table(args: &CompareArgs, reference: &Image, settings: &CompareSettings, rows: &[Row]) {
    outln!(
        "reference {} ({}x{}, {} channels)",
        args.reference.display(),
        reference.width,
        reference.height,
        reference.channels
    );
    for (name, text) in conventions(settings) {
        outln!("  {name:<7} {text}");
    }
    outln!();
    let names: Vec<String> = rows.iter().map(|r| r.path.display().to_string()).collect();
    let width = names
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(0)
        .max(5);
    outln!(
        "{:<width$}  {:>10}  {:>10}  {:>8}  {:>8}  {:>8}  {:>8}  {:>10}",
        "image",
        "MSE",
        "relMSE",
        "SMAPE",
        "PSNR dB",
        "SSIM",
        "FLIP",
        "non-finite"
    );
    for (row, name) in rows.iter().zip(&names) {
        let m = &row.metrics;
        let [psnr, ssim, flip] = if m.clipped_alike() {
            ["clipped".to_string(), "clipped".into(), "clipped".into()]
        } else {
            [
                if m.psnr.is_finite() {
                    format!("{:.2}", m.psnr)
                } else {
                    "inf".into()
                },
                format!("{:.5}", m.ssim),
                format!("{:.5}", m.flip),
            ]
        };
        outln!(
            "{name:<width$}  {:>10.4e}  {:>10.4e}  {:>8.5}  {psnr:>8}  {ssim:>8}  {flip:>8}  {:>10}",
            m.mse,
            m.relmse,
            m.smape,
            m.nonfinite_pixels
        );
    }
    if rows.iter().any(|r| r.metrics.clipped_alike()) {
        outln!();
        outln!(
            "clipped: the linear values differ but every differing pixel clips to white or black \
             at this exposure, so PSNR, SSIM and FLIP cannot see the difference (see the warning)"
        );
    }
    let excluded: Vec<_> = rows
        .iter()
        .filter(|r| r.metrics.nonfinite_pixels > 0)
        .collect();
    if !excluded.is_empty() {
        outln!();
        outln!(
            "non-finite: pixels with a NaN or infinite channel in the reference or the image; \
             left out of every metric"
        );
    }
    for row in rows {
        if let Some(d) = &row.diff {
            outln!(
                "diff {} -> {} ({})",
                row.path.display(),
                d.display(),
                DiffMetric::from(args.diff_metric).scale_description()
            );
        }
    }
}

fn to_json(
    args: &CompareArgs,
    reference: &Image,
    settings: &CompareSettings,
    rows: &[Row],
) -> serde_json::Value {
    // JSON has no infinity: identical tone-mapped images give "psnr_db": null.
    let finite = |v: f64| {
        if v.is_finite() {
            json!(v)
        } else {
            serde_json::Value::Null
        }
    };
    let images: Vec<_> = rows
        .iter()
        .map(|r| {
            let m = &r.metrics;
            // Clipped alike: the tone-mapped scores would call different images identical.
            let seen = |v: f64| {
                if m.clipped_alike() {
                    serde_json::Value::Null
                } else {
                    finite(v)
                }
            };
            json!({
                "image": r.path.display().to_string(),
                "mse": finite(m.mse),
                "relmse": finite(m.relmse),
                "smape": finite(m.smape),
                "psnr_db": seen(m.psnr),
                "ssim": seen(m.ssim),
                "flip": seen(m.flip),
                "clipped_alike": m.clipped_alike(),
                "nonfinite_pixels": m.nonfinite_pixels,
                "diff": r.diff.as_ref().map(|d| d.display().to_string()),
            })
        })
        .collect();
    json!({
        "reference": {
            "image": args.reference.display().to_string(),
            "width": reference.width,
            "height": reference.height,
            "channels": reference.channels,
        },
        "settings": {
            "exposure_stops": settings.exposure,
            "relmse_epsilon": RELMSE_EPSILON,
            "smape_epsilon": SMAPE_EPSILON,
            "tone_map": TONE_MAP_DESCRIPTION,
            "psnr_peak": 1.0,
            "ssim": {
                "input": "tone-mapped Rec.709 luminance",
                "window": SSIM_WINDOW,
                "sigma": SSIM_SIGMA,
                "k1": SSIM_K1,
                "k2": SSIM_K2,
            },
            "flip": { "mode": "LDR", "ppd": settings.flip_ppd },
            "diff_metric": args.diff.as_ref().map(|_| match args.diff_metric {
                DiffKind::Flip => "flip",
                DiffKind::Relmse => "relmse",
            }),
            "nonfinite_policy": "pixels with a NaN or infinite channel in either image are left \
                                 out of every metric and counted in nonfinite_pixels",
        },
        "images": images,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diff_paths_get_an_index_only_for_several_images() {
        let out = Path::new("dir/err.png");
        assert_eq!(diff_path(out, 0, 1), Path::new("dir/err.png"));
        assert_eq!(diff_path(out, 0, 3), Path::new("dir/err-1.png"));
        assert_eq!(diff_path(out, 2, 3), Path::new("dir/err-3.png"));
        assert_eq!(diff_path(Path::new("err"), 1, 2), Path::new("err-2"));
    }
}
