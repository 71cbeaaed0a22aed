//! Finding lights (and other noise-free, far too bright pixels) in a frame that comes without
//! an emission plane, so that they can be passed through instead of smeared over their
//! neighbours.
//!
//! Why not a threshold on brightness alone: a sunlit floor patch, a 1-spp firefly and an area
//! light can all be 50× brighter than the rest of the frame. What sets a light apart is that
//! emitted radiance seen directly is noise-free: neighbouring pixels inside a light carry the
//! same value to the last few bits at any sample count, while a bright pixel of a noisy lit
//! surface has no neighbour within a few per cent of it. So the detector asks two things of a
//! seed pixel — far brighter than its surroundings can explain, and flat with its neighbours —
//! and then grows the region from the seeds through pixels that are bright or equally flat
//! (a light larger than the window is bright only at its rim, flat inside). A region found
//! that way must then stand far above the arithmetic mean of what surrounds it: clusters of
//! equal 1-spp samples of one bright area's bounce light pass the first tests but not that one.

mod level;
mod noisy;
mod rim;
mod search;

#[cfg(test)]
mod noisy_tests;
#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

use lumo_image::Image;

use crate::common::gbuffer::{check_features, Features};
use crate::FilterError;

/// Settings of [`detect_emitters`]; the defaults were chosen on the tuning set
/// (scenes/tuning, docs/filters.md), never on the held-out scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterParams {
    /// A seed is at least this many times brighter (demodulated luminance) than the geometric
    /// mean of its window.
    pub brightness: f32,
    /// Radius of the window of that geometric mean, in pixels.
    pub radius: usize,
    /// Two pixels are "flat" when their demodulated luminances differ by at most this
    /// fraction of the larger.
    pub flatness: f32,
    /// A seed needs at least this many flat, bright neighbours among its 8.
    pub flat_neighbours: usize,
    /// Rings of pixels around the region, passed through with it ([`EmitterMask::rim`]): the
    /// anti-aliased rim of a light, partly covered, is neither flat nor always bright enough
    /// to be found, and would spread.
    pub dilate: usize,
    /// A region is kept only if its median demodulated luminance is at least this many times
    /// the arithmetic mean of its surroundings (0: every region is kept); see
    /// `drop_explained_regions`.
    pub region_contrast: f32,
}

impl Default for EmitterParams {
    fn default() -> Self {
        Self {
            brightness: 8.0,
            radius: 8,
            flatness: 0.02,
            flat_neighbours: 3,
            dilate: 1,
            region_contrast: 4.0,
        }
    }
}

/// What [`detect_emitters`] found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EmitterMask {
    /// Pixels of lights: pass them through unfiltered, as an emission plane would mark them.
    pub light: Vec<bool>,
    /// The rings around them ([`EmitterParams::dilate`]): the anti-aliased rim, partly light.
    pub rim: Vec<bool>,
}

impl EmitterMask {
    /// Runs `filter` with the lights and their rims passed through ([`crate::with_passthrough`]).
    ///
    /// Why the rim is passed through rather than hidden and filled ([`crate::with_hidden`]):
    /// on the tuning set a filled rim loses the light's share of its partly covered pixels
    /// (tune-room, guided: relMSE 3.5e-3 → 4.2e-3 at 1 spp, 2.6e-3 → 3.4e-3 at 4 spp), which
    /// costs more than the rim's unfiltered noise.
    ///
    /// After the filter, a light whose interior is not flat — a dim emitter that also
    /// reflects noisy bounce light — has its interior averaged over itself, demodulated by
    /// `albedo` when given (`noisy.rs`, docs/filters.md); a noise-free light passes through
    /// bit for bit. Then each rim pixel is clamped between half the filtered surface beside
    /// it and the light's level (`rim.rs`).
    pub fn filter<F, E>(
        &self,
        color: &Image,
        albedo: Option<&Image>,
        filter: F,
    ) -> Result<crate::Filtered, E>
    where
        F: FnOnce(&Image) -> Result<crate::Filtered, E>,
    {
        let pass: Vec<bool> = self
            .light
            .iter()
            .zip(&self.rim)
            .map(|(&l, &r)| l || r)
            .collect();
        let mut out = crate::common::passthrough::with_passthrough(color, &pass, filter)?;
        // A light that reflects noisy bounce light is averaged over itself (`noisy.rs`).
        let flatness = EmitterParams::default().flatness;
        noisy::smooth_noisy_lights(
            color,
            albedo,
            &self.light,
            &self.rim,
            flatness,
            &mut out.image,
        );
        // The rim's noise is bounded by the light and the filtered surface beside it
        // (`rim.rs`): no black pixels or speckles along a light's edge.
        rim::clamp_rim(color, &self.light, &self.rim, &mut out.image);
        Ok(out)
    }

    /// The mask an emission plane gives: its non-zero pixels (any channel; NaN counts) are
    /// lights, and `dilate` rings around the non-background ones, over non-background pixels,
    /// are their rim, passed through with them as [`detect_emitters`]' rim is.
    ///
    /// Why the rim: a renderer's emission plane (lumo's is the pixel-centre ray's) marks a
    /// pixel on a light's anti-aliased edge only when its centre sees the light, yet its
    /// colour holds the light's share either way; filtered, that share spread a glow around the
    /// light and the light pulled its neighbours' error estimates (a dark ring), so the plane
    /// made `lumo denoise` worse than its own light search (cornell 512², 4 spp, `auto`, against
    /// 1024 spp: relMSE 4.4e-3 with the plane, 1.7e-3 without; 1.7e-3 with this rim). The sky's edge needs no rim: background pixels
    /// are kept apart from geometry by every filter already.
    pub fn from_emission(
        emission: &Image,
        features: &Features,
        dilate: usize,
    ) -> Result<EmitterMask, FilterError> {
        let (w, h) = (emission.width, emission.height);
        check_features(features, w, h)?;
        let n = w * h;
        let c = emission.channels;
        let light: Vec<bool> = (0..n)
            .map(|i| emission.data[i * c..(i + 1) * c].iter().any(|&v| v != 0.0))
            .collect();
        let background: Vec<bool> = (0..n)
            .map(|i| crate::common::gbuffer::is_background(features, i))
            .collect();
        let core: Vec<bool> = (0..n).map(|i| light[i] && !background[i]).collect();
        // (A light pixel out of `core` is background, never reached.)
        let rim = search::rings(&core, |i| !background[i], w, h, dilate);
        Ok(EmitterMask { light, rim })
    }
}

/// The darkest albedo luminance a pixel is demodulated by: black surfaces would otherwise
/// divide by 0.
const ALBEDO_FLOOR: f32 = 0.05;

/// Pixels of `color` that look like directly visible emitters ([`EmitterMask::light`]) and
/// the rim around them ([`EmitterMask::rim`]); [`EmitterMask::filter`] passes both through,
/// as an emission plane would mark them.
///
/// Reads the albedo (to tell texture from light; without it, luminance is used as is) and the
/// depth / position planes of `features` (background pixels are never marked: the filters
/// keep them apart from geometry already, and they do not count towards any window's level).
/// Non-finite colour pixels are never marked (the filters treat them as missing).
pub fn detect_emitters(
    color: &Image,
    features: &Features,
    params: &EmitterParams,
) -> Result<EmitterMask, FilterError> {
    crate::common::gbuffer::check_color("color", color)?;
    let (w, h) = (color.width, color.height);
    check_features(features, w, h)?;
    // (Written so that NaN parameters fail too.)
    let valid = params.brightness > 1.0
        && params.flatness >= 0.0
        && params.flat_neighbours <= 8
        && params.region_contrast >= 0.0
        && params.region_contrast.is_finite();
    if !valid {
        return Err(crate::common::error::param(
            "emitter detection",
            format!(
                "{params:?} (brightness must be > 1, flatness ≥ 0, flat_neighbours ≤ 8, \
                 region_contrast finite and ≥ 0)"
            ),
        ));
    }
    Ok(search::search(color, features, params))
}
