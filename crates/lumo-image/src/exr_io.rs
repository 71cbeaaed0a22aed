use std::path::Path;

use exr::prelude::{self as exrp, ReadChannels, ReadLayers, WritableImage};

use crate::io::{format_err, io_err};
use crate::limits::{check_image_size, max_image_pixels, MAX_PIXELS_VAR};
use crate::{Image, ImageError};

/// Reads the first valid layer of an OpenEXR file (half, float or uint channels).
///
/// Channel choice: `R,G,B` (any layer prefix) → 3 channels; else `X,Y,Z` → 3; else a single
/// non-alpha channel (`Y`, `Z`, `depth`, …) → 1. Alpha is ignored.
///
/// The headers are read and checked first (every layer's size against the pixel budget, its
/// block count against the file's `file_bytes`): the exr crate allocates a layer's pixels and
/// block table as its header says, before it finds out that the file is too short.
pub(crate) fn read(path: &Path, file_bytes: u64) -> Result<Image, ImageError> {
    check_headers(path, file_bytes)?;
    let image = exrp::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| exr_err(path, "cannot read OpenEXR", e))?;
    let size = image.layer_data.size;
    let (w, h) = (size.width(), size.height());
    let channels = &image.layer_data.channel_data.list;
    let short_name = |c: &exrp::AnyChannel<exrp::FlatSamples>| {
        let name = c.name.to_string();
        name.rsplit('.').next().unwrap_or("").to_string()
    };
    let find = |want: &str| {
        channels
            .iter()
            .find(|c| short_name(c).eq_ignore_ascii_case(want))
    };
    let picked: Vec<_> = if let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) {
        vec![r, g, b]
    } else if let (Some(x), Some(y), Some(z)) = (find("X"), find("Y"), find("Z")) {
        vec![x, y, z]
    } else {
        let non_alpha: Vec<_> = channels
            .iter()
            .filter(|c| !short_name(c).eq_ignore_ascii_case("A"))
            .collect();
        if non_alpha.len() == 1 {
            non_alpha
        } else {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(format_err(
                path,
                format!(
                    "cannot tell which channels hold the image (found {names:?}); expected R,G,B, \
                     X,Y,Z or a single channel"
                ),
            ));
        }
    };
    let n = picked.len();
    let mut data = vec![0.0f32; w * h * n];
    for (c, ch) in picked.iter().enumerate() {
        for (i, v) in ch.sample_data.values_as_f32().enumerate().take(w * h) {
            data[i * n + c] = v;
        }
    }
    Ok(Image::from_vec(w, h, n, data))
}

/// Every layer within the pixel budget (counting all its channels, as the exr crate allocates
/// them all) and no more blocks than the file can hold.
fn check_headers(path: &Path, file_bytes: u64) -> Result<(), ImageError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    let meta = exr::meta::MetaData::read_from_unbuffered(file, false)
        .map_err(|e| exr_err(path, "cannot read OpenEXR header", e))?;
    let mut blocks = 0u64;
    for header in &meta.headers {
        let size = header.layer_size;
        let (w, h) = (size.width(), size.height());
        check_image_size(path, w, h, file_bytes)?;
        // Up to four channels (RGBA) fit the budget's pixel count; more count as more pixels.
        let channels = header.channels.list.len().max(1) as u64;
        let samples = (w as u64 * h as u64).saturating_mul(channels.div_ceil(4));
        if samples > max_image_pixels() {
            return Err(format_err(
                path,
                format!(
                    "{w}x{h} pixels in {channels} channels (in a file of {file_bytes} bytes) is \
                     over the image limit of {} pixels of up to 4 channels; if the image is \
                     genuine, raise the limit with {MAX_PIXELS_VAR}=PIXELS",
                    max_image_pixels()
                ),
            ));
        }
        blocks = blocks.saturating_add(header.chunk_count as u64);
    }
    // Each block has an 8-byte entry in the offset table and at least an 8-byte block header.
    if blocks.saturating_mul(16) > file_bytes {
        return Err(format_err(
            path,
            format!(
                "truncated or corrupt OpenEXR: its headers announce {blocks} blocks of pixels, \
                 more than a file of {file_bytes} bytes can hold"
            ),
        ));
    }
    Ok(())
}

/// An exr crate error as an [`ImageError`]: an I/O failure keeps its kind, anything else is a
/// format error prefixed with `what`.
fn exr_err(path: &Path, what: &str, e: exrp::Error) -> ImageError {
    match e {
        exrp::Error::Io(source) => io_err(path, source),
        other => format_err(path, format!("{what}: {other}")),
    }
}

/// Writes float32 channels: `Y` for one channel, `R,G,B` for three, `R,G,B,A` for four.
pub(crate) fn write(path: &Path, image: &Image) -> Result<(), ImageError> {
    let names: &[&str] = match image.channels {
        1 => &["Y"],
        3 => &["R", "G", "B"],
        4 => &["R", "G", "B", "A"],
        n => {
            return Err(format_err(
                path,
                format!("cannot write a {n}-channel image as EXR (1, 3 or 4 channels)"),
            ))
        }
    };
    let n = image.channels;
    let list: exrp::SmallVec<[exrp::AnyChannel<exrp::FlatSamples>; 4]> = names
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let plane: Vec<f32> = image.data.iter().skip(c).step_by(n).copied().collect();
            exrp::AnyChannel::new(*name, exrp::FlatSamples::F32(plane))
        })
        .collect();
    let layer = exrp::Layer::new(
        (image.width, image.height),
        exrp::LayerAttributes::default(),
        // Blocks in increasing order: the default ("unspecified") writes them in the order the
        // parallel compressors finish, so the same image gave different bytes on every run.
        exrp::Encoding {
            line_order: exrp::LineOrder::Increasing,
            ..exrp::Encoding::FAST_LOSSLESS
        },
        exrp::AnyChannels::sort(list),
    );
    exrp::Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| exr_err(path, "cannot write OpenEXR", e))
}
