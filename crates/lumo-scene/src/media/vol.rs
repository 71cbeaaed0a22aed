//! Mitsuba's binary `.vol` grid files (the `gridvolume` format, shared with Mitsuba 0.6).
//!
//! Layout (little endian): `VOL`, version byte 3, encoding i32 (1 = float32), resolution x, y,
//! z (i32), channels (i32), a bounding box (6 f32, ignored as Mitsuba 3 ignores it by
//! default), then x-fastest float32 data.

use std::io::Read;
use std::path::Path;

use super::{DensityGrid, MAX_GRID_VOXELS};

/// Bytes before the voxels.
const HEADER: u64 = 48;

/// Reads a single-channel `.vol` file as a density grid. The error says what is wrong
/// (without the path, which the caller adds with the element that names the file).
pub fn read_vol(path: &Path) -> Result<DensityGrid, String> {
    let io = |e: std::io::Error| format!("cannot read: {}", lumo_image::describe_io_error(&e));
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err("is not a regular file".into());
    }
    let size = meta.len();
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut header = [0u8; HEADER as usize];
    if size < HEADER {
        return Err(format!(
            "is {size} bytes, shorter than a .vol header ({HEADER} bytes); not a Mitsuba grid file"
        ));
    }
    file.read_exact(&mut header).map_err(io)?;
    if &header[..3] != b"VOL" {
        return Err("does not start with \"VOL\"; not a Mitsuba grid (.vol) file".into());
    }
    if header[3] != 3 {
        return Err(format!(
            "is .vol version {}; lumo reads version 3 (Mitsuba's)",
            header[3]
        ));
    }
    let int =
        |i: usize| i32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!(
            "has encoding {encoding}; lumo reads encoding 1 (float32), as Mitsuba 3 does"
        ));
    }
    let (rx, ry, rz, channels) = (int(8), int(12), int(16), int(20));
    if rx <= 0 || ry <= 0 || rz <= 0 {
        return Err(format!(
            "has resolution {rx}×{ry}×{rz}; every axis needs at least one voxel"
        ));
    }
    if channels != 1 {
        return Err(format!(
            "has {channels} channels; lumo reads density grids of 1 channel (write sigma_t \
             as one channel and give the colour as the medium's albedo)"
        ));
    }
    let voxels = rx as u64 * ry as u64 * rz as u64;
    if voxels > MAX_GRID_VOXELS {
        return Err(format!(
            "has {rx}×{ry}×{rz} = {voxels} voxels, more than lumo's limit of {MAX_GRID_VOXELS} \
             ({} of densities); downsample the grid",
            lumo_image::format_bytes(MAX_GRID_VOXELS * 4)
        ));
    }
    let expected = HEADER + voxels * 4;
    if size != expected {
        return Err(format!(
            "is {size} bytes, but its header ({rx}×{ry}×{rz} voxels of 1 float) needs \
             {expected}; the file is truncated or its header is wrong"
        ));
    }
    let mut bytes = vec![0u8; (voxels * 4) as usize];
    file.read_exact(&mut bytes).map_err(io)?;
    let data = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    DensityGrid::new([rx as usize, ry as usize, rz as usize], data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vol(res: [i32; 3], channels: i32, values: &[f32]) -> Vec<u8> {
        let mut b = b"VOL\x03".to_vec();
        for v in [1, res[0], res[1], res[2], channels] {
            b.extend(v.to_le_bytes());
        }
        for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0].iter().chain(values) {
            b.extend(v.to_le_bytes());
        }
        b
    }

    fn read(name: &str, bytes: &[u8]) -> Result<DensityGrid, String> {
        let dir = std::env::temp_dir().join(format!("lumo-vol-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        let r = read_vol(&p);
        std::fs::remove_file(&p).unwrap();
        r
    }

    #[test]
    fn reads_a_grid_and_refuses_bad_ones() {
        let g = read("ok.vol", &vol([2, 1, 1], 1, &[0.5, 1.5])).unwrap();
        assert_eq!(g.resolution(), [2, 1, 1]);
        assert_eq!(g.max(), 1.5);
        let lying = read("lying.vol", &vol([4, 4, 4], 1, &[1.0; 8])).unwrap_err();
        assert!(lying.contains("truncated"), "{lying}");
        let huge = read("huge.vol", &vol([100_000, 100_000, 100_000], 1, &[1.0])).unwrap_err();
        assert!(huge.contains("limit"), "{huge}");
        let nan = read("nan.vol", &vol([2, 1, 1], 1, &[1.0, f32::NAN])).unwrap_err();
        assert!(nan.contains("voxel (1, 0, 0)"), "{nan}");
        let neg = read("neg.vol", &vol([2, 1, 1], 1, &[-1.0, 0.0])).unwrap_err();
        assert!(neg.contains("≥ 0"), "{neg}");
        let png = read(
            "x.vol",
            b"\x89PNG\r\n\x1a\n and then more than fifty bytes of nothing at all",
        )
        .unwrap_err();
        assert!(png.contains("not a Mitsuba grid"), "{png}");
        let rgb = read("rgb.vol", &vol([1, 1, 1], 3, &[1.0; 3])).unwrap_err();
        assert!(rgb.contains("3 channels"), "{rgb}");
    }
}
