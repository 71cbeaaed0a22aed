//! What every frame of one `lumo render` shares, and how one image is rendered and written.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lumo_image::{write_image, Image};
use lumo_pipeline::{run_pipeline, run_pipeline_on_sums, Pipeline};
use lumo_render::camera::PinholeCamera;
use lumo_render::{
    Frame, IntegratorOptions, PixelSums, PpmStats, RenderScene, RenderSettings, RenderStats,
};

use super::args::RenderArgs;
use super::validate::ppm_settings;

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
    /// Photon mapping's counters.
    pub ppm: Option<PpmStats>,
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

    /// Renders `rs` with the job's integrator and pipeline; `progress` gets 0..1. The
    /// integrators without a G-buffer render through lumo-render's table, refusing a scene
    /// they cannot render; the path tracer through the filtering pipeline.
    pub fn render(&self, rs: &RenderScene, progress: &(dyn Fn(f32) + Sync)) -> Result<Rendered> {
        let settings = &self.settings;
        let integrator = self.args.integrator;
        if !integrator.caps().gbuffer {
            let camera = PinholeCamera::new(&rs.scene.camera, settings.width, settings.height);
            if let Some(why) = integrator.scene_refusal(rs, &camera) {
                bail!(why);
            }
            let options = IntegratorOptions {
                ppm: ppm_settings(self.args)?,
            };
            let out = self
                .pool
                .install(|| integrator.render_image(rs, settings, &options, progress));
            return Ok(Rendered {
                image: out.image,
                stats: out.stats,
                aovs: None,
                timings: None,
                ppm: out.ppm,
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
        Ok(self.rendered(self.with_dirac(rs, out)))
    }

    /// `out` with the Dirac lights' exact light among its planes when AOVs are written and the
    /// pipeline did not make it (`--pipeline none`, say): `lumo denoise --input-dir` keeps
    /// that plane out of its filter, so the planes a user denoises later carry it too.
    fn with_dirac(
        &self,
        rs: &RenderScene,
        mut out: lumo_pipeline::PipelineOutput,
    ) -> lumo_pipeline::PipelineOutput {
        if self.args.aovs.is_some() && out.planes.iter().all(|(n, _)| *n != "dirac") {
            let s = &self.settings;
            let camera = PinholeCamera::new(&rs.scene.camera, s.width, s.height);
            if let Some(d) = self
                .pool
                .install(|| lumo_render::dirac_direct(rs, &camera, s))
            {
                out.planes.push(("dirac", d));
            }
        }
        out
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
        Ok(self.rendered(self.with_dirac(rs, out)))
    }

    fn rendered(&self, out: lumo_pipeline::PipelineOutput) -> Rendered {
        Rendered {
            image: out.image,
            stats: out.stats,
            timings: (self.pipeline != Pipeline::None).then(|| out.timings.to_string()),
            aovs: Some((out.frame, out.planes)),
            ppm: None,
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
