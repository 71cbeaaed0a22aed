//! Materials that are two BSDFs: Mitsuba's `twosided` with a front and a back BSDF, and
//! `blendbsdf`. Each branch becomes a material of its own, appended after the scene's (so the
//! per-material tables of plastics' coats, anisotropy and sidedness hold for it as for any
//! material), and a hit on the parent material is shaded as a hit on the branch it picks:
//! the side the ray arrived from, or a blend's random choice.

use lumo_scene::{BsdfSpec, Material, Texture};

use super::Surface;

/// How a material with two branches picks one.
#[derive(Clone, Debug)]
pub(crate) enum Pick {
    /// By the side the ray arrived from (`twosided`).
    Side,
    /// The second with probability `weight` (`blendbsdf`).
    Blend(Texture),
}

/// A material with two branches: how it picks and the branches' material indices.
#[derive(Clone, Debug)]
pub(crate) struct Branches {
    /// How the branch is picked.
    pub pick: Pick,
    /// The front side's / first BSDF's material.
    pub first: usize,
    /// The back side's / second BSDF's material.
    pub second: usize,
}

/// `b` with adapters over a two-branch BSDF pushed into both branches (a mask over a
/// `twosided` masks both sides), so that a two-branch BSDF, if any, is outermost.
fn hoist(b: &BsdfSpec) -> BsdfSpec {
    let wrap = |nested: BsdfSpec, b: &BsdfSpec| -> BsdfSpec {
        let nested = Box::new(nested);
        match b {
            BsdfSpec::Mask {
                opacity, cutoff, ..
            } => BsdfSpec::Mask {
                opacity: opacity.clone(),
                cutoff: *cutoff,
                nested,
            },
            BsdfSpec::NormalMap { normals, .. } => BsdfSpec::NormalMap {
                normals: normals.clone(),
                nested,
            },
            BsdfSpec::BumpMap { height, scale, .. } => BsdfSpec::BumpMap {
                height: height.clone(),
                scale: *scale,
                nested,
            },
            other => other.clone(),
        }
    };
    let nested = match b.adapted() {
        Some(nested) => hoist(nested),
        None => return b.clone(),
    };
    match nested {
        BsdfSpec::TwoSided { front, back } => BsdfSpec::TwoSided {
            front: Box::new(wrap(*front, b)),
            back: Box::new(wrap(*back, b)),
        },
        BsdfSpec::Blend {
            weight,
            first,
            second,
        } => BsdfSpec::Blend {
            weight,
            first: Box::new(wrap(*first, b)),
            second: Box::new(wrap(*second, b)),
        },
        plain => wrap(plain, b),
    }
}

/// The branch materials of `materials` (to be appended after them) and, per material of the
/// whole list (the scene's, then the branches'), its branches if it has two.
pub(crate) fn branch_materials(materials: &[Material]) -> (Vec<Material>, Vec<Option<Branches>>) {
    let mut extra: Vec<Material> = Vec::new();
    let mut branches: Vec<Option<Branches>> = Vec::new();
    let n = materials.len();
    let mut i = 0;
    // Branches may have branches (a blend of blends): a worklist over the growing list.
    while i < n + extra.len() {
        let m = if i < n { &materials[i] } else { &extra[i - n] };
        let spec = hoist(&m.bsdf);
        let split = match spec {
            BsdfSpec::TwoSided { front, back } => Some((Pick::Side, *front, *back, true)),
            BsdfSpec::Blend {
                weight,
                first,
                second,
            } => Some((Pick::Blend(weight), *first, *second, m.two_sided)),
            _ => None,
        };
        let (name, emission, emission_map) = (m.name.clone(), m.emission, m.emission_map.clone());
        let entry = split.map(|(pick, a, b, two_sided)| {
            let branch = |bsdf: BsdfSpec, side: &str| Material {
                name: format!("{name} ({side})"),
                bsdf,
                emission,
                emission_map: emission_map.clone(),
                two_sided,
                spectra: Default::default(),
            };
            let (ma, mb) = match pick {
                Pick::Side => (branch(a, "front"), branch(b, "back")),
                Pick::Blend(_) => (branch(a, "first"), branch(b, "second")),
            };
            extra.push(ma);
            extra.push(mb);
            let first = n + extra.len() - 2;
            Branches {
                pick,
                first,
                second: first + 1,
            }
        });
        branches.push(entry);
        i += 1;
    }
    (extra, branches)
}

/// A uniform number in [0, 1) from the hit itself: the blend's choice at `s`. Every hit point
/// differs in its bits, so the choices are as good as independent draws, and they depend on
/// nothing but the hit (the same on any thread, and the same for a light path and a camera
/// path meeting there).
#[inline]
pub(crate) fn hit_uniform(s: &Surface) -> f32 {
    let mut h = (s.p.x.to_bits() as u64)
        ^ ((s.p.y.to_bits() as u64) << 21)
        ^ ((s.p.z.to_bits() as u64) << 42)
        ^ ((s.instance as u64) << 32)
        ^ s.triangle as u64;
    // splitmix64's finaliser.
    h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^= h >> 31;
    (h >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Basis;
    use glam::{Vec2, Vec3};

    /// The blend's numbers are uniform over neighbouring hit points (a 256×256 patch of a
    /// plane 1 mm across): a χ² test on 16 bins.
    #[test]
    fn hit_numbers_are_uniform_over_nearby_points() {
        let mut bins = [0u32; 16];
        let n = 256;
        for i in 0..n {
            for j in 0..n {
                let s = Surface {
                    p: Vec3::new(0.3 + i as f32 * 4e-6, 1.2, -0.7 + j as f32 * 4e-6),
                    ng: Vec3::Y,
                    frame: Basis::new(Vec3::Y),
                    uv: Vec2::ZERO,
                    color: Vec3::ONE,
                    material: 0,
                    instance: 3,
                    triangle: 17,
                    back: false,
                };
                let u = hit_uniform(&s);
                assert!((0.0..1.0).contains(&u));
                bins[(u * 16.0) as usize] += 1;
            }
        }
        // χ² with 15 degrees of freedom: 37.7 is its 99.9th percentile.
        let share = (n * n / 16) as f32;
        let chi2: f32 = bins
            .iter()
            .map(|&c| (c as f32 - share).powi(2) / share)
            .sum();
        assert!(chi2 < 37.7, "χ² = {chi2}: {bins:?}");
    }

    /// A mask over a `twosided` masks both sides, and each side becomes a material whose
    /// tables are those of its own BSDF.
    #[test]
    fn adapters_over_two_branches_go_into_both() {
        let diffuse = |c: f32| BsdfSpec::Diffuse {
            reflectance: Texture::Constant(Vec3::splat(c)),
        };
        let mut m = Material::diffuse("m", Vec3::ONE);
        m.bsdf = BsdfSpec::Mask {
            opacity: Texture::Constant(Vec3::splat(0.5)),
            cutoff: None,
            nested: Box::new(BsdfSpec::TwoSided {
                front: Box::new(diffuse(0.2)),
                back: Box::new(diffuse(0.7)),
            }),
        };
        let (extra, branches) = branch_materials(&[m]);
        assert_eq!(extra.len(), 2);
        let b = branches[0].as_ref().expect("branches");
        assert!(matches!(b.pick, Pick::Side));
        assert_eq!((b.first, b.second), (1, 2));
        for (m, c) in extra.iter().zip([0.2, 0.7]) {
            let BsdfSpec::Mask { nested, .. } = &m.bsdf else {
                panic!("{:?}", m.bsdf)
            };
            assert!(
                matches!(&**nested, BsdfSpec::Diffuse { reflectance: Texture::Constant(r) } if r.x == c)
            );
        }
        assert!(branches[1].is_none() && branches[2].is_none());
    }
}
