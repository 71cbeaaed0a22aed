//! `lumo render` carried out: one image, the photon mapper's, or a sequence of frames.

use crate::cli_common::{errln, outln};
use std::time::Instant;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};

use super::args::RenderArgs;
use super::job::Job;
use super::plan::{Choices, Ready};
use crate::arguments::ppm_map_bytes;
use crate::output::si;

/// Renders what `ready` planned and writes it, saying on stdout how fast it went.
pub fn execute(args: &RenderArgs, ready: Ready) -> Result<()> {
    let Ready {
        choices:
            Choices {
                pipeline,
                settings,
                ppm: _,
                sequence,
                outputs,
            },
        pool,
        rs,
        build,
    } = ready;
    let job = Job {
        args,
        pipeline,
        settings,
        pool: &pool,
        outputs,
    };
    if let Some(seq) = sequence {
        if let Some(dir) = &args.temporal_eval {
            return super::temporal_eval::run(&seq, &job, rs, dir, args.reference_spp);
        }
        return seq.run(&job, rs, build);
    }
    let bar = ProgressBar::new(1000).with_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}%  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
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
    if let Some(stats) = out.ppm {
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
    let unit = args.integrator.info().sample_unit;
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
