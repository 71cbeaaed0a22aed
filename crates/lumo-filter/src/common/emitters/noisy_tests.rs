//! Lights that reflect noisy bounce light (`noisy.rs`).

use super::*;

/// splitmix64 of `i` as a number in [0, 1): independent per-pixel draws.
fn hash01(i: u64) -> f32 {
    let mut z = i.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// A dark wall (0.002) with a light of emission 0.4 in [8, 40) × [8, 32); on the light, a
/// fraction `speckles` of the pixels also caught bounce light worth 1.2 (so the light's
/// expected value is 0.4 + 1.2 · speckles), as a 1-spp frame of a dim diffuse emitter in a
/// lamp-lit room shows it.
fn speckled_light(speckles: f32) -> (Image, f32) {
    let (w, h) = (48, 40);
    let mut img = Image::new(w, h, 3, 0.002);
    for y in 8..32 {
        for x in 8..40 {
            let hit = hash01((y * w + x) as u64) < speckles;
            img.pixel_mut(x, y).fill(if hit { 1.6 } else { 0.4 });
        }
    }
    (img, 0.4 + 1.2 * speckles)
}

/// The mean squared error of the light's interior (less its one-pixel edge, which keeps its
/// pass-through) against its expected value.
fn light_error(img: &Image, truth: f32) -> f32 {
    let mut sum = 0.0;
    for y in 9..31 {
        for x in 9..39 {
            sum += (img.pixel(x, y)[0] - truth).powi(2);
        }
    }
    sum / (22.0 * 30.0)
}

/// The light found by the search on a speckled light: its interior ends up near the light's
/// mean instead of keeping the speckles (before: every pixel passed through, the error was the
/// speckles' whole variance); its edge keeps its own values.
#[test]
fn a_light_with_bounce_light_speckles_is_averaged_over_itself() {
    let (img, truth) = speckled_light(0.15);
    let found = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
    let lit = (0..img.width * img.height)
        .filter(|&i| found.light[i])
        .count();
    assert!(lit > 24 * 32 / 2, "the search found {lit} light pixels");
    // An identity "filter": what comes back on the light is the smoothing's alone.
    let out = found
        .filter(&img, None, |c| {
            Ok::<_, FilterError>(crate::Filtered {
                image: c.clone(),
                missing: 0,
            })
        })
        .unwrap();
    let before = light_error(&img, truth);
    let after = light_error(&out.image, truth);
    assert!(
        after < 0.25 * before,
        "light error {after} after smoothing, {before} passed through"
    );
    // The mean stays: the bounce light's energy is spread over the light, not lost.
    let mean = |i: &Image| {
        (8..32)
            .flat_map(|y| (8..40).map(move |x| (x, y)))
            .map(|(x, y)| i.pixel(x, y)[0])
            .sum::<f32>()
            / (24.0 * 32.0)
    };
    assert!(
        (mean(&out.image) - mean(&img)).abs() < 0.03 * mean(&img),
        "light mean {} against {}",
        mean(&out.image),
        mean(&img)
    );
    for (x, y) in (8..40).flat_map(|x| [(x, 8), (x, 31)]) {
        assert_eq!(
            out.image.pixel(x, y),
            img.pixel(x, y),
            "edge pixel ({x}, {y})"
        );
    }
}

/// A noise-free light with an anti-aliased edge (columns half and a quarter covered, as
/// several samples per pixel give them) passes through bit for bit, as before: its edge is
/// not noise (a first version averaged it and made the Cornell box at 4 spp 12× worse).
#[test]
fn a_noise_free_light_passes_through_bit_for_bit() {
    let (mut img, _) = speckled_light(0.0);
    for y in 8..32 {
        img.pixel_mut(8, y).fill(0.2);
        img.pixel_mut(39, y).fill(0.1);
        img.pixel_mut(7, y).fill(0.05);
    }
    let found = detect_emitters(&img, &Features::default(), &EmitterParams::default()).unwrap();
    assert!(found.light.iter().any(|&l| l));
    let out = found
        .filter(&img, None, |c| {
            let mut image = c.clone();
            // A filter that changes everything it sees: the light must not see it. (Its level,
            // under the surface's 0.002, keeps the rim inside the bounds `rim.rs` clamps it to.)
            for v in &mut image.data {
                *v = 0.001;
            }
            Ok::<_, FilterError>(crate::Filtered { image, missing: 0 })
        })
        .unwrap();
    for i in 0..img.width * img.height {
        if found.light[i] || found.rim[i] {
            assert_eq!(
                &out.image.data[i * 3..i * 3 + 3],
                &img.data[i * 3..i * 3 + 3],
                "pixel {i}"
            );
        }
    }
}
