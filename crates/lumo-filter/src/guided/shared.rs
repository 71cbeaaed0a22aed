//! The guided filter's input prepared once for several runs on the same colour and guide
//! planes: `auto` runs nine candidates that differ only in radius, ε and sub-sampling.
//!
//! Why: each run used to check and copy the colour again (two image-sized buffers and a pass
//! over the frame) and, on the coarse grid, average the same guide and colour into the same
//! blocks again. Sharing them changes no value: every run reads exactly the buffers it made
//! for itself before.

use lumo_image::Image;

use super::stream::Problem;
use super::{
    apply_upsampled, apply_upsampled_weighted, check_planes, check_run, coarse_grid, downsample,
    exact, fill_missing, guided_input, Guide, GuidedParams,
};
use crate::common::gbuffer::Filtered;
use crate::FilterError;

/// A colour image and a guide checked and prepared for guided-filter runs ([`Self::filter`],
/// [`Self::self_weighted`]) with any ε, radius and sub-sampling.
pub(crate) struct SharedInput<'a> {
    color: &'a Image,
    guide: &'a Guide,
    /// The colour as the filter reads it, missing pixels still 0: they are filled per run,
    /// from the run's window.
    p: Vec<f32>,
    /// 1 where the colour pixel is valid, 0 where it is missing.
    valid: Vec<f32>,
    /// Number of missing pixels.
    missing: usize,
    /// Block means for the fast filter, per sub-sampling factor, made on first use.
    blocks: Vec<Blocks>,
    /// With missing pixels: the colour filled for the last run's radius (its buffer reused
    /// from run to run: a fresh one costs its page faults again), and the fast filter's block
    /// means of it for that radius and a sub-sampling factor.
    filled: Filled,
    /// The fast filter's coarse coefficients, a buffer reused by every run (six of `auto`'s
    /// candidates: fresh, it was 7.5 values per pixel of page faults each).
    coarse_ab: Vec<f32>,
}

/// [`SharedInput::filled`]: `p` is filled for `radius` (None: not yet), and `blocks` holds the
/// block means of that `p` for sub-sampling factor `blocks.0`.
#[derive(Default)]
struct Filled {
    radius: Option<usize>,
    p: Vec<f32>,
    blocks: Option<(usize, Vec<f32>)>,
}

/// The guide's block means for sub-sampling factor `s`, and the colour's when no pixel is
/// missing (otherwise they depend on the run's radius through the filling).
struct Blocks {
    s: usize,
    guide: Vec<f32>,
    p: Option<Vec<f32>>,
}

impl<'a> SharedInput<'a> {
    /// Checks `color` (3 channels) against `guide` (same size, 1..=8 dimensions; its ε is not
    /// used here: each run gives its own) and prepares the colour.
    pub(crate) fn new(color: &'a Image, guide: &'a Guide) -> Result<Self, FilterError> {
        check_planes(color, guide)?;
        let (p, valid, missing) = guided_input(color);
        Ok(Self {
            color,
            guide,
            p,
            valid,
            missing,
            blocks: Vec::new(),
            filled: Filled::default(),
            coarse_ab: Vec::new(),
        })
    }

    /// [`super::guided`] with ε `eps` (one per guide dimension).
    pub(crate) fn filter(
        &mut self,
        eps: &[f32],
        params: &GuidedParams,
    ) -> Result<Filtered, FilterError> {
        Ok(self.run::<false>(eps, params)?.0)
    }

    /// [`super::guided_self_weighted`] with ε `eps`: the filtered image and each pixel's
    /// self-weight.
    pub(crate) fn self_weighted(
        &mut self,
        eps: &[f32],
        params: &GuidedParams,
    ) -> Result<(Filtered, Vec<f32>), FilterError> {
        self.run::<true>(eps, params)
    }

    /// One run; the self-weights are empty unless `SW`.
    fn run<const SW: bool>(
        &mut self,
        eps: &[f32],
        params: &GuidedParams,
    ) -> Result<(Filtered, Vec<f32>), FilterError> {
        let (w, h, d) = (self.color.width, self.color.height, self.guide.dims);
        check_run(d, eps, params)?;
        let (radius, s) = (params.radius, params.fast_subsample);
        let blocks = (s > 1).then(|| self.blocks_for(s));
        if self.missing > 0 {
            self.fill_for(radius, s);
        }
        let p = if self.missing > 0 {
            &self.filled.p
        } else {
            &self.p
        };
        let (image, weights) = if let Some(i) = blocks {
            let b = &self.blocks[i];
            // With missing pixels the input's block means depend on this run's filling.
            let pl = match &b.p {
                Some(pl) => pl.as_slice(),
                None => &self.filled.blocks.as_ref().expect("made by fill_for").1,
            };
            let size = (w.div_ceil(s), h.div_ceil(s));
            let ab = &mut self.coarse_ab;
            let coarse = coarse_grid::<SW>((&b.guide, pl), size, (eps, radius, s), ab);
            if SW {
                apply_upsampled_weighted(&self.guide.data, w, h, d, &coarse)
            } else {
                let image = apply_upsampled(&self.guide.data, w, h, d, &coarse);
                (image, Vec::new())
            }
        } else {
            let pb = Problem {
                guide: &self.guide.data,
                p,
                eps,
                w,
                h,
                r: radius,
            };
            exact::<SW>(&pb, d)
        };
        let missing = self.missing;
        Ok((Filtered { image, missing }, weights))
    }

    /// Fills the missing pixels of the colour for `radius` into `filled.p` and, when `s` > 1,
    /// makes its block means, unless the last run already did (the same bits as a fresh fill:
    /// `auto`'s main and flat candidates of one radius follow each other).
    fn fill_for(&mut self, radius: usize, s: usize) {
        let (w, h) = (self.color.width, self.color.height);
        let f = &mut self.filled;
        if f.radius != Some(radius) {
            f.p.clear();
            f.p.extend_from_slice(&self.p);
            fill_missing(&mut f.p, &self.valid, w, h, radius);
            f.radius = Some(radius);
            f.blocks = None;
        }
        if s > 1 && f.blocks.as_ref().is_none_or(|b| b.0 != s) {
            f.blocks = Some((s, downsample(&f.p, w, h, 3, s)));
        }
    }

    /// The index in `blocks` of sub-sampling factor `s`'s block means, made if new.
    fn blocks_for(&mut self, s: usize) -> usize {
        if let Some(i) = self.blocks.iter().position(|b| b.s == s) {
            return i;
        }
        let (w, h, d) = (self.color.width, self.color.height, self.guide.dims);
        self.blocks.push(Blocks {
            s,
            guide: downsample(&self.guide.data, w, h, d, s),
            p: (self.missing == 0).then(|| downsample(&self.p, w, h, 3, s)),
        });
        self.blocks.len() - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guided::self_weight::two_region_guide;

    /// Runs on one shared input give the bits that each run gives on a fresh one, whatever ran
    /// before it, and with missing pixels the bits of the colour filled from the run's own
    /// window: exact and fast filters, two sub-sampling factors, two ε.
    #[test]
    fn shared_runs_equal_fresh_runs() {
        let (w, h) = (37, 29);
        let guide = Guide::from_image(&two_region_guide(w, h, 17), vec![0.001, 0.002]).unwrap();
        let mut color = Image::new(w, h, 3, 0.0);
        for (i, v) in color.data.iter_mut().enumerate() {
            *v = 0.5 + 0.4 * ((i as f32 * 0.618) * 12.9898).sin();
        }
        let flat = vec![0.01; guide.dims];
        let runs = [
            (3, 1, &guide.eps),
            (6, 2, &flat),
            (2, 3, &guide.eps),
            (9, 2, &guide.eps),
        ];
        for with_missing in [false, true] {
            let mut color = color.clone();
            if with_missing {
                for i in [5, 6, 100, 101, 102, 400, 1000] {
                    color.data[i * 3 + 1] = f32::NAN;
                }
            }
            let mut shared = SharedInput::new(&color, &guide).unwrap();
            for &(radius, s, eps) in &runs {
                let params = GuidedParams {
                    radius,
                    fast_subsample: s,
                };
                let (a, wa) = shared.self_weighted(eps, &params).unwrap();
                let fresh = || SharedInput::new(&color, &guide).unwrap();
                let (b, wb) = fresh().self_weighted(eps, &params).unwrap();
                let plain = shared.filter(eps, &params).unwrap();
                let plain_fresh = fresh().filter(eps, &params).unwrap();
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let at = format!("radius {radius}, s {s}, missing {with_missing}");
                assert_eq!(bits(&a.image.data), bits(&b.image.data), "{at}");
                assert_eq!(bits(&wa), bits(&wb), "{at}: self-weights");
                assert_eq!(wa.len(), w * h, "{at}");
                assert_eq!(
                    bits(&plain.image.data),
                    bits(&plain_fresh.image.data),
                    "{at}"
                );
                assert_eq!(a.missing, if with_missing { 7 } else { 0 }, "{at}");
                // Missing pixels are filled from the run's own window: the same bits as a
                // colour that came with them filled.
                let (mut p, valid, _) = guided_input(&color);
                fill_missing(&mut p, &valid, w, h, radius);
                let filled = Image::from_vec(w, h, 3, p);
                let mut complete = SharedInput::new(&filled, &guide).unwrap();
                let (c, wc) = complete.self_weighted(eps, &params).unwrap();
                assert_eq!(bits(&a.image.data), bits(&c.image.data), "{at}: filled");
                assert_eq!(bits(&wa), bits(&wc), "{at}: filled, self-weights");
            }
        }
    }
}
