//! The one table of integrators: each light-transport algorithm that renders whole images,
//! with its name, what it can do, what it needs from the scene and what its samples count
//! ([`Integrator::info`]), and the one entry point that renders an image with any of them
//! ([`Integrator::render_image`]), and its samples one by one for a progressive viewer's
//! streams ([`Integrator::stream_camera_sample`], [`Integrator::stream_light_path`]).
//! `lumo render`, `lumo serve`, `lumo bench` and the wire protocol derive their lists, checks
//! and messages from it, as the filters do from `lumo_filter::FILTERS`; adding an integrator is
//! a variant, a row and its dispatch arms here.

use lumo_image::Image;

use crate::camera::PinholeCamera;
use crate::integrators::bdpt::BdptSettings;
use crate::integrators::path::PathSettings;
use crate::integrators::photon::{self, PpmSettings};
use crate::render::{render, render_bdpt, render_light, render_ppm, PpmStats};
use crate::render_scene::RenderScene;
use crate::settings::{RenderSettings, RenderStats};
use crate::stream::{SampleStream, StreamSample};

/// A light-transport algorithm that renders whole images.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Integrator {
    /// Unidirectional path tracing from the camera.
    Path,
    /// Particle tracing from the lights.
    Light,
    /// Bidirectional path tracing.
    Bdpt,
    /// One-pass progressive photon mapping.
    Ppm,
}

/// What an integrator needs from the scene's lights as particle sources.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Particles {
    /// Never starts paths at the lights.
    Unused,
    /// Starts every path at a light: refuses a scene whose lights emit no particles
    /// (environment lights emit none).
    Required,
    /// Joins light subpaths where lights emit particles; without them it renders as a path
    /// tracer, which is said as a warning.
    Optional,
    /// Traces photons from the lights; without them only emitters and direct light appear,
    /// which is said as a warning.
    Photons,
}

/// What an integrator can do and needs; the front ends check options against it.
#[derive(Clone, Copy, Debug)]
pub struct Capabilities {
    /// Transports light at three hero wavelengths (`PathSettings::spectral`).
    pub spectral: bool,
    /// Makes a G-buffer and per-pixel sample sums beside the image: AOV planes, the filtering
    /// pipelines, the temporal filter and chunked (distributed) renders take only it.
    pub gbuffer: bool,
    /// Transports light through participating media and null boundaries.
    pub media: bool,
    /// Projects light onto a pinhole's film, so it refuses thin lenses, orthographic cameras
    /// and pixel filters wider than the box.
    pub splats: bool,
    /// What it needs from the lights.
    pub particles: Particles,
    /// Feeds the server's camera sample stream ([`Integrator::stream_camera_sample`]).
    pub camera_stream: bool,
    /// Feeds the server's light sample stream: with its camera samples where it feeds both
    /// streams (each camera sample then counts as one light path), else by light paths of
    /// its own ([`Integrator::stream_light_path`]).
    pub light_stream: bool,
}

/// An integrator's row of the table.
#[derive(Clone, Copy, Debug)]
pub struct IntegratorInfo {
    /// The name on every command line (`--integrator NAME`), in tables and on the wire.
    pub name: &'static str,
    /// What it is called in sentences ("the light tracer").
    pub label: &'static str,
    /// One line for `--help`.
    pub description: &'static str,
    /// What its samples-per-second count (the closing line of `lumo render`).
    pub sample_unit: &'static str,
    /// What `--spp` counts for it.
    pub spp_counts: &'static str,
    /// What it can do and needs.
    pub caps: Capabilities,
}

/// Settings that some integrators take beyond [`RenderSettings`].
#[derive(Clone, Copy, Debug, Default)]
pub struct IntegratorOptions {
    /// Photon mapping's map size, pass size and radius.
    pub ppm: PpmSettings,
}

/// One image rendered by [`Integrator::render_image`].
#[derive(Clone, Debug)]
pub struct RenderedImage {
    /// The image (linear RGB).
    pub image: Image,
    /// Work counters.
    pub stats: RenderStats,
    /// Photon mapping's own counters (`None` for the others).
    pub ppm: Option<PpmStats>,
}

impl Integrator {
    /// Every integrator, in the order lists show them.
    pub const ALL: [Integrator; 4] = [
        Integrator::Path,
        Integrator::Light,
        Integrator::Bdpt,
        Integrator::Ppm,
    ];

    /// Its row of the table.
    pub const fn info(self) -> &'static IntegratorInfo {
        match self {
            Integrator::Path => &IntegratorInfo {
                name: "path",
                label: "path tracer",
                description: "Path tracing from the camera with next-event estimation (every \
                              pipeline, AOVs)",
                sample_unit: "samples",
                spp_counts: "camera samples per pixel",
                caps: Capabilities {
                    spectral: true,
                    gbuffer: true,
                    media: true,
                    splats: false,
                    particles: Particles::Unused,
                    camera_stream: true,
                    light_stream: false,
                },
            },
            Integrator::Light => &IntegratorInfo {
                name: "light",
                label: "light tracer",
                description: "Particle tracing from the lights, each vertex splatted onto the \
                              film (no pipeline, no AOVs; environment lights emit nothing)",
                sample_unit: "light paths",
                spp_counts: "light paths per pixel of the image",
                caps: Capabilities {
                    spectral: true,
                    gbuffer: false,
                    media: true,
                    splats: true,
                    particles: Particles::Required,
                    camera_stream: false,
                    light_stream: true,
                },
            },
            Integrator::Bdpt => &IntegratorInfo {
                name: "bdpt",
                label: "bidirectional path tracer",
                description: "Bidirectional path tracing: camera and light subpaths joined by \
                              every strategy with multiple importance sampling (no pipeline, \
                              no AOVs)",
                sample_unit: "samples",
                spp_counts: "camera and light subpath pairs per pixel",
                caps: Capabilities {
                    spectral: false,
                    gbuffer: false,
                    media: true,
                    splats: true,
                    particles: Particles::Optional,
                    camera_stream: true,
                    light_stream: true,
                },
            },
            Integrator::Ppm => &IntegratorInfo {
                name: "ppm",
                label: "photon mapping",
                description: "One-pass progressive photon mapping: photon batches grow a kd-tree \
                              while the passes gather from it at a shrinking radius (no \
                              pipeline, no AOVs)",
                sample_unit: "samples",
                spp_counts: "passes: a photon batch, then one camera sample per pixel",
                caps: Capabilities {
                    spectral: false,
                    gbuffer: false,
                    media: false,
                    splats: false,
                    particles: Particles::Photons,
                    camera_stream: true,
                    light_stream: false,
                },
            },
        }
    }

    /// Its name (`--integrator NAME`).
    pub const fn name(self) -> &'static str {
        self.info().name
    }

    /// Its capabilities.
    pub const fn caps(self) -> Capabilities {
        self.info().caps
    }

    /// The integrator called `name`, as [`Integrator::name`] spells it.
    pub fn from_name(name: &str) -> Option<Integrator> {
        Integrator::ALL.into_iter().find(|i| i.name() == name)
    }

    /// The names of the integrators `keep` selects, joined as a sentence ("path or light",
    /// with `word` = "or"): refusal messages list the alternatives with it.
    pub fn names_where(keep: impl Fn(Capabilities) -> bool, word: &str) -> String {
        let names: Vec<&str> = Integrator::ALL
            .into_iter()
            .filter(|i| keep(i.caps()))
            .map(Integrator::name)
            .collect();
        sentence(&names, word)
    }

    /// Why it cannot render a scene with participating media (`None` where it can or the
    /// scene has none), naming the integrators that can.
    pub fn media_refusal(self, scene: &lumo_scene::Scene) -> Option<String> {
        crate::media::refusal(scene, self.name(), self.caps().media)
    }

    /// Why it cannot render `rs` through `camera` (`None` where it can): a camera that only
    /// the integrators without splats render, or lights that emit no particles to start from.
    pub fn scene_refusal(self, rs: &RenderScene, camera: &PinholeCamera) -> Option<String> {
        let name = self.name();
        let scene = &rs.scene.name;
        let caps = self.caps();
        if caps.splats {
            if let Some(what) = camera.unsupported_by_splats() {
                let splatting: Vec<&str> = Integrator::ALL
                    .into_iter()
                    .filter(|i| i.caps().splats)
                    .map(|i| i.info().label)
                    .collect();
                return Some(format!(
                    "{scene}: --integrator {name}: the scene has {what}, which the {} (they \
                     project light onto a pinhole's film) do not render; use --integrator {}",
                    splatting.join(" and "),
                    Integrator::names_where(|c| !c.splats, "or")
                ));
            }
        }
        if caps.particles == Particles::Required && rs.lights.emits_no_particles() {
            return Some(format!(
                "{scene}: --integrator {name}: no light emits particles (environment lights do \
                 not); use --integrator {}",
                Integrator::Path.name()
            ));
        }
        None
    }

    /// A warning (one line, "warning: …") where it renders `rs` less fully than the path
    /// tracer would: `None` where it renders the scene as intended.
    pub fn scene_warning(
        self,
        rs: &RenderScene,
        camera: &PinholeCamera,
        path: &PathSettings,
    ) -> Option<String> {
        match self.caps().particles {
            Particles::Unused | Particles::Required => None,
            Particles::Optional => rs.lights.emits_no_particles().then(|| {
                format!(
                    "warning: {}: no light emits particles (environment lights do not): \
                     --integrator {} runs as a path tracer here",
                    rs.scene.name,
                    self.name()
                )
            }),
            Particles::Photons => photon::scene_warning(rs, camera, path),
        }
    }

    /// Renders the whole image `settings` describes with this integrator, in the current
    /// rayon pool; `progress` gets the fraction done. The image is the same bits on any number
    /// of threads. Check [`Integrator::scene_refusal`] first: a refused scene renders black.
    pub fn render_image(
        self,
        rs: &RenderScene,
        settings: &RenderSettings,
        options: &IntegratorOptions,
        progress: &(dyn Fn(f32) + Sync),
    ) -> RenderedImage {
        let plain = |(image, stats)| RenderedImage {
            image,
            stats,
            ppm: None,
        };
        match self {
            Integrator::Path => {
                let rows = settings.height.max(1) as f32;
                let (frame, stats) = render(rs, settings, &|done| progress(done as f32 / rows));
                plain((frame.color, stats))
            }
            Integrator::Light => plain(render_light(rs, settings, progress)),
            Integrator::Bdpt => {
                let bdpt = BdptSettings {
                    path: settings.path,
                    only: None,
                };
                plain(render_bdpt(rs, settings, &bdpt, progress))
            }
            Integrator::Ppm => {
                let (image, stats) = render_ppm(rs, settings, &options.ppm, progress);
                RenderedImage {
                    image,
                    stats: RenderStats {
                        samples: stats.samples,
                        rays: stats.rays,
                    },
                    ppm: Some(stats),
                }
            }
        }
    }
}

impl Integrator {
    /// Its camera sample of pixel (x, y) in pass `pass` for the progressive streams, and the
    /// rays it traced; samples it also feeds the light stream with go to `light`. `None` for an
    /// integrator without [`Capabilities::camera_stream`].
    pub fn stream_camera_sample(
        self,
        stream: &SampleStream,
        x: u32,
        y: u32,
        pass: u32,
        light: &mut impl FnMut(StreamSample),
    ) -> Option<(StreamSample, u32)> {
        match self {
            Integrator::Path => Some(stream.path_sample(x, y, pass)),
            Integrator::Light => None,
            Integrator::Bdpt => Some(stream.bdpt_sample(x, y, pass, light)),
            Integrator::Ppm => stream.ppm_sample(x, y, pass),
        }
    }

    /// Its light path `m` for the progressive light stream: the splats go to `out`; returns
    /// the rays traced. `None` for an integrator without light paths of its own (see
    /// [`Capabilities::light_stream`]).
    pub fn stream_light_path(
        self,
        stream: &SampleStream,
        m: u64,
        out: &mut impl FnMut(StreamSample),
    ) -> Option<u32> {
        match self {
            Integrator::Light => Some(stream.light_path(m, out)),
            Integrator::Path | Integrator::Bdpt | Integrator::Ppm => None,
        }
    }

    /// Whether it feeds the light stream by light paths of its own.
    pub fn streams_light_paths(self) -> bool {
        let caps = self.caps();
        caps.light_stream && !caps.camera_stream
    }
}

/// `names` as a list in a sentence: "a", "a or b", "a, b or c" (with `word` = "or").
pub fn sentence<S: AsRef<str>>(names: &[S], word: &str) -> String {
    match names.split_last() {
        None => String::new(),
        Some((last, [])) => last.as_ref().to_owned(),
        Some((last, rest)) => {
            let rest: Vec<&str> = rest.iter().map(AsRef::as_ref).collect();
            format!("{} {word} {}", rest.join(", "), last.as_ref())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every variant is in `ALL` once, and names find their integrators back.
    #[test]
    fn the_table_lists_every_integrator_once_by_a_unique_name() {
        for i in Integrator::ALL {
            // Exhaustive: a new variant fails to compile here until it is listed.
            let listed = match i {
                Integrator::Path | Integrator::Light | Integrator::Bdpt | Integrator::Ppm => {
                    Integrator::ALL.iter().filter(|&&j| j == i).count()
                }
            };
            assert_eq!(listed, 1, "{i:?}");
            assert_eq!(Integrator::from_name(i.name()), Some(i));
            assert!(!i.info().description.is_empty() && !i.info().label.is_empty());
        }
        assert_eq!(Integrator::from_name("both"), None);
    }

    /// The sentences the refusals are built from read as they did when they were written out.
    #[test]
    fn capability_lists_read_as_sentences() {
        assert_eq!(
            Integrator::names_where(|c| c.spectral, "or"),
            "path or light"
        );
        assert_eq!(
            Integrator::names_where(|c| !c.spectral, "and"),
            "bdpt and ppm"
        );
        assert_eq!(Integrator::names_where(|c| !c.splats, "or"), "path or ppm");
        assert_eq!(Integrator::names_where(|c| c.gbuffer, "or"), "path");
        assert_eq!(Integrator::names_where(|_| false, "or"), "");
    }
}
