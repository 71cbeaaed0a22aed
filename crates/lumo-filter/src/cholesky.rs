//! Small symmetric positive definite solves (the guided filter's d×d window systems).

/// Solves `A x_c = b_c` for the 3 right-hand sides `b` with `A` symmetric positive definite
/// (D×D, only the lower triangle is read). One Cholesky factorisation serves all three colour
/// channels. Pivots are floored at a tiny positive value, so a matrix that rounding made
/// slightly indefinite still gives a finite answer instead of NaN.
#[inline]
pub(crate) fn solve_spd3<const D: usize>(a: &[[f32; D]; D], b: &[[f32; D]; 3]) -> [[f32; D]; 3] {
    let mut l = [[0.0f32; D]; D];
    let mut inv_diag = [0.0f32; D];
    for j in 0..D {
        let mut s = a[j][j];
        for k in 0..j {
            s -= l[j][k] * l[j][k];
        }
        let d = s.max(1e-12).sqrt();
        l[j][j] = d;
        inv_diag[j] = 1.0 / d;
        for i in j + 1..D {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = s * inv_diag[j];
        }
    }
    let mut x = [[0.0f32; D]; 3];
    for c in 0..3 {
        // Forward: L y = b.
        let mut y = [0.0f32; D];
        for i in 0..D {
            let mut s = b[c][i];
            for k in 0..i {
                s -= l[i][k] * y[k];
            }
            y[i] = s * inv_diag[i];
        }
        // Backward: Lᵀ x = y.
        for i in (0..D).rev() {
            let mut s = y[i];
            for k in i + 1..D {
                s -= l[k][i] * x[c][k];
            }
            x[c][i] = s * inv_diag[i];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let x = solve_spd3::<3>(&a, &b);
        for c in 0..3 {
            for i in 0..3 {
                assert!((x[c][i] - want[c][i]).abs() < 1e-5);
            }
        }
    }
}
