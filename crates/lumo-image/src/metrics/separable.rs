//! Separable 2-D filtering of single-channel planes, used by FLIP.

use rayon::prelude::*;

/// Correlates a `w`×`h` plane with the separable kernel `kx` (along rows) ⊗ `ky` (down
/// columns), both of odd length centred on the middle tap. Samples outside the plane repeat
/// the nearest edge pixel: with this rule FLIP's corner and edge pixels match the
/// `flip-evaluator` package (tests/integration/flip_reference.rs).
pub(crate) fn filter_clamped(
    plane: &[f32],
    w: usize,
    h: usize,
    kx: &[f32],
    ky: &[f32],
) -> Vec<f32> {
    debug_assert_eq!(plane.len(), w * h);
    debug_assert!(kx.len() % 2 == 1 && ky.len() % 2 == 1);
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let rx = (kx.len() / 2) as isize;
    let ry = (ky.len() / 2) as isize;
    let clamp = |i: isize, n: usize| i.clamp(0, n as isize - 1) as usize;

    let mut tmp = vec![0.0f32; w * h];
    tmp.par_chunks_mut(w)
        .zip(plane.par_chunks(w))
        .for_each(|(out, row)| {
            for (x, o) in out.iter_mut().enumerate() {
                let mut acc = 0.0f32;
                for (k, weight) in kx.iter().enumerate() {
                    acc += weight * row[clamp(x as isize + k as isize - rx, w)];
                }
                *o = acc;
            }
        });

    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, out_row)| {
        for (k, weight) in ky.iter().enumerate() {
            let src = clamp(y as isize + k as isize - ry, h);
            let src_row = &tmp[src * w..(src + 1) * w];
            for (o, s) in out_row.iter_mut().zip(src_row) {
                *o += weight * s;
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_2d_correlation_with_clamped_borders() {
        let (w, h) = (6, 4);
        let plane: Vec<f32> = (0..w * h).map(|i| ((i * 7) % 11) as f32).collect();
        let kx = [0.25, -0.5, 1.0];
        let ky = [0.1, 0.3, 0.2, 0.3, 0.1];
        let got = filter_clamped(&plane, w, h, &kx, &ky);
        for y in 0..h {
            for x in 0..w {
                let mut expected = 0.0f32;
                for (j, wy) in ky.iter().enumerate() {
                    for (i, wx) in kx.iter().enumerate() {
                        let sx = (x as isize + i as isize - 1).clamp(0, w as isize - 1) as usize;
                        let sy = (y as isize + j as isize - 2).clamp(0, h as isize - 1) as usize;
                        expected += wx * wy * plane[sy * w + sx];
                    }
                }
                assert!((got[y * w + x] - expected).abs() < 1e-5, "({x},{y})");
            }
        }
    }
}
