//! Parsers and limits of options several subcommands share (`render`, `serve`, `bench`).

use lumo_render::integrators::photon::KdTree;

/// Most samples per pixel `--spp` accepts: 2^20 is days of rendering at 512x512; beyond,
/// a typo (4294967295) would run for ever.
pub const MAX_SPP: u32 = 1 << 20;

/// Bytes of a photon map holding `photons` photons (tree nodes included).
pub fn ppm_map_bytes(photons: usize) -> u64 {
    photons as u64 * KdTree::BYTES_PER_PHOTON as u64
}

/// Most photons `--max-photons` accepts: 2^30 is 72 GB of map.
pub const MAX_PHOTONS: usize = 1 << 30;

/// Parses `WxH`.
pub fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let err = || {
        format!("invalid size {s:?}: expected WIDTHxHEIGHT with both in 1..=16384, e.g. 512x512")
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let w: usize = w.trim().parse().map_err(|_| err())?;
    let h: usize = h.trim().parse().map_err(|_| err())?;
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(err());
    }
    Ok((w, h))
}

/// Parses `--time T`: seconds, a finite number (a NaN would reach the animation as a
/// transform that is "not finite", naming an instance instead of the option).
pub fn parse_time(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(t) if t.is_finite() => Ok(t),
        _ => Err(format!(
            "invalid time {s:?}: expected a finite number of seconds, e.g. 0.5"
        )),
    }
}

/// Parses `NAME=VALUE` for `-D`.
pub fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err(format!(
            "invalid definition {s:?}: expected NAME=VALUE, e.g. spp=64"
        )),
    }
}
