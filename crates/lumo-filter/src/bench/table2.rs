//! The filter configurations of the papers' Table 2 (filter time per resolution × settings),
//! run on a [`SyntheticFrame`]: one list for `cargo bench -p lumo-filter` and `lumo bench
//! speed`, so both time exactly the same work.

use std::sync::Mutex;

use crate::{
    bilateral, build_guide, guided, AtrousFilter, AtrousParams, BilateralParams, DepthNorm,
    Features, FilterError, GuideKind, GuidedParams, SyntheticFrame,
};

/// What a configuration filters with; callers format their own labels from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Table2Kind {
    /// À-Trous with a fixed colour σ and `weights` edge-stopping weights (0 none, 1 colour,
    /// 2 + normal, 3 + position).
    Atrous {
        /// À-Trous levels.
        iterations: usize,
        /// Edge-stopping weights, 0–3.
        weights: usize,
    },
    /// À-Trous with lumo's defaults: variance-guided colour weight, normal and position.
    AtrousDefault,
    /// Guided filter, r = 24, ε = 0.003, guide of `dims` dimensions, coefficients sub-sampled by
    /// `fast` (1 = exact); the time includes building the guide.
    Guided {
        /// Guide dimensions: 1, 3 or 4.
        dims: usize,
        /// Fast guided filter sub-sampling.
        fast: usize,
    },
    /// Cross bilateral filter with normal and depth range terms, σ_s = r/2.
    Bilateral {
        /// Window radius.
        radius: usize,
    },
}

/// Names of the À-Trous weight counts 0–3.
pub const ATROUS_WEIGHT_NAMES: [&str; 4] =
    ["none", "colour", "colour+normal", "colour+normal+position"];

/// Runs one configuration on a frame (the result is discarded).
pub type Table2Run = Box<dyn Fn(&SyntheticFrame) -> Result<(), FilterError> + Sync>;

/// One Table 2 configuration.
pub struct Table2Config {
    /// What it runs.
    pub kind: Table2Kind,
    /// Runs it.
    pub run: Table2Run,
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
            // One filter per configuration, reused between runs: warm, as a renderer
            // filtering frame after frame (and as the peers are timed).
            let filter = Mutex::new(AtrousFilter::new());
            v.push(Table2Config {
                kind: Table2Kind::Atrous {
                    iterations,
                    weights,
                },
                run: Box::new(move |fr| {
                    let f = Features {
                        normal: Some(&fr.normal),
                        position: Some(&fr.position),
                        depth: Some(&fr.depth),
                        ..Features::default()
                    };
                    let mut filter = filter.lock().unwrap_or_else(|e| e.into_inner());
                    std::hint::black_box(filter.filter(&fr.noisy, &f, &p)?);
                    Ok(())
                }),
            });
        }
    }
    let filter = Mutex::new(AtrousFilter::new());
    v.push(Table2Config {
        kind: Table2Kind::AtrousDefault,
        run: Box::new(move |fr| {
            let f = Features {
                normal: Some(&fr.normal),
                position: Some(&fr.position),
                depth: Some(&fr.depth),
                variance: Some(&fr.variance),
                ..Features::default()
            };
            let mut filter = filter.lock().unwrap_or_else(|e| e.into_inner());
            std::hint::black_box(filter.filter(&fr.noisy, &f, &AtrousParams::default())?);
            Ok(())
        }),
    });
    for (kind, dims) in [
        (GuideKind::Grey, 1),
        (GuideKind::Normal, 3),
        (GuideKind::NormalDepth, 4),
    ] {
        for fast in [1usize, 4] {
            v.push(Table2Config {
                kind: Table2Kind::Guided { dims, fast },
                run: Box::new(move |fr| {
                    let f = Features {
                        normal: Some(&fr.normal),
                        depth: Some(&fr.depth),
                        ..Features::default()
                    };
                    let g = build_guide(kind, &f, DepthNorm::Range, 0.003, 0.003)?;
                    let p = GuidedParams {
                        radius: 24,
                        fast_subsample: fast,
                    };
                    std::hint::black_box(guided(&fr.noisy, &g, &p)?);
                    Ok(())
                }),
            });
        }
    }
    for radius in [16usize, 24, 32] {
        let p = BilateralParams {
            radius,
            sigma_spatial: radius as f32 / 2.0,
            ..BilateralParams::default()
        };
        v.push(Table2Config {
            kind: Table2Kind::Bilateral { radius },
            run: Box::new(move |fr| {
                let f = Features {
                    normal: Some(&fr.normal),
                    depth: Some(&fr.depth),
                    ..Features::default()
                };
                std::hint::black_box(bilateral(&fr.noisy, &f, &p)?);
                Ok(())
            }),
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
