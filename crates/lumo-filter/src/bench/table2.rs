//! The filter configurations of the papers' Table 2 (filter time per resolution × settings),
//! run on a [`SyntheticFrame`] through the [`Denoiser`] interface: one list for
//! `cargo bench -p lumo-filter` and `lumo bench speed`, so both time exactly the same work.

use crate::{
    AtrousDenoiser, AtrousParams, BilateralDenoiser, BilateralParams, Denoiser, Features,
    FilterError, FilterInput, FilterKind, GuideKind, GuidedDenoiser, GuidedParams, SyntheticFrame,
};

/// Names of the À-Trous weight counts 0–3.
pub const ATROUS_WEIGHT_NAMES: [&str; 4] =
    ["none", "colour", "colour+normal", "colour+normal+position"];

/// One Table 2 configuration: a denoiser with fixed parameters and the planes of the frame
/// it is given.
pub struct Table2Config {
    /// Which filter (its name and title come from [`crate::FILTERS`]).
    pub filter: FilterKind,
    /// The settings in words, e.g. "5 it, colour+normal" or "4 dims, r=24, fast s=4".
    pub label: String,
    /// Whether `lumo bench speed` lists it: it leaves out the unweighted À-Trous rows (a
    /// plain B3 convolution, in the papers' table for comparison only).
    pub speed_table: bool,
    /// The denoiser, reused between runs: warm, as a renderer filtering frame after frame
    /// (the À-Trous keeps its working memory).
    denoiser: Box<dyn Denoiser>,
    /// The planes of the frame it reads.
    planes: fn(&SyntheticFrame) -> Features<'_>,
}

impl Table2Config {
    /// Filters the frame's noisy image once (the result is discarded).
    pub fn run(&mut self, frame: &SyntheticFrame) -> Result<(), FilterError> {
        let input = FilterInput::new(&frame.noisy, (self.planes)(frame));
        std::hint::black_box(self.denoiser.denoise(&input)?);
        Ok(())
    }
}

/// Normal, position and depth: the À-Trous edge-stopping planes.
fn geometry(fr: &SyntheticFrame) -> Features<'_> {
    Features {
        normal: Some(&fr.normal),
        position: Some(&fr.position),
        depth: Some(&fr.depth),
        ..Features::default()
    }
}

/// The geometry planes and the variance: lumo's default À-Trous.
fn geometry_variance(fr: &SyntheticFrame) -> Features<'_> {
    Features {
        variance: Some(&fr.variance),
        ..geometry(fr)
    }
}

/// Normal and depth: the guide and the bilateral range terms.
fn normal_depth(fr: &SyntheticFrame) -> Features<'_> {
    Features {
        normal: Some(&fr.normal),
        depth: Some(&fr.depth),
        ..Features::default()
    }
}

/// Every configuration, in table order: À-Trous at 1, 5 and 10 iterations with 0–3 weights,
/// then with lumo's defaults; the guided filter with 1, 3 and 4 dimensions, exact and fast
/// (s = 4); the cross bilateral filter at r = 16, 24, 32.
pub fn table2_configs() -> Vec<Table2Config> {
    let mut v = Vec::new();
    for iterations in [1usize, 5, 10] {
        for weights in 0..=3 {
            let p = AtrousParams {
                iterations,
                sigma_color: (weights >= 1).then_some(4.0),
                sigma_luminance: None,
                sigma_normal: (weights >= 2).then_some(0.3),
                sigma_position: (weights >= 3).then_some(0.1),
                ..AtrousParams::default()
            };
            v.push(Table2Config {
                filter: FilterKind::Atrous,
                label: format!("{iterations} it, {}", ATROUS_WEIGHT_NAMES[weights]),
                speed_table: weights > 0,
                denoiser: Box::new(AtrousDenoiser::new(p)),
                planes: geometry,
            });
        }
    }
    v.push(Table2Config {
        filter: FilterKind::Atrous,
        label: "5 it, variance-guided + normal + position (lumo's default)".to_string(),
        speed_table: true,
        denoiser: Box::new(AtrousDenoiser::new(AtrousParams::default())),
        planes: geometry_variance,
    });
    for guide in [GuideKind::Grey, GuideKind::Normal, GuideKind::NormalDepth] {
        for fast in [1usize, 4] {
            let mode = if fast == 1 {
                "exact".to_string()
            } else {
                format!("fast s={fast}")
            };
            v.push(Table2Config {
                filter: FilterKind::Guided,
                label: format!("{} dims, r=24, {mode}", guide.dims()),
                speed_table: true,
                // The time includes building the guide, as in the papers.
                denoiser: Box::new(GuidedDenoiser {
                    guide,
                    eps_normal: 0.003,
                    eps_depth: 0.003,
                    params: GuidedParams {
                        radius: 24,
                        fast_subsample: fast,
                    },
                    ..GuidedDenoiser::default()
                }),
                planes: normal_depth,
            });
        }
    }
    for radius in [16usize, 24, 32] {
        let params = BilateralParams {
            radius,
            sigma_spatial: radius as f32 / 2.0,
            ..BilateralParams::default()
        };
        v.push(Table2Config {
            filter: FilterKind::Bilateral,
            label: format!("r={radius}, normal + depth"),
            speed_table: true,
            denoiser: Box::new(BilateralDenoiser {
                params,
                demodulate: false,
            }),
            planes: normal_depth,
        });
    }
    v
}

/// How many timed runs a configuration gets at most when one run takes `first_ms`: slow cells
/// are timed fewer times (3 above 4 s, 1 above 20 s) so a whole table stays bounded.
pub fn timed_runs_cap(first_ms: f64) -> usize {
    if first_ms > 20_000.0 {
        1
    } else if first_ms > 4_000.0 {
        3
    } else {
        usize::MAX
    }
}
