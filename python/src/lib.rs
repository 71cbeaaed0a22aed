//! `lumo._native`: the Rust side of lumo's Python package. Images cross as `(bytes, height,
//! width, channels)` of little-endian float32 (the `lumo` package turns them into numpy arrays
//! and back); every call that works releases the GIL; every error is a `lumo.LumoError` with
//! lumo's own message (the file, the field, the fix).
#![forbid(unsafe_code)]

use std::path::PathBuf;

use lumo_cli::chunked::{Chunk, ChunkedRender, Role};
use lumo_image::Image;
use lumo_render::{frame_from_estimates, PixelSums};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

create_exception!(
    _native,
    LumoError,
    PyException,
    "An error with lumo's own message."
);

fn lumo_err(e: anyhow::Error) -> PyErr {
    LumoError::new_err(format!("{e:#}"))
}

/// An image as `(bytes, height, width, channels)`.
type Planar<'py> = (Bound<'py, PyBytes>, usize, usize, usize);

fn to_planar<'py>(py: Python<'py>, img: &Image) -> Planar<'py> {
    let bytes: Vec<u8> = img.data.iter().flat_map(|v| v.to_le_bytes()).collect();
    (
        PyBytes::new(py, &bytes),
        img.height,
        img.width,
        img.channels,
    )
}

fn from_planar(data: &[u8], height: usize, width: usize, channels: usize) -> PyResult<Image> {
    let n = height
        .checked_mul(width)
        .and_then(|p| p.checked_mul(channels))
        .ok_or_else(|| LumoError::new_err("image size overflows"))?;
    if data.len() != n * 4 {
        return Err(LumoError::new_err(format!(
            "{} bytes for a {width}x{height} image of {channels} float32 channels ({} expected)",
            data.len(),
            n * 4
        )));
    }
    let mut img = Image::new(width, height, channels, 0.0);
    for (v, b) in img.data.iter_mut().zip(data.chunks_exact(4)) {
        *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    Ok(img)
}

/// `lumo render WORDS…` planned for rendering in chunks of samples (see `lumo.ray`).
#[pyclass(module = "lumo._native")]
struct RenderPlan {
    inner: ChunkedRender,
}

#[pymethods]
impl RenderPlan {
    /// Plans the words after `lumo render`; a driver also checks the outputs.
    #[new]
    #[pyo3(signature = (words, driver = false))]
    fn new(py: Python<'_>, words: Vec<String>, driver: bool) -> PyResult<Self> {
        let role = if driver { Role::Driver } else { Role::Worker };
        let inner = py
            .allow_threads(|| ChunkedRender::new(&words, role))
            .map_err(lumo_err)?;
        Ok(RenderPlan { inner })
    }

    /// The frames to render (`[0]` for a still).
    #[getter]
    fn frames(&self) -> Vec<u32> {
        self.inner.frames()
    }

    /// Samples per pixel of each frame.
    #[getter]
    fn spp(&self) -> u32 {
        self.inner.spp()
    }

    /// `(width, height)`.
    #[getter]
    fn size(&self) -> (usize, usize) {
        self.inner.size()
    }

    /// Fingerprint of options, scene file and lumo version.
    #[getter]
    fn plan_id(&self) -> u64 {
        self.inner.plan_id()
    }

    /// Every frame cut into `(frame, first, count)` chunks of at most `chunk_spp` samples.
    fn chunks(&self, chunk_spp: u32) -> Vec<(u32, u32, u32)> {
        self.inner
            .chunks(chunk_spp)
            .into_iter()
            .map(|c| (c.frame, c.first, c.count))
            .collect()
    }

    /// Renders one chunk; returns its exact sums as bytes.
    fn render_chunk<'py>(
        &mut self,
        py: Python<'py>,
        frame: u32,
        first: u32,
        count: u32,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let size = self.inner.size();
        let inner = &mut self.inner;
        let bytes = py
            .allow_threads(|| {
                inner
                    .render_chunk(Chunk {
                        frame,
                        first,
                        count,
                    })
                    .map(|c| c.to_bytes(size))
            })
            .map_err(lumo_err)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// Checks a chunk's bytes against this plan (and against `expect`, the
    /// `(frame, first, count)` the task was given) and adds them to their frame's sums (exact:
    /// the order of arrival does not matter); returns the chunk's `(frame, first, count)`.
    #[pyo3(signature = (data, expect = None))]
    fn add_chunk(
        &mut self,
        py: Python<'_>,
        data: &[u8],
        expect: Option<(u32, u32, u32)>,
    ) -> PyResult<(u32, u32, u32)> {
        let inner = &mut self.inner;
        let c = py
            .allow_threads(|| {
                let c = inner.read_chunk(data)?;
                let got = (c.chunk.frame, c.chunk.first, c.chunk.count);
                if let Some(want) = expect.filter(|&w| w != got) {
                    anyhow::bail!(
                        "it holds frame {} samples {}..+{} where frame {} samples {}..+{} were \
                         asked for",
                        got.0,
                        got.1,
                        got.2,
                        want.0,
                        want.1,
                        want.2
                    );
                }
                inner.add(c)
            })
            .map_err(lumo_err)?;
        Ok((c.frame, c.first, c.count))
    }

    /// Runs the pipeline on a frame's added-up chunks (covering samples `0..spp`) and writes
    /// what `lumo render` writes; returns what was written.
    fn finish<'py>(&mut self, py: Python<'py>, frame: u32) -> PyResult<Bound<'py, PyDict>> {
        let inner = &mut self.inner;
        let done = py.allow_threads(|| inner.finish(frame)).map_err(lumo_err)?;
        let d = PyDict::new(py);
        let files: Vec<String> = done.files.iter().map(|p| p.display().to_string()).collect();
        d.set_item("files", files)?;
        d.set_item("aovs", done.aovs.map(|p: PathBuf| p.display().to_string()))?;
        d.set_item("samples", done.samples)?;
        d.set_item("rays", done.rays)?;
        Ok(d)
    }

    /// Renders samples `first..first + count` of frame `frame` as a [`Passes`].
    fn render_passes(
        &mut self,
        py: Python<'_>,
        frame: u32,
        first: u32,
        count: u32,
    ) -> PyResult<Passes> {
        let size = self.inner.size();
        let plan_id = self.inner.plan_id();
        let inner = &mut self.inner;
        let c = py
            .allow_threads(|| {
                inner.render_chunk(Chunk {
                    frame,
                    first,
                    count,
                })
            })
            .map_err(lumo_err)?;
        Ok(Passes {
            size,
            plan_id,
            frame,
            ranges: vec![(first, first + count)],
            sums: c.sums,
        })
    }
}

/// The exact per-pixel sums of some sample passes of one frame: they add up, bit for bit.
#[pyclass(module = "lumo._native", frozen)]
struct Passes {
    size: (usize, usize),
    plan_id: u64,
    frame: u32,
    /// Sample ranges summed, sorted and disjoint.
    ranges: Vec<(u32, u32)>,
    sums: Vec<PixelSums>,
}

#[pymethods]
impl Passes {
    /// Sample ranges `(start, end)` summed.
    #[getter]
    fn ranges(&self) -> Vec<(u32, u32)> {
        self.ranges.clone()
    }

    /// Samples summed per pixel.
    #[getter]
    fn count(&self) -> u32 {
        self.ranges.iter().map(|(a, b)| b - a).sum()
    }

    /// `(width, height)`.
    #[getter]
    fn size(&self) -> (usize, usize) {
        self.size
    }

    /// Both sets of passes added up; they must be of one render and not overlap.
    fn add(&self, py: Python<'_>, other: &Passes) -> PyResult<Passes> {
        if other.plan_id != self.plan_id || other.frame != self.frame {
            return Err(LumoError::new_err(
                "these renders differ in scene, settings or frame; only passes of one render add up",
            ));
        }
        let mut ranges = self.ranges.clone();
        ranges.extend(&other.ranges);
        ranges.sort_unstable();
        if let Some(w) = ranges.windows(2).find(|w| w[1].0 < w[0].1) {
            return Err(LumoError::new_err(format!(
                "passes {}..{} and {}..{} overlap: each sample may be added once",
                w[0].0, w[0].1, w[1].0, w[1].1
            )));
        }
        let sums = py.allow_threads(|| {
            let mut sums = self.sums.clone();
            for (a, b) in sums.iter_mut().zip(&other.sums) {
                a.merge(b);
            }
            sums
        });
        Ok(Passes {
            size: self.size,
            plan_id: self.plan_id,
            frame: self.frame,
            ranges,
            sums,
        })
    }

    /// Every plane of the frame as `name → (bytes, height, width, channels)`: `color` (the
    /// image) and the AOVs of `lumo render --aovs`. The G-buffer planes come from the
    /// pixel-centre sample, sample 0, and are zero where it is not among the passes.
    fn planes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (w, h) = self.size;
        let count = self.count();
        let frame = py.allow_threads(|| {
            let estimates: Vec<_> = self.sums.iter().map(PixelSums::estimate).collect();
            frame_from_estimates(w, h, count, &estimates)
        });
        let d = PyDict::new(py);
        for (name, img) in frame.planes() {
            d.set_item(name, to_planar(py, img))?;
        }
        Ok(d)
    }
}

/// `(spp, (width, height))` that `lumo render WORDS…` would use; loads the scene file but
/// builds no BVH.
#[pyfunction]
fn planned_defaults(py: Python<'_>, words: Vec<String>) -> PyResult<(u32, (usize, usize))> {
    py.allow_threads(|| lumo_cli::chunked::planned_defaults(&words))
        .map_err(lumo_err)
}

/// Renders `lumo render WORDS…` (a still, any integrator and pipeline) and returns the image.
#[pyfunction]
fn render_image<'py>(py: Python<'py>, words: Vec<String>) -> PyResult<Planar<'py>> {
    let img = py
        .allow_threads(|| lumo_cli::chunked::render_image(&words))
        .map_err(lumo_err)?;
    Ok(to_planar(py, &img))
}

/// Runs `lumo denoise WORDS…`.
#[pyfunction]
fn denoise_words(py: Python<'_>, words: Vec<String>) -> PyResult<()> {
    py.allow_threads(|| lumo_cli::denoise::run_words(&words))
        .map_err(lumo_err)
}

/// Every metric of `lumo compare` of `image` against `reference`, as a dict.
#[pyfunction]
#[pyo3(signature = (reference, image, exposure = 0.0, ppd = None))]
fn compare<'py>(
    py: Python<'py>,
    reference: Planar<'py>,
    image: Planar<'py>,
    exposure: f32,
    ppd: Option<f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let r = from_planar(
        reference.0.as_bytes(),
        reference.1,
        reference.2,
        reference.3,
    )?;
    let t = from_planar(image.0.as_bytes(), image.1, image.2, image.3)?;
    let (m, note) = py
        .allow_threads(|| -> anyhow::Result<_> {
            let settings = lumo_cli::compare_cmd::compare_settings(exposure, ppd)?;
            let (a, b) = (PathBuf::from("reference"), PathBuf::from("image"));
            lumo_cli::compare_cmd::check_comparable(&a, &r, &b, &t)?;
            let m = lumo_image::metrics::compare(&r, &t, &settings)
                .map_err(|e| anyhow::anyhow!("reference vs image: {e}"))?;
            let note = m
                .clipped_alike()
                .then(|| lumo_cli::compare_cmd::clipped_note(&settings, &[&r, &t], m.mse));
            Ok((m, note))
        })
        .map_err(lumo_err)?;
    // As `lumo compare --json`: the tone-mapped scores of images that differ only where both
    // clip would call them identical, so they are None and `clipped_note` says why.
    let seen = |v: f64| (!m.clipped_alike()).then_some(v);
    let d = PyDict::new(py);
    d.set_item("mse", m.mse)?;
    d.set_item("relmse", m.relmse)?;
    d.set_item("smape", m.smape)?;
    d.set_item("psnr", seen(m.psnr))?;
    d.set_item("ssim", seen(m.ssim))?;
    d.set_item("flip", seen(m.flip))?;
    d.set_item("clipped_alike", m.clipped_alike())?;
    d.set_item("clipped_note", note)?;
    d.set_item("nonfinite_pixels", m.nonfinite_pixels)?;
    Ok(d)
}

/// Reads an EXR, PFM or PNG file.
#[pyfunction]
fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Planar<'py>> {
    let img = py
        .allow_threads(|| lumo_image::read_image(&path))
        .map_err(|e| lumo_err(e.into()))?;
    Ok(to_planar(py, &img))
}

/// Writes an EXR, PFM or PNG file (atomically, as every lumo command).
#[pyfunction]
fn write_image<'py>(py: Python<'py>, path: PathBuf, image: Planar<'py>) -> PyResult<()> {
    let img = from_planar(image.0.as_bytes(), image.1, image.2, image.3)?;
    py.allow_threads(|| lumo_image::write_image(&path, &img))
        .map_err(|e| lumo_err(e.into()))
}

/// Runs a render worker for the hub of `lumo serve --remote-workers` at `hub` (`HOST:PORT`)
/// with its `token`, until the hub closes the connection; Ctrl-C (a Python signal) stops it.
#[pyfunction]
#[pyo3(signature = (hub, token, name, threads = 0))]
fn run_remote_worker(
    py: Python<'_>,
    hub: String,
    token: String,
    name: String,
    threads: usize,
) -> PyResult<()> {
    use std::sync::atomic::Ordering;
    use std::time::Duration;
    let mut config = lumo_server::remote::RemoteWorkerConfig::new(hub, token, name);
    config.threads = threads;
    let stop = config.stop.clone();
    let worker = std::thread::spawn(move || lumo_server::remote::run_remote_worker(config));
    // The worker runs on its own thread so that this one can look for Python signals.
    while !worker.is_finished() {
        py.allow_threads(|| std::thread::sleep(Duration::from_millis(50)));
        if let Err(e) = py.check_signals() {
            stop.store(true, Ordering::Relaxed);
            let _ = py.allow_threads(|| worker.join());
            return Err(e);
        }
    }
    match worker.join() {
        Ok(result) => result.map_err(|e| LumoError::new_err(e.to_string())),
        Err(_) => Err(LumoError::new_err("the render worker panicked")),
    }
}

/// The version of the lumo crates this module was built from.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LumoError", m.py().get_type::<LumoError>())?;
    m.add_class::<RenderPlan>()?;
    m.add_class::<Passes>()?;
    m.add_function(wrap_pyfunction!(planned_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(render_image, m)?)?;
    m.add_function(wrap_pyfunction!(denoise_words, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(run_remote_worker, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
