//! What one rendered view shows, as the quality rules of a release judge it: the pixels
//! and nearest depth of every object instance, how much of the image its largest class
//! covers, how much of it has depth, and how much of the colour is blown out.

use serde::{Deserialize, Serialize};

use std::sync::LazyLock;

use super::raster::Frame;
use osmab_evaluator::ground_truth::{FRAME_STRIDE, POINT_STRIDE};

/// A frame is degenerate when one class covers more than this share of its pixels...
pub const DOMINANT_CLASS_LIMIT: f64 = 0.85;
/// ... or fewer than this share of its pixels have depth.
pub const MIN_VALID_DEPTH: f64 = 0.5;
/// A pixel is saturated when all three channels are at least this.
pub const SATURATED_LEVEL: u8 = 250;
/// A view is bare when objects (anything but the room's shell) cover less than this share
/// of it: a wall, a floor, an empty corner. Such a frame teaches a mapper nothing.
pub const BARE_OBJECT_FRACTION: f64 = 0.10;

/// Whether class id `id` is one of the room's shell (the class table's).
pub(crate) fn is_shell_id(id: usize) -> bool {
    static SHELL: LazyLock<Vec<bool>> = LazyLock::new(|| crate::classes::table().classes().iter().map(|c| c.role == crate::classes::Role::Shell).collect());
    SHELL.get(id).copied().unwrap_or(false)
}

/// One object instance in a view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Visible {
    pub instance_id: u16,
    pub pixels: u32,
    /// Nearest planar depth of its pixels, metres.
    pub nearest: f32,
}

/// What a view shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct View {
    /// Every instance with at least one pixel, by instance id.
    pub objects: Vec<Visible>,
    /// The largest share of the image one class covers.
    pub dominant_fraction: f64,
    /// The share of pixels with depth.
    pub valid_fraction: f64,
    /// The largest share of the image one object instance covers.
    pub largest_object_fraction: f64,
    /// The share of the image objects (classes not of the room's shell) cover.
    pub object_fraction: f64,
}

impl View {
    /// Measure the classes, instances and depth of `frame`.
    pub fn of(frame: &Frame) -> View {
        let n = frame.depth.len().max(1);
        let mut instances: Vec<(u32, f32)> = Vec::new();
        let mut classes: Vec<u32> = Vec::new();
        let mut valid = 0usize;
        for ((&depth, &class), &instance) in frame.depth.iter().zip(&frame.semantic).zip(&frame.instance) {
            if depth <= 0.0 {
                continue;
            }
            valid += 1;
            if classes.len() <= class as usize {
                classes.resize(class as usize + 1, 0);
            }
            classes[class as usize] += 1;
            if instance == 0 {
                continue;
            }
            if instances.len() <= instance as usize {
                instances.resize(instance as usize + 1, (0, f32::INFINITY));
            }
            let entry = &mut instances[instance as usize];
            entry.0 += 1;
            entry.1 = entry.1.min(depth);
        }
        View {
            objects: instances
                .iter()
                .enumerate()
                .filter(|(_, (pixels, _))| *pixels > 0)
                .map(|(id, &(pixels, nearest))| Visible { instance_id: id as u16, pixels, nearest })
                .collect(),
            dominant_fraction: classes.iter().copied().max().unwrap_or(0) as f64 / n as f64,
            valid_fraction: valid as f64 / n as f64,
            largest_object_fraction: instances.iter().map(|i| i.0).max().unwrap_or(0) as f64 / n as f64,
            object_fraction: classes.iter().enumerate().filter(|(c, _)| !is_shell_id(*c)).map(|(_, n)| *n as u64).sum::<u64>() as f64 / n as f64,
        }
    }

    /// Whether the view is degenerate or bare: no view to choose, or to turn past.
    pub fn bare(&self) -> bool {
        self.degenerate() || self.object_fraction < BARE_OBJECT_FRACTION
    }

    /// Whether the frame is dominated by one class or has too little depth.
    pub fn degenerate(&self) -> bool {
        self.dominant_fraction > DOMINANT_CLASS_LIMIT || self.valid_fraction < MIN_VALID_DEPTH
    }

    /// The pixels of instance `id` (0 when not visible).
    pub fn pixels_of(&self, id: u16) -> u32 {
        self.objects.binary_search_by_key(&id, |v| v.instance_id).map_or(0, |i| self.objects[i].pixels)
    }
}

/// How one object was observed along a sequence.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Observed {
    /// Frames in which it is visible.
    pub frames: usize,
    /// Camera positions (x, z) of its distinct viewpoints, in the order first reached.
    pub viewpoints: Vec<[f64; 2]>,
    /// Ground-truth points it leaves, estimated from its pixels in the ground-truth
    /// frames (every `FRAME_STRIDE`-th frame, every `POINT_STRIDE`-th pixel).
    pub points: f64,
    /// The nearest depth of its pixels over the sequence, metres.
    pub closest: Option<f64>,
}

/// When an observation counts as a viewpoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewpointRule {
    /// Full-resolution pixels the object must cover.
    pub min_pixels: f64,
    /// Positions closer than this (metres) are one viewpoint.
    pub separation: f64,
}

impl Observed {
    /// Add frame `index`, taken at `position`, where the object covers `pixels`
    /// (full-resolution) with nearest depth `nearest`.
    pub fn add(&mut self, index: usize, position: [f64; 2], pixels: f64, nearest: f64, rule: &ViewpointRule) {
        self.frames += 1;
        self.closest = Some(self.closest.map_or(nearest, |c| c.min(nearest)));
        if index % FRAME_STRIDE == 0 {
            self.points += pixels / POINT_STRIDE as f64;
        }
        if pixels >= rule.min_pixels && self.far_from_viewpoints(position, rule.separation) {
            self.viewpoints.push(position);
        }
    }

    /// Whether `position` is at least `separation` from every viewpoint so far.
    pub fn far_from_viewpoints(&self, position: [f64; 2], separation: f64) -> bool {
        self.viewpoints.iter().all(|v| ((v[0] - position[0]).powi(2) + (v[1] - position[1]).powi(2)).sqrt() >= separation)
    }
}

/// Classes (void excluded) with at least `min_pixels` pixels of valid depth in a frame
/// as written (semantic and 16-bit depth images): the same count whichever renderer
/// drew the frame.
pub fn visible_classes(semantic: &[u16], depth: &[u16], min_pixels: f64) -> u16 {
    let mut per_class: std::collections::BTreeMap<u16, u32> = std::collections::BTreeMap::new();
    for (&c, &d) in semantic.iter().zip(depth) {
        if c != 0 && d > 0 {
            *per_class.entry(c).or_default() += 1;
        }
    }
    per_class.values().filter(|&&p| p as f64 >= min_pixels).count().min(u16::MAX as usize) as u16
}

/// A 64-bit digest of bytes (for telling frames apart, not for security).
pub fn digest64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325 ^ bytes.len() as u64;
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        h = (h ^ u64::from_le_bytes(c.try_into().expect("8 bytes"))).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(29);
    }
    for &b in chunks.remainder() {
        h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
    }
    h ^ (h >> 31)
}

/// Exposure of a colour image (RGB, 3 bytes a pixel): the share of saturated pixels and
/// the mean Rec. 601 luma (0–255).
pub fn exposure(rgb: &[u8]) -> (f64, f64) {
    let n = (rgb.len() / 3).max(1);
    let mut saturated = 0usize;
    let mut luma = 0u64;
    for p in rgb.chunks_exact(3) {
        if p[0] >= SATURATED_LEVEL && p[1] >= SATURATED_LEVEL && p[2] >= SATURATED_LEVEL {
            saturated += 1;
        }
        luma += 299 * p[0] as u64 + 587 * p[1] as u64 + 114 * p[2] as u64;
    }
    (saturated as f64 / n as f64, luma as f64 / 1000.0 / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_counts_instances_classes_and_depth() {
        let frame = Frame {
            width: 4,
            height: 1,
            rgb: vec![255, 255, 255, 0, 0, 0, 250, 251, 249, 100, 100, 100],
            depth: vec![1.0, 2.0, 0.5, 0.0],
            semantic: vec![3, 3, 7, 0],
            instance: vec![5, 5, 9, 0],
            ..Default::default()
        };
        let view = View::of(&frame);
        assert_eq!(view.objects, vec![Visible { instance_id: 5, pixels: 2, nearest: 1.0 }, Visible { instance_id: 9, pixels: 1, nearest: 0.5 }]);
        assert_eq!((view.dominant_fraction, view.valid_fraction, view.largest_object_fraction), (0.5, 0.75, 0.5));
        assert!(!view.degenerate());
        assert_eq!(view.pixels_of(9), 1);
        assert_eq!(view.pixels_of(4), 0);
        let (saturated, luma) = exposure(&frame.rgb);
        assert_eq!(saturated, 0.25, "one pixel has every channel at 250 or more; 249 is not");
        assert!((luma - (255.0 + 0.0 + 250.0 * 0.299 + 251.0 * 0.587 + 249.0 * 0.114 + 100.0) / 4.0).abs() < 1e-9);
    }
}
