//! The frames of `lumo render --frames A..B`: the range and its options, each frame's file
//! name and seed.

use std::path::{Path, PathBuf};

/// Highest frame number `--frames` accepts: a million frames is over eleven hours of film at
/// 24 fps; a larger number is a typo.
pub const MAX_FRAME: u32 = 999_999;

/// Frame rate of `--frames` without `--fps`: film's.
pub const DEFAULT_FPS: f32 = 24.0;

/// Fewest digits in a frame file's number (`out_0007.exr`); more when the last frame needs them.
const MIN_DIGITS: usize = 4;

/// The frames of `--frames A..B`: `first` to `last`, both included.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// The first frame.
    pub first: u32,
    /// The last frame (at least `first`).
    pub last: u32,
}

impl FrameRange {
    /// How many frames.
    pub fn count(&self) -> u32 {
        self.last - self.first + 1
    }
}

/// Parses `--frames`: `A..B` (both included, like a frame range in an animation program),
/// `A..=B` (the same) or a single frame `N`.
pub fn parse_frames(s: &str) -> Result<FrameRange, String> {
    let example = "expected A..B with whole frame numbers from 0 to 999999, e.g. 0..47 \
                   (frames 0 to 47, both included)";
    let number = |t: &str| -> Result<u32, String> {
        let t = t.trim();
        let n: u64 = t
            .parse()
            .map_err(|_| format!("{t:?} is not a frame number; {example}"))?;
        u32::try_from(n)
            .ok()
            .filter(|&n| n <= MAX_FRAME)
            .ok_or_else(|| format!("frame {n} is past the last frame number {MAX_FRAME}"))
    };
    let (first, last) = match s.split_once("..") {
        Some((a, b)) => (number(a)?, number(b.strip_prefix('=').unwrap_or(b))?),
        None => {
            let n = number(s)?;
            (n, n)
        }
    };
    if last < first {
        return Err(format!(
            "the last frame {last} comes before the first {first}; write the range first to \
             last, e.g. {last}..{first}"
        ));
    }
    Ok(FrameRange { first, last })
}

/// Parses `--fps`: a positive, finite frame rate of at most 10,000.
pub fn parse_fps(s: &str) -> Result<f32, String> {
    let fps: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number; give frames per second, e.g. 24 or 29.97"))?;
    if !(fps > 0.0 && fps <= 10_000.0) {
        return Err(format!(
            "{fps} frames per second: the rate must be above 0 and at most 10000, e.g. 24"
        ));
    }
    Ok(fps)
}

/// Parses `--orbit`: a finite angle in degrees (negative turns the other way).
pub fn parse_orbit(s: &str) -> Result<f32, String> {
    let deg: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not an angle; give degrees, e.g. 360 for a full turn"))?;
    if !deg.is_finite() || deg.abs() > 36_000.0 {
        return Err(format!(
            "{s}: give an angle in degrees within ±36000, e.g. 360 for a full turn"
        ));
    }
    Ok(deg)
}

/// The file of frame `frame` for output `base`: the frame number, zero-padded to `digits`,
/// joins the file stem with an underscore (`out.exr` → `out_0007.exr`).
pub fn frame_file(base: &Path, frame: u32, digits: usize) -> PathBuf {
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match base.extension() {
        Some(ext) => format!("{stem}_{frame:0digits$}.{}", ext.to_string_lossy()),
        None => format!("{stem}_{frame:0digits$}"),
    };
    base.with_file_name(name)
}

/// Digits of frame numbers in file names: at least [`MIN_DIGITS`], more if `last` needs them.
pub fn frame_digits(last: u32) -> usize {
    last.to_string().len().max(MIN_DIGITS)
}

/// The seed of frame `frame` of a sequence rendered with `seed`: a hash of both, so that no
/// two (seed, frame) pairs share their noise by construction (`seed + frame·k`, used before,
/// gave seed 5's frame 1 the noise of seed 5 + k's frame 0: the same images, shifted).
pub fn frame_seed(seed: u32, frame: u32) -> u32 {
    // splitmix64's step: every input bit reaches every output bit.
    let z = (u64::from(seed) << 32 | u64::from(frame)).wrapping_add(0x9e37_79b9_7f4a_7c15);
    lumo_render::sampler::mix64(z) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_parse_inclusive() {
        let r = parse_frames("0..47").unwrap();
        assert_eq!((r.first, r.last, r.count()), (0, 47, 48));
        assert_eq!(parse_frames("5..=5").unwrap().count(), 1);
        assert_eq!(
            parse_frames("12").unwrap(),
            FrameRange {
                first: 12,
                last: 12
            }
        );
        assert_eq!(parse_frames(" 3 .. 4 ").unwrap().count(), 2);
    }

    #[test]
    fn bad_frame_ranges_say_what_to_write() {
        let e = parse_frames("10..2").unwrap_err();
        assert!(e.contains("comes before") && e.contains("2..10"), "{e}");
        for bad in ["a..b", "1..x", "-1..3", "1.5..3", "", "..", "1...3"] {
            let e = parse_frames(bad).unwrap_err();
            assert!(
                e.contains("not a frame number") && e.contains("0..47"),
                "{bad}: {e}"
            );
        }
        let e = parse_frames("0..5000000000").unwrap_err();
        assert!(e.contains("999999"), "{e}");
    }

    #[test]
    fn fps_and_orbit_must_be_usable_numbers() {
        assert_eq!(parse_fps("29.97").unwrap(), 29.97);
        for bad in ["0", "-24", "nan", "inf", "1e9"] {
            assert!(parse_fps(bad).unwrap_err().contains("above 0"), "{bad}");
        }
        assert!(parse_fps("fast").unwrap_err().contains("not a number"));
        assert_eq!(parse_orbit("-90").unwrap(), -90.0);
        assert!(parse_orbit("inf").is_err() && parse_orbit("left").is_err());
    }

    #[test]
    fn frame_files_are_numbered_after_the_stem() {
        let p = |base: &str, f, last| frame_file(Path::new(base), f, frame_digits(last));
        assert_eq!(p("out.exr", 7, 47), PathBuf::from("out_0007.exr"));
        assert_eq!(p("dir/shot.png", 0, 9), PathBuf::from("dir/shot_0000.png"));
        assert_eq!(p("a.b.pfm", 12345, 12345), PathBuf::from("a.b_12345.pfm"));
        assert_eq!(p("noext", 3, 3), PathBuf::from("noext_0003"));
    }
}
