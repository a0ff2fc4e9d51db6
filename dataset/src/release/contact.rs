//! Contact sheets, for a person to look at: a grid of thumbnails of one sequence, and an
//! overview of the release — every scene's preview frame under every lighting.

use std::path::{Path, PathBuf};

use osmab_evaluator::formats::image::{RgbImage, read_jpeg_rgb, write_png_rgb};
use osmab_evaluator::formats::sequence::frame_path;
use osmab_evaluator::scores::ReleaseLighting;
use osmab_evaluator::{InputError, Result};

use crate::render::sequence::SequenceSummary;

/// Thumbnails per side of a sequence's grid, and thumbnail width.
const GRID: usize = 4;
const THUMB_WIDTH: usize = 200;
/// Gap between thumbnails of the overview, pixels.
const GAP: usize = 4;

/// Write up to 16 frames of the sequence in `sequence_dir` as one PNG: evenly spaced
/// over the frames that are not degenerate (a sheet shows what the sequence is about,
/// not its few frames of bare wall), over all frames when too few are left.
pub fn write_contact_sheet(sequence_dir: &Path, summary: &SequenceSummary, out: &Path) -> Result<()> {
    let frames = summary.frames;
    if frames == 0 {
        return Ok(());
    }
    let telling: Vec<usize> = (0..frames).filter(|&i| summary.per_frame.get(i).is_none_or(|m| !m.degenerate())).collect();
    let pool: Vec<usize> = if telling.len() >= GRID * GRID { telling } else { (0..frames).collect() };
    let picks: Vec<usize> = (0..GRID * GRID).map(|k| pool[k * pool.len() / (GRID * GRID)]).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let paths: Vec<Option<PathBuf>> = picks.iter().map(|&i| Some(frame_path(sequence_dir, "frame", i))).collect();
    write_grid(&paths, GRID, 0, out)
}

/// Write the overview of a release: one row per scene, one column per lighting, each
/// cell the frame `preview` (row's frame index) of `sequences/<lighting>/<scene>`.
pub fn write_overview(release: &Path, scenes: &[(String, usize)], lightings: &[ReleaseLighting], out: &Path) -> Result<()> {
    let paths: Vec<Option<PathBuf>> = scenes
        .iter()
        .flat_map(|(scene, preview)| lightings.iter().map(move |l| Some(frame_path(&release.join("sequences").join(l.name()).join(scene), "frame", *preview))))
        .collect();
    write_grid(&paths, lightings.len().max(1), GAP, out)
}

/// Thumbnails of the JPEG frames `paths` (all of one size; `None` leaves a cell empty),
/// `columns` to a row, `gap` pixels apart, as one PNG.
fn write_grid(paths: &[Option<PathBuf>], columns: usize, gap: usize, out: &Path) -> Result<()> {
    let Some(first_path) = paths.iter().flatten().next() else { return Ok(()) };
    let first = read_jpeg_rgb(first_path, None)?;
    let scale = first.width as f64 / THUMB_WIDTH as f64;
    let thumb_h = ((first.height as f64 / scale).round() as usize).max(1);
    let rows = paths.len().div_ceil(columns);
    let (sheet_w, sheet_h) = (columns * THUMB_WIDTH + (columns - 1) * gap, rows * thumb_h + rows.saturating_sub(1) * gap);
    let mut sheet = vec![32u8; sheet_w * sheet_h * 3];
    for (k, path) in paths.iter().enumerate() {
        let Some(path) = path else { continue };
        let image = read_jpeg_rgb(path, Some((first.width, first.height)))?;
        let (ox, oy) = ((k % columns) * (THUMB_WIDTH + gap), (k / columns) * (thumb_h + gap));
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
    write_png_rgb(out, &RgbImage { width: sheet_w as u32, height: sheet_h as u32, pixels: sheet })
}
