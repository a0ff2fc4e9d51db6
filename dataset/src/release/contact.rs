//! Contact sheets: a grid of thumbnails of one sequence, for a person to look at.

use std::path::Path;

use osmab_evaluator::formats::image::read_jpeg_rgb;
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::{InputError, Result};

/// Thumbnails per side of the grid, and thumbnail width.
const GRID: usize = 4;
const THUMB_WIDTH: usize = 200;

/// Write up to 16 evenly spaced frames of the sequence in `sequence_dir` (with `frames`
/// frames) as one PNG.
pub fn write_contact_sheet(sequence_dir: &Path, frames: usize, out: &Path) -> Result<()> {
    if frames == 0 {
        return Ok(());
    }
    let picks: Vec<usize> =
        (0..GRID * GRID).map(|k| k * frames / (GRID * GRID)).filter(|&i| i < frames).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let first = read_jpeg_rgb(&frame_path(sequence_dir, "frame", picks[0]), None)?;
    let scale = first.width as f64 / THUMB_WIDTH as f64;
    let thumb_h = ((first.height as f64 / scale).round() as usize).max(1);
    let (sheet_w, sheet_h) = (GRID * THUMB_WIDTH, GRID * thumb_h);
    let mut sheet = vec![32u8; sheet_w * sheet_h * 3];
    for (k, &i) in picks.iter().enumerate() {
        let image = read_jpeg_rgb(&frame_path(sequence_dir, "frame", i), Some((first.width, first.height)))?;
        let (ox, oy) = ((k % GRID) * THUMB_WIDTH, (k / GRID) * thumb_h);
        for y in 0..thumb_h {
            let sy = ((y as f64 * scale) as usize).min(image.height as usize - 1);
            for x in 0..THUMB_WIDTH {
                let sx = ((x as f64 * scale) as usize).min(image.width as usize - 1);
                let s = 3 * (sy * image.width as usize + sx);
                let d = 3 * ((oy + y) * sheet_w + ox + x);
                sheet[d..d + 3].copy_from_slice(&image.pixels[s..s + 3]);
            }
        }
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).map_err(|e| InputError::io(dir, &e))?;
    }
    let file = std::fs::File::create(out).map_err(|e| InputError::io(out, &e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), sheet_w as u32, sheet_h as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let err = |e: png::EncodingError| InputError::new(out, "(png)", e.to_string());
    encoder.write_header().map_err(err)?.write_image_data(&sheet).map_err(err)
}
