//! The one interface every filter offers ([`Denoiser`]), the input set it reads
//! ([`FilterInput`]) and the one list of filters ([`FILTERS`]), which the command line, the
//! benchmarks and the tables use instead of lists of their own.
//!
//! Why one seam: each filter has an entry point of its own shape (`atrous(colour, features,
//! params)`, `guided(colour, guide, params)` after `build_guide`, `jbu(low, features, params)`,
//! `TemporalFilter::filter(frame)`), so every caller that let a user choose a filter had its
//! own list of names and its own dispatch. Behind this trait a caller holds a
//! `Box<dyn Denoiser>` made from the list and calls [`Denoiser::denoise`]; the functions stay
//! as they are, and the trait calls them unchanged (so the results are the same bit for bit).
//!
//! Choices:
//! - `denoise` takes `&mut self`: a denoiser owns its working memory (the À-Trous keeps about
//!   18 floats per pixel between frames) and, for the temporal filter, its history. So the
//!   stateful [`crate::TemporalFilter`] is a `Denoiser` like the others, with no second trait:
//!   motion vectors and ids are optional members of [`FilterInput`] (ignored by the spatial
//!   filters), and [`Denoiser::reset`] forgets a history (a no-op elsewhere).
//! - Parameters stay per filter ([`crate::AtrousParams`], …), held by the filter's denoiser
//!   struct as a public field: the input set is what changes per frame, the parameters what a
//!   user sets once.
//! - A filter that needs a plane the input lacks returns [`FilterError::MissingFeature`]
//!   naming the plane; planes a filter does not read are ignored.

use std::fmt;

use lumo_image::Image;

use crate::common::gbuffer::{Features, Filtered};
use crate::{
    AtrousDenoiser, AutoDenoiser, BilateralDenoiser, FilterError, GuidedDenoiser, JbuDenoiser,
    TemporalFilter, TemporalParams,
};

/// Everything a [`Denoiser`] may read for one frame: the colour to filter and the planes that
/// steer it. All planes have the colour's size, except for the upsampling filters
/// ([`Shape::LowResColor`]), whose colour is the low-resolution buffer.
#[derive(Clone, Copy, Debug)]
pub struct FilterInput<'a> {
    /// The noisy colour, 3 channels; non-finite pixels are missing.
    pub color: &'a Image,
    /// The G-buffer: normal, position, depth, albedo, variance (see [`Features`]).
    pub features: Features<'a>,
    /// Motion vectors (2 channels or more), read by the temporal filter: where each pixel's
    /// surface was in the previous frame, in pixels relative to the pixel. `None`: no motion.
    pub motion: Option<&'a Image>,
    /// Object / instance id per pixel (row-major), read by the temporal filter: history of
    /// another object is rejected. Optional.
    pub ids: Option<&'a [u32]>,
}

impl<'a> FilterInput<'a> {
    /// Colour and G-buffer planes, with no motion vectors or ids.
    pub fn new(color: &'a Image, features: Features<'a>) -> Self {
        Self {
            color,
            features,
            motion: None,
            ids: None,
        }
    }
}

/// A screen-space filter behind one interface: it holds its parameters (and any working
/// memory or history), reads what it needs from a [`FilterInput`] and returns the filtered
/// colour. Object safe: callers hold a `Box<dyn Denoiser>` made by [`FilterKind::denoiser`].
///
/// `Send` so that a denoiser can be handed to a worker thread (a server's render loop).
pub trait Denoiser: Send {
    /// The filter's name in [`FILTERS`] (and on the command line).
    fn name(&self) -> &'static str;

    /// Filters one frame. Errors name the plane or parameter at fault; a needed plane that
    /// is absent is a [`FilterError::MissingFeature`].
    fn denoise(&mut self, input: &FilterInput) -> Result<Filtered, FilterError>;

    /// Forgets any history, so the next frame starts afresh (a camera cut). The spatial
    /// filters keep none: for them this does nothing.
    fn reset(&mut self) {}
}

/// The plane `plane`, or the [`FilterError::MissingFeature`] that says `filter` needs it
/// (`needs`: the plane in words, e.g. "a normal plane").
pub(crate) fn require<'a>(
    plane: Option<&'a Image>,
    filter: &'static str,
    needs: &'static str,
) -> Result<&'a Image, FilterError> {
    plane.ok_or_else(|| FilterError::MissingFeature {
        filter,
        needs: needs.into(),
    })
}

/// Which filter; [`FILTERS`] says everything else about it (name, description, input shape,
/// constructor). The discriminant is the filter's index in [`FILTERS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterKind {
    /// Edge-avoiding À-Trous ([`crate::atrous()`]).
    Atrous,
    /// Guided filter with a geometry guide ([`crate::guided()`]).
    Guided,
    /// Cross bilateral filter ([`crate::bilateral()`]).
    Bilateral,
    /// Joint bilateral upsampling ([`crate::jbu()`]).
    Jbu,
    /// Spatiotemporal variance-guided filtering ([`crate::TemporalFilter`]).
    Temporal,
    /// Guided filters at several radii blended per pixel by their estimated error
    /// ([`crate::auto()`]).
    Auto,
}

/// What a filter's colour input is, and so which callers can use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// One full-resolution image, filtered on its own (what `lumo denoise` runs).
    Image,
    /// A low-resolution colour buffer, upsampled to the features' resolution.
    LowResColor,
    /// Frames in order: the filter keeps a history, read through motion vectors.
    Sequence,
}

/// One entry of [`FILTERS`].
#[derive(Clone, Copy)]
pub struct FilterInfo {
    /// Which filter.
    pub kind: FilterKind,
    /// The name on the command line and in files: lower case, unique.
    pub name: &'static str,
    /// The name tables print (e.g. "À-Trous").
    pub title: &'static str,
    /// One line for help texts.
    pub description: &'static str,
    /// What its colour input is.
    pub shape: Shape,
    /// A denoiser with the library's defaults (docs/filters.md).
    pub new: fn() -> Box<dyn Denoiser>,
}

impl fmt::Debug for FilterInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FilterInfo")
            .field("kind", &self.kind)
            .field("name", &self.name)
            .field("shape", &self.shape)
            .finish_non_exhaustive()
    }
}

/// Every filter, in [`FilterKind`] order. To add one: a variant of [`FilterKind`] and one
/// entry here, pointing at the file that implements [`Denoiser`] for it.
pub const FILTERS: &[FilterInfo] = &[
    FilterInfo {
        kind: FilterKind::Atrous,
        name: "atrous",
        title: "À-Trous",
        description: "Edge-avoiding À-Trous wavelet filter (fast; normal + position + colour weights)",
        shape: Shape::Image,
        new: || Box::new(AtrousDenoiser::default()),
    },
    FilterInfo {
        kind: FilterKind::Guided,
        name: "guided",
        title: "guided",
        description: "Guided image filter with a normal (+ depth) guide (cost independent of radius)",
        shape: Shape::Image,
        new: || Box::new(GuidedDenoiser::default()),
    },
    FilterInfo {
        kind: FilterKind::Bilateral,
        name: "bilateral",
        title: "cross bilateral",
        description: "Brute-force cross bilateral filter (slow quality reference)",
        shape: Shape::Image,
        new: || Box::new(BilateralDenoiser::default()),
    },
    FilterInfo {
        kind: FilterKind::Jbu,
        name: "jbu",
        title: "JBU",
        description: "Joint bilateral upsampling of a low-resolution buffer by full-resolution depth and normals",
        shape: Shape::LowResColor,
        new: || Box::new(JbuDenoiser::default()),
    },
    FilterInfo {
        kind: FilterKind::Temporal,
        name: "temporal",
        title: "SVGF",
        description: "Spatiotemporal variance-guided filtering (SVGF): reprojected history + variance-guided À-Trous",
        shape: Shape::Sequence,
        new: || {
            Box::new(
                TemporalFilter::new(TemporalParams::default())
                    .expect("the default temporal parameters are valid"),
            )
        },
    },
    FilterInfo {
        kind: FilterKind::Auto,
        name: "auto",
        title: "auto",
        description: "Guided filters at radii 2-32 and the À-Trous, blended per pixel by a leave-one-out error estimate (the default)",
        shape: Shape::Image,
        new: || Box::new(AutoDenoiser::default()),
    },
];

impl FilterKind {
    /// Its entry in [`FILTERS`].
    pub fn info(self) -> &'static FilterInfo {
        &FILTERS[self as usize]
    }

    /// Its name in [`FILTERS`].
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The filter called `name` in [`FILTERS`].
    pub fn from_name(name: &str) -> Option<FilterKind> {
        FILTERS.iter().find(|f| f.name == name).map(|f| f.kind)
    }

    /// A denoiser with the library's defaults.
    pub fn denoiser(self) -> Box<dyn Denoiser> {
        (self.info().new)()
    }
}

impl fmt::Display for FilterKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
