//! Small symmetric positive definite solves (the guided filter's d×d window systems).

/// Systems solved together, one per lane.
pub(crate) const L: usize = 16;

/// Solves `A x_c = b_c` for the 3 right-hand sides `b` with `A` symmetric positive definite
/// (D×D), given A's Cholesky factor from [`factor_lanes`], for L independent systems at once,
/// stored lane-last (`a[i][j][lane]`) so that every step is a loop over lanes that
/// vectorises. One factorisation serves all three colour channels (and, for `auto`, the
/// window's inverse).
#[inline(always)]
pub(super) fn solve_factored<const D: usize>(
    lo: &[[[f32; L]; D]; D],
    inv_diag: &[[f32; L]; D],
    b: &[[[f32; L]; D]; 3],
) -> [[[f32; L]; D]; 3] {
    let mut x = [[[0.0f32; L]; D]; 3];
    for c in 0..3 {
        // Forward: L y = b.
        let mut y = [[0.0f32; L]; D];
        for i in 0..D {
            let mut s = b[c][i];
            for k in 0..i {
                for l in 0..L {
                    s[l] -= lo[i][k][l] * y[k][l];
                }
            }
            for l in 0..L {
                y[i][l] = s[l] * inv_diag[i][l];
            }
        }
        // Backward: Lᵀ x = y.
        for i in (0..D).rev() {
            let mut s = y[i];
            for k in i + 1..D {
                for l in 0..L {
                    s[l] -= lo[k][i][l] * x[c][k][l];
                }
            }
            for l in 0..L {
                x[c][i][l] = s[l] * inv_diag[i][l];
            }
        }
    }
    x
}

/// The lower Cholesky factor of L symmetric positive definite D×D systems (lanes last; only
/// the lower triangle of `a` is read) and the reciprocals of its diagonal. Pivots are floored
/// at a tiny positive value, so a matrix that rounding made slightly indefinite still gives a
/// finite answer instead of NaN.
#[inline(always)]
pub(crate) fn factor_lanes<const D: usize>(
    a: &[[[f32; L]; D]; D],
) -> ([[[f32; L]; D]; D], [[f32; L]; D]) {
    let mut lo = [[[0.0f32; L]; D]; D];
    let mut inv_diag = [[0.0f32; L]; D];
    for j in 0..D {
        let mut s = a[j][j];
        for k in 0..j {
            for l in 0..L {
                s[l] -= lo[j][k][l] * lo[j][k][l];
            }
        }
        for l in 0..L {
            let d = s[l].max(1e-12).sqrt();
            lo[j][j][l] = d;
            inv_diag[j][l] = 1.0 / d;
        }
        for i in j + 1..D {
            let mut s = a[i][j];
            for k in 0..j {
                for l in 0..L {
                    s[l] -= lo[i][k][l] * lo[j][k][l];
                }
            }
            for l in 0..L {
                lo[i][j][l] = s[l] * inv_diag[j][l];
            }
        }
    }
    (lo, inv_diag)
}

/// The inverse `M = L⁻¹` of the lower factor [`factor_lanes`] returns (lower triangular; the
/// system's inverse is `MᵀM`).
#[inline(always)]
pub(crate) fn inverse_factor_lanes<const D: usize>(
    lo: &[[[f32; L]; D]; D],
    inv_diag: &[[f32; L]; D],
) -> [[[f32; L]; D]; D] {
    let mut m = [[[0.0f32; L]; D]; D];
    for j in 0..D {
        m[j][j] = inv_diag[j];
        for i in j + 1..D {
            let mut s = [0.0f32; L];
            for k in j..i {
                for l in 0..L {
                    s[l] += lo[i][k][l] * m[k][j][l];
                }
            }
            for l in 0..L {
                m[i][j][l] = -s[l] * inv_diag[i][l];
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inverse_factor_gives_the_inverse() {
        let a = [
            [4.0, 1.0, 0.5, 0.1],
            [1.0, 3.0, 0.2, 0.3],
            [0.5, 0.2, 2.0, 0.4],
            [0.1, 0.3, 0.4, 1.5],
        ];
        let mut al = [[[0.0f32; L]; 4]; 4];
        for l in 0..L {
            for i in 0..4 {
                for j in 0..4 {
                    al[i][j][l] = a[i][j] * (1.0 + l as f32);
                }
            }
        }
        let (lo, inv_diag) = factor_lanes(&al);
        let m = inverse_factor_lanes(&lo, &inv_diag);
        for l in 0..L {
            // (MᵀM) A = I.
            for i in 0..4 {
                for j in 0..4 {
                    let mut v = 0.0;
                    for k in 0..4 {
                        let inv_ik: f32 = (0..4).map(|q| m[q][i][l] * m[q][k][l]).sum();
                        v += inv_ik * al[k][j][l];
                    }
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((v - want).abs() < 1e-5, "lane {l} ({i}, {j}): {v}");
                }
            }
        }
    }

    #[test]
    fn solves_a_known_system() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let want = [[1.0, -2.0, 0.5], [0.0, 1.0, 0.0], [3.0, 3.0, -1.0]];
        let mut b = [[0.0f32; 3]; 3];
        for c in 0..3 {
            for i in 0..3 {
                b[c][i] = (0..3).map(|k| a[i][k] * want[c][k]).sum();
            }
        }
        // The same system in every lane but one, which gets a scaled copy.
        let mut al = [[[0.0f32; L]; 3]; 3];
        let mut bl = [[[0.0f32; L]; 3]; 3];
        for l in 0..L {
            let s = if l == 5 { 2.0 } else { 1.0 };
            for i in 0..3 {
                for j in 0..3 {
                    al[i][j][l] = a[i][j] * s;
                    bl[i][j][l] = b[i][j] * s;
                }
            }
        }
        let (lo, inv_diag) = factor_lanes::<3>(&al);
        let x = solve_factored::<3>(&lo, &inv_diag, &bl);
        for l in 0..L {
            for c in 0..3 {
                for i in 0..3 {
                    assert!((x[c][i][l] - want[c][i]).abs() < 1e-5, "lane {l}");
                }
            }
        }
    }
}
