//! Typed errors of the filters: every one names the plane or parameter at fault.

/// Everything a filter can reject. Filters never panic on user data; they return one of these.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// A feature plane does not have the colour image's size.
    #[error("{name} is {width}x{height} but {reference} is {ref_width}x{ref_height}")]
    SizeMismatch {
        /// The plane that does not fit (e.g. "normal").
        name: &'static str,
        /// Its width.
        width: usize,
        /// Its height.
        height: usize,
        /// The plane it was compared with (usually "color").
        reference: &'static str,
        /// Width of the reference.
        ref_width: usize,
        /// Height of the reference.
        ref_height: usize,
    },
    /// A depth plane with several channels that differ: depth is one value per pixel, stored
    /// as 1 channel or 3 equal ones; anything else is most likely another plane given as depth.
    #[error(
        "depth has {channels} channels that differ (at pixel ({x}, {y}): {values:?}); depth is \
         1 channel or 3 equal ones: is this the normal or the position plane?"
    )]
    DepthChannelsDiffer {
        /// The plane's channel count.
        channels: usize,
        /// Column of the first pixel whose channels differ.
        x: usize,
        /// Its row.
        y: usize,
        /// Its first three channels.
        values: [f32; 3],
    },
    /// A plane has a channel count the filter cannot interpret.
    #[error("{name} has {got} channels, expected {expected}")]
    Channels {
        /// The plane at fault.
        name: &'static str,
        /// Its channel count.
        got: usize,
        /// What would be accepted, in words.
        expected: &'static str,
    },
    /// A parameter is outside its valid range.
    #[error("invalid {name}: {reason}")]
    Parameter {
        /// The parameter at fault.
        name: &'static str,
        /// Why it is rejected.
        reason: String,
    },
    /// A filter was asked for a mode that needs a feature plane that was not given.
    #[error("{filter} needs {needs}")]
    MissingFeature {
        /// The filter (or mode) that was asked for.
        filter: &'static str,
        /// The planes it needs, in words.
        needs: String,
    },
    /// The image is empty (zero width or height).
    #[error("{name} is empty ({width}x{height})")]
    Empty {
        /// The plane at fault.
        name: &'static str,
        /// Its width.
        width: usize,
        /// Its height.
        height: usize,
    },
}

/// Builds a [`FilterError::Parameter`].
pub(crate) fn param(name: &'static str, reason: impl Into<String>) -> FilterError {
    FilterError::Parameter {
        name,
        reason: reason.into(),
    }
}
