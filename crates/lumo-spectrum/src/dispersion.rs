//! Dispersive glasses: index of refraction as a function of wavelength (Sellmeier equation,
//! n²(λ) = 1 + Σ Bᵢλ² / (λ² − Cᵢ), λ in µm), for the named dielectrics Mitsuba knows.
//!
//! Mitsuba 3 gives each named glass one index (e.g. `bk7` = 1.5046). lumo keeps that index at
//! the sodium d line (587.56 nm) and adds the glass's measured dispersion around it:
//! n(λ) = n_Mitsuba + n_Sellmeier(λ) − n_Sellmeier(587.56 nm), so RGB rendering, Mitsuba and
//! spectral rendering agree on the mean index and only the spectral renderer spreads colours.

/// Sellmeier coefficients of a glass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glass {
    /// B₁..B₃ (dimensionless).
    pub b: [f64; 3],
    /// C₁..C₃ in µm².
    pub c: [f64; 3],
}

/// The sodium d line, nm (where an index without wavelength is quoted).
pub const D_LINE: f32 = 587.56;

/// (Mitsuba name, Sellmeier coefficients) of the dispersive glasses lumo knows. Sources:
/// Schott's N-BK7 data sheet; Malitson 1965 (fused silica); Malitson & Dodge 1972 (sapphire,
/// ordinary ray); Peter 1923 (diamond).
const GLASSES: &[(&str, Glass)] = &[
    (
        "bk7",
        Glass {
            b: [1.039_612_12, 0.231_792_344, 1.010_469_45],
            c: [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
        },
    ),
    (
        "fused quartz",
        Glass {
            b: [0.696_166_3, 0.407_942_6, 0.897_479_4],
            c: [0.004_679_148, 0.013_512_063, 97.934_003],
        },
    ),
    (
        "sapphire",
        Glass {
            b: [1.431_349_3, 0.650_547_13, 5.341_402_1],
            c: [0.005_279_926, 0.014_238_27, 325.017_83],
        },
    ),
    (
        "diamond",
        Glass {
            b: [0.3306, 4.3356, 0.0],
            c: [0.030_625, 0.011_236, 0.0],
        },
    ),
];

impl Glass {
    /// The glass Mitsuba calls `name` (e.g. "bk7"), if lumo knows its dispersion.
    pub fn named(name: &str) -> Option<Glass> {
        GLASSES.iter().find(|(n, _)| *n == name).map(|(_, g)| *g)
    }

    /// Names of the dispersive glasses.
    pub fn names() -> impl Iterator<Item = &'static str> {
        GLASSES.iter().map(|(n, _)| *n)
    }

    /// The Sellmeier index at `lambda` nm.
    pub fn sellmeier(&self, lambda: f32) -> f32 {
        let l2 = (lambda as f64 * 1e-3).powi(2);
        let n2 = 1.0
            + (0..3)
                .map(|i| self.b[i] * l2 / (l2 - self.c[i]))
                .sum::<f64>();
        n2.max(1.0).sqrt() as f32
    }

    /// The index at `lambda` nm of this glass quoted as `ior` at the d line.
    #[inline]
    pub fn ior(&self, ior: f32, lambda: f32) -> f32 {
        ior + self.sellmeier(lambda) - self.sellmeier(D_LINE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bk7_matches_its_data_sheet() {
        let g = Glass::named("bk7").unwrap();
        // Schott N-BK7: n_d = 1.5168, n_F (486.13 nm) = 1.5224, n_C (656.27 nm) = 1.5143;
        // Abbe number 64.17.
        assert!((g.sellmeier(587.56) - 1.5168).abs() < 1e-4);
        let (nf, nc) = (g.sellmeier(486.13), g.sellmeier(656.27));
        assert!((nf - 1.5224).abs() < 2e-4 && (nc - 1.5143).abs() < 2e-4);
        let abbe = (g.sellmeier(587.56) - 1.0) / (nf - nc);
        assert!((abbe - 64.17).abs() < 0.5, "{abbe}");
        assert_eq!(g.ior(1.5046, D_LINE), 1.5046);
    }

    #[test]
    fn every_glass_is_normal_dispersive() {
        for name in Glass::names() {
            let g = Glass::named(name).unwrap();
            let (blue, red) = (g.sellmeier(420.0), g.sellmeier(680.0));
            assert!(blue > red && red > 1.3, "{name}: {blue} {red}");
        }
    }
}
