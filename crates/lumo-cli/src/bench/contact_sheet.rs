//! The contact sheet of `lumo bench quality`: one row per scene and spp, the reference in the
//! first column and one column per method; under each image a magnified crop of the scene's
//! hardest region and the image's scores, drawn with the built-in bitmap font.

use lumo_image::Image;

use super::font::{draw_text, text_width, GLYPH_H};

/// One image of a row, with the text lines drawn beside its crop.
pub struct Tile<'a> {
    /// Linear RGB, the scene's size.
    pub image: &'a Image,
    /// Short lines (about 10 characters fit at 256 px per tile).
    pub lines: Vec<String>,
}

/// One row: a scene at one spp.
pub struct Row<'a> {
    /// The reference and then each method, in column order.
    pub tiles: Vec<Tile<'a>>,
    /// The crop window (x, y, side) in image pixels, outlined on the reference.
    pub crop: (usize, usize, usize),
}

const GAP: usize = 4;
const BACKGROUND: [f32; 3] = [0.012, 0.012, 0.012];
const TEXT: [f32; 3] = [0.9, 0.9, 0.9];
const MARK: [f32; 3] = [1.0, 0.75, 0.0];

/// Side of the crop window for a `w`×`h` image: a quarter of the shorter side.
pub fn crop_side(w: usize, h: usize) -> usize {
    (w.min(h) / 4).max(1)
}

/// The `side`×`side` window where `error` (one value per pixel, row-major, `w` wide) sums
/// highest; the first such window in row-major order, so the choice is deterministic.
pub fn hardest_window(error: &[f64], w: usize, h: usize, side: usize) -> (usize, usize) {
    let side = side.min(w).min(h).max(1);
    // Summed-area table with a zero row and column in front.
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            let e = error[y * w + x];
            row += if e.is_finite() { e } else { 0.0 };
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let sum = |x: usize, y: usize| {
        let (x1, y1) = (x + side, y + side);
        sat[y1 * (w + 1) + x1] - sat[y * (w + 1) + x1] - sat[y1 * (w + 1) + x]
            + sat[y * (w + 1) + x]
    };
    let mut best = (0, 0, f64::NEG_INFINITY);
    for y in 0..=h - side {
        for x in 0..=w - side {
            let s = sum(x, y);
            if s > best.2 {
                best = (x, y, s);
            }
        }
    }
    (best.0, best.1)
}

/// The linear value a display shows: `clamp(2^exposure · x, 0, 1)`, non-finite as black.
fn display(x: f32, gain: f32) -> f32 {
    let v = x * gain;
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Layout of one cell, in canvas pixels.
struct Cell {
    w: usize,
    h: usize,
    zoom: usize,
    scale: usize,
    text_h: usize,
}

impl Cell {
    fn new(w: usize, h: usize, side: usize, max_lines: usize) -> Self {
        let scale = if w >= 200 { 2 } else { 1 };
        let zoom = ((w / 2) / side).max(1);
        let line_h = (GLYPH_H + 1) * scale;
        let text_h = (side * zoom).max(max_lines * line_h);
        Cell {
            w,
            h,
            zoom,
            scale,
            text_h,
        }
    }

    fn height(&self) -> usize {
        self.h + GAP + self.text_h
    }
}

/// Composes the sheet. `columns` are the column titles (reference first); every row must have
/// one tile per column and all images the same size. Returns linear RGB ready for
/// `write_image` (which applies the sRGB transfer function).
pub fn contact_sheet(columns: &[String], rows: &[Row], exposure: f32) -> Image {
    let (w, h) = rows
        .first()
        .and_then(|r| r.tiles.first())
        .map_or((1, 1), |t| (t.image.width, t.image.height));
    let side = crop_side(w, h);
    let max_lines = rows
        .iter()
        .flat_map(|r| r.tiles.iter().map(|t| t.lines.len()))
        .max()
        .unwrap_or(0);
    let cell = Cell::new(w, h, side, max_lines);
    let header = (GLYPH_H + 2) * cell.scale + GAP;
    let width = GAP + columns.len() * (w + GAP);
    let height = header + rows.len() * (cell.height() + GAP) + GAP;
    let mut canvas = Image::new(width, height, 3, 0.0);
    for p in canvas.data.chunks_exact_mut(3) {
        p.copy_from_slice(&BACKGROUND);
    }
    for (c, title) in columns.iter().enumerate() {
        let x = GAP + c * (w + GAP) + w.saturating_sub(text_width(title, cell.scale)) / 2;
        draw_text(&mut canvas, x, GAP, title, cell.scale, TEXT);
    }
    let gain = exposure.exp2();
    for (r, row) in rows.iter().enumerate() {
        let y0 = header + r * (cell.height() + GAP);
        for (c, tile) in row.tiles.iter().enumerate() {
            let x0 = GAP + c * (w + GAP);
            draw_tile(&mut canvas, &cell, x0, y0, tile, row.crop, gain);
            if c == 0 {
                outline(
                    &mut canvas,
                    x0 + row.crop.0,
                    y0 + row.crop.1,
                    row.crop.2,
                    MARK,
                );
            }
        }
    }
    canvas
}

fn draw_tile(
    canvas: &mut Image,
    cell: &Cell,
    x0: usize,
    y0: usize,
    tile: &Tile,
    crop: (usize, usize, usize),
    gain: f32,
) {
    let img = tile.image;
    for y in 0..cell.h.min(img.height) {
        for x in 0..cell.w.min(img.width) {
            let src = img.rgb(x, y);
            let dst = canvas.pixel_mut(x0 + x, y0 + y);
            for k in 0..3 {
                dst[k] = display(src[k], gain);
            }
        }
    }
    // The crop, magnified by pixel replication so single-pixel noise stays visible as such.
    let (cx, cy, side) = crop;
    let ys = y0 + cell.h + GAP;
    for y in 0..side * cell.zoom {
        for x in 0..side * cell.zoom {
            let (sx, sy) = (cx + x / cell.zoom, cy + y / cell.zoom);
            if sx < img.width && sy < img.height {
                let src = img.rgb(sx, sy);
                let dst = canvas.pixel_mut(x0 + x, ys + y);
                for k in 0..3 {
                    dst[k] = display(src[k], gain);
                }
            }
        }
    }
    let tx = x0 + side * cell.zoom + GAP;
    let line_h = (GLYPH_H + 1) * cell.scale;
    for (i, line) in tile.lines.iter().enumerate() {
        // Clip lines to the cell so long text never runs into the next column.
        let room = (x0 + cell.w).saturating_sub(tx) / (6 * cell.scale);
        let text: String = line.chars().take(room).collect();
        draw_text(canvas, tx, ys + i * line_h, &text, cell.scale, TEXT);
    }
}

/// A one-pixel square outline, clipped to the canvas.
fn outline(canvas: &mut Image, x: usize, y: usize, side: usize, colour: [f32; 3]) {
    let (x1, y1) = (x + side.saturating_sub(1), y + side.saturating_sub(1));
    let mut put = |px: usize, py: usize| {
        if px < canvas.width && py < canvas.height {
            canvas.pixel_mut(px, py).copy_from_slice(&colour);
        }
    };
    for i in x..=x1 {
        put(i, y);
        put(i, y1);
    }
    for j in y..=y1 {
        put(x, j);
        put(x1, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hardest_window_is_where_the_error_is() {
        let (w, h) = (40, 30);
        let mut err = vec![0.01; w * h];
        for y in 12..20 {
            for x in 25..33 {
                err[y * w + x] = 1.0;
            }
        }
        assert_eq!(hardest_window(&err, w, h, 8), (25, 12));
        // Uniform error: the first window.
        assert_eq!(hardest_window(&vec![1.0; w * h], w, h, 8), (0, 0));
        // NaN counts as no error rather than poisoning the sums.
        err[0] = f64::NAN;
        assert_eq!(hardest_window(&err, w, h, 8), (25, 12));
    }

    #[test]
    fn the_sheet_has_one_cell_per_row_and_column_with_images_in_place() {
        let a = Image::new(64, 48, 3, 0.5);
        let b = Image::new(64, 48, 3, 0.25);
        let rows: Vec<Row> = (0..2)
            .map(|_| Row {
                tiles: vec![
                    Tile {
                        image: &a,
                        lines: vec!["REF".into()],
                    },
                    Tile {
                        image: &b,
                        lines: vec!["X 1".into(), "Y 2".into()],
                    },
                ],
                crop: (4, 4, crop_side(64, 48)),
            })
            .collect();
        let sheet = contact_sheet(&["REFERENCE".into(), "ATROUS".into()], &rows, 0.0);
        assert_eq!(sheet.width, GAP + 2 * (64 + GAP));
        let cell = Cell::new(64, 48, 12, 2);
        let header = (GLYPH_H + 2) + GAP;
        assert_eq!(sheet.height, header + 2 * (cell.height() + GAP) + GAP);
        // Centre of the second column's first image is b's value; exposure 0 keeps it.
        let (x, y) = (GAP + 64 + GAP + 32, header + 24);
        assert_eq!(sheet.pixel(x, y), &[0.25, 0.25, 0.25]);
        // The crop outline is drawn on the reference only.
        assert_eq!(sheet.pixel(GAP + 4, header + 4), &MARK);
        assert_eq!(
            sheet.pixel(GAP + 64 + GAP + 4, header + 4),
            &[0.25, 0.25, 0.25]
        );
    }

    #[test]
    fn display_values_are_exposed_clamped_and_finite() {
        assert_eq!(display(0.25, 2.0), 0.5);
        assert_eq!(display(3.0, 1.0), 1.0);
        assert_eq!(display(f32::NAN, 1.0), 0.0);
    }
}
