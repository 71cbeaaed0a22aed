//! lumo's `cornell` against Mitsuba 3's `cornell_box()`.
//!
//! Reference: Mitsuba 3.9.1, variant llvm_ad_rgb, `path` integrator (rr_depth 5), box
//! reconstruction filter, 512×512, 1024 spp, independent sampler; the full record (quadrant and
//! region means, timings, machine) is tests/data/mitsuba_cornell_reference.json, produced by
//! scripts/compare_mitsuba.py's reference mode. The image mean is resolution-independent in
//! expectation, so a smaller lumo render is compared against it.

use lumo_render::{render, PathSettings, RenderScene, RenderSettings};

/// (max_depth, Mitsuba's mean RGB over the image).
const MITSUBA_MEANS: [(u32, [f64; 3]); 3] = [
    (2, [0.163_905_1, 0.114_186_5, 0.052_060_4]),
    (3, [0.197_130_1, 0.129_139_3, 0.057_029_9]),
    (5, [0.227_174_8, 0.138_721_2, 0.059_553_3]),
];

#[test]
fn cornell_mean_rgb_matches_mitsuba_within_one_percent() {
    let scene = lumo_scene::builtin_scene("cornell").unwrap();
    let rs = RenderScene::new(scene).unwrap();
    for (max_depth, reference) in MITSUBA_MEANS {
        let settings = RenderSettings {
            width: 128,
            height: 128,
            spp: 64,
            seed: 0,
            path: PathSettings {
                max_depth,
                ..Default::default()
            },
        };
        let (frame, _) = render(&rs, &settings, &|_| {});
        let got = frame.color.channel_means();
        for c in 0..3 {
            let rel = (got[c] - reference[c]) / reference[c];
            eprintln!(
                "max_depth {max_depth} channel {c}: lumo {:.5} Mitsuba {:.5} ({:+.2}%)",
                got[c],
                reference[c],
                rel * 100.0
            );
            assert!(
                rel.abs() < 0.01,
                "max_depth {max_depth}, channel {c}: lumo {:.5} vs Mitsuba {:.5} ({:+.2}%)",
                got[c],
                reference[c],
                rel * 100.0
            );
        }
    }
}
