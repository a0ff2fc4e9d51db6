//! One frame at the mapper's working resolution: the colour of each block of pixels, the
//! depth and world point at its centre, and (val scenes only) the class seen there.

use osmab_evaluator::Result;
use osmab_evaluator::formats::image::{read_jpeg_rgb, read_png_gray16};
use osmab_evaluator::formats::sequence::frame_path;

use crate::public::PublicSequence;

/// The working image is at most this wide: a frame is read in square blocks of pixels.
pub const WORK_WIDTH: u32 = 160;
/// Depths beyond this many metres are not used (too few pixels to classify at that range).
pub const MAX_DEPTH_M: f32 = 8.0;

/// A frame reduced to blocks.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Blocks across.
    pub width: usize,
    /// Blocks down.
    pub height: usize,
    /// Mean colour of each block, each channel in [0, 1].
    pub rgb: Vec<[f32; 3]>,
    /// Standard deviation of the luminance inside each block (its fine texture).
    pub texture: Vec<f32>,
    /// Depth in metres at each block's centre pixel; 0 where there is none.
    pub depth: Vec<f32>,
    /// The world point at each block's centre pixel (meaningless where depth is 0).
    pub world: Vec<[f32; 3]>,
    /// The camera's position in the world.
    pub eye: [f32; 3],
    /// Class id at each block's centre pixel, for frames whose semantics may be read.
    pub classes: Option<Vec<u16>>,
}

impl Frame {
    /// Whether block `i` has a usable depth.
    pub fn valid(&self, i: usize) -> bool {
        self.depth[i] > 0.0
    }
}

/// The side of a block for `sequence`'s images.
pub fn block_side(sequence: &PublicSequence) -> usize {
    sequence.camera.image_width.div_ceil(WORK_WIDTH) as usize
}

/// Read frame `index` of `sequence`; `with_classes` reads its semantic frame too (only
/// allowed where the sequence is labelled).
pub fn read_frame(sequence: &PublicSequence, index: usize, with_classes: bool) -> Result<Frame> {
    let camera = &sequence.camera;
    let size = Some((camera.image_width, camera.image_height));
    let colour = read_jpeg_rgb(&frame_path(&sequence.dir, "frame", index), size)?;
    let depth = read_png_gray16(&frame_path(&sequence.dir, "depth", index), size)?;
    let semantic = if with_classes && sequence.labelled { Some(read_png_gray16(&frame_path(&sequence.dir, "semantic", index), size)?.pixels) } else { None };
    let side = block_side(sequence);
    let (full_w, full_h) = (camera.image_width as usize, camera.image_height as usize);
    let (width, height) = (full_w / side, full_h / side);
    let pose = &sequence.poses[index];
    let mut frame = Frame {
        width,
        height,
        rgb: Vec::with_capacity(width * height),
        texture: Vec::with_capacity(width * height),
        depth: Vec::with_capacity(width * height),
        world: Vec::with_capacity(width * height),
        eye: [pose[0][3] as f32, pose[1][3] as f32, pose[2][3] as f32],
        classes: semantic.as_ref().map(|_| Vec::with_capacity(width * height)),
    };
    for by in 0..height {
        for bx in 0..width {
            let (mean, texture) = block_mean(&colour.pixels, full_w, bx * side, by * side, side);
            frame.rgb.push(mean);
            frame.texture.push(texture);
            let (u, v) = (bx * side + side / 2, by * side + side / 2);
            let centre = v * full_w + u;
            let z = depth.pixels[centre] as f32 / camera.png_depth_scale as f32;
            let z = if z > 0.0 && z <= MAX_DEPTH_M { z } else { 0.0 };
            frame.depth.push(z);
            frame.world.push(back_project(sequence, index, u, v, z));
            if let (Some(classes), Some(semantic)) = (frame.classes.as_mut(), semantic.as_ref()) {
                classes.push(semantic[centre]);
            }
        }
    }
    Ok(frame)
}

/// The mean colour of a block and the standard deviation of its luminance.
fn block_mean(pixels: &[u8], full_w: usize, x0: usize, y0: usize, side: usize) -> ([f32; 3], f32) {
    let (mut sum, mut luma, mut luma2) = ([0u32; 3], 0.0f32, 0.0f32);
    for y in y0..y0 + side {
        for x in x0..x0 + side {
            let p = 3 * (y * full_w + x);
            for c in 0..3 {
                sum[c] += pixels[p + c] as u32;
            }
            let l = luminance([pixels[p], pixels[p + 1], pixels[p + 2]].map(|v| v as f32 / 255.0));
            luma += l;
            luma2 += l * l;
        }
    }
    let n = (side * side) as f32;
    let mean_luma = luma / n;
    (sum.map(|s| s as f32 / (n * 255.0)), (luma2 / n - mean_luma * mean_luma).max(0.0).sqrt())
}

/// Rec. 601 luma of an RGB colour in [0, 1].
pub fn luminance(rgb: [f32; 3]) -> f32 {
    0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
}

fn back_project(sequence: &PublicSequence, index: usize, u: usize, v: usize, z: f32) -> [f32; 3] {
    let camera = &sequence.camera;
    let m = &sequence.poses[index];
    let z = z as f64;
    let x = (u as f64 - camera.cx) * z / camera.fx;
    let y = (v as f64 - camera.cy) * z / camera.fy;
    std::array::from_fn(|r| (m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3]) as f32)
}
