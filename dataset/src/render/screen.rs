//! The triangles a frame draws, after clipping and projection, kept by task of the
//! transform that made them: each task's triangles sorted by the bands of rows they touch
//! (so each band of the visibility pass visits only its own, and no step gathers them all
//! in one place), and one `u32` that names any of them for the per-pixel hit buffer.

use super::raster::{BAND, Camera};

/// A triangle after clipping and projection: screen x, y and 1/z per vertex, plus the
/// source triangle and each vertex's barycentric coordinates in it.
#[derive(Debug, Clone, Copy)]
pub(super) struct ScreenTriangle {
    /// Screen positions in f64: clipped floor and wall triangles reach ~10⁵ pixels.
    pub(super) xy: [[f64; 2]; 3],
    pub(super) inv_z: [f32; 3],
    /// 1/z over the screen, from the source triangle's plane: a·x + b·y + c.
    pub(super) inv_z_plane: [f64; 3],
    /// Barycentric coordinates (in the source triangle) of each vertex.
    pub(super) bary: [[f32; 3]; 3],
    pub(super) source: u32,
}

/// The clipped, projected triangles of one task of the transform, and their places in it
/// sorted by the bands of rows they touch.
#[derive(Debug, Clone, Default)]
pub(super) struct Part {
    pub(super) triangles: Vec<ScreenTriangle>,
    /// Places in `triangles`, band by band, each band's in order.
    binned: Vec<u32>,
    /// Band b's places are `binned[band_starts[b]..band_starts[b + 1]]`.
    band_starts: Vec<u32>,
    /// Where the next place of each band goes, while binning.
    cursors: Vec<u32>,
}

impl Part {
    /// Sorts the triangles' places by the bands of `bands` of rows of the image they touch.
    pub(super) fn bin(&mut self, bands: usize, camera: &Camera) {
        let Part { triangles, binned, band_starts, cursors } = self;
        band_starts.clear();
        band_starts.resize(bands + 1, 0);
        for t in triangles.iter() {
            for band in bands_touched(t, camera) {
                band_starts[band + 1] += 1;
            }
        }
        for band in 0..bands {
            band_starts[band + 1] += band_starts[band];
        }
        cursors.clear();
        cursors.extend_from_slice(&band_starts[..bands]);
        binned.clear();
        binned.resize(band_starts[bands] as usize, 0);
        for (place, t) in triangles.iter().enumerate() {
            for band in bands_touched(t, camera) {
                binned[cursors[band] as usize] = place as u32;
                cursors[band] += 1;
            }
        }
    }

    /// The places of the triangles that touch `band`, in order.
    pub(super) fn in_band(&self, band: usize) -> &[u32] {
        &self.binned[self.band_starts[band] as usize..self.band_starts[band + 1] as usize]
    }
}

/// The bands of rows a screen triangle's box touches (none when it misses the image).
fn bands_touched(t: &ScreenTriangle, camera: &Camera) -> std::ops::RangeInclusive<usize> {
    let (wf, hf) = (camera.width as f64, camera.height as f64);
    let ys = [t.xy[0][1], t.xy[1][1], t.xy[2][1]];
    let xs = [t.xy[0][0], t.xy[1][0], t.xy[2][0]];
    let (ymin, ymax) = (ys[0].min(ys[1]).min(ys[2]), ys[0].max(ys[1]).max(ys[2]));
    let (xmin, xmax) = (xs[0].min(xs[1]).min(xs[2]), xs[0].max(xs[1]).max(xs[2]));
    if ymax < 0.0 || ymin > hf - 1.0 || xmax < 0.0 || xmin > wf - 1.0 || !(ymin.is_finite() && ymax.is_finite()) {
        #[allow(clippy::reversed_empty_ranges)]
        return 1..=0;
    }
    let first = (ymin.ceil().max(0.0) as usize) / BAND;
    let last = ((ymax.floor().min(hf - 1.0)) as usize) / BAND;
    first..=last
}

/// A frame's clipped, projected triangles, by task of the transform, and how one `u32`
/// (what `Frame::hit` holds) names one of them: its part in the high bits, its place in
/// the part in the low `place_bits`.
#[derive(Debug, Clone, Default)]
pub(super) struct Screen {
    pub(super) parts: Vec<Part>,
    place_bits: u32,
}

impl Screen {
    /// Fits the index to the parts as the transform left them.
    pub(super) fn index_parts(&mut self) {
        let most = self.parts.iter().map(|p| p.triangles.len()).max().unwrap_or(0);
        self.place_bits = usize::BITS - most.leading_zeros();
        // Every index stays below u32::MAX, which stands for no hit.
        assert!(
            (self.parts.len() as u64) << self.place_bits <= u64::from(u32::MAX),
            "{} parts of up to {most} screen triangles are more than a frame's hits can index",
            self.parts.len()
        );
    }

    pub(super) fn index(&self, part: usize, place: u32) -> u32 {
        (part as u32) << self.place_bits | place
    }

    pub(super) fn triangle(&self, index: u32) -> &ScreenTriangle {
        let place = index & ((1u64 << self.place_bits) - 1) as u32;
        &self.parts[(index >> self.place_bits) as usize].triangles[place as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(width: u32, height: u32) -> Camera {
        Camera { width, height, fx: 100.0, fy: 100.0, cx: 0.0, cy: 0.0, pose: nalgebra::Matrix4::identity() }
    }

    /// A triangle whose box spans the rows `top..=bottom` (as floats) and columns 5 to 20.
    fn spanning_rows(top: f64, bottom: f64, source: u32) -> ScreenTriangle {
        ScreenTriangle {
            xy: [[10.0, top], [20.0, bottom], [5.0, bottom]],
            inv_z: [1.0; 3],
            inv_z_plane: [0.0, 0.0, 1.0],
            bary: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            source,
        }
    }

    #[test]
    fn each_band_lists_in_order_the_triangles_whose_box_touches_it() {
        // 64 rows: four bands of 16.
        let mut part = Part {
            triangles: vec![
                spanning_rows(0.0, 5.0, 0),
                spanning_rows(10.0, 40.0, 1),
                spanning_rows(-30.0, -1.0, 2), // above the image
                spanning_rows(50.0, 200.0, 3),
                spanning_rows(15.5, 15.9, 4),         // between two rows: covers no pixel centre
                spanning_rows(f64::NAN, f64::NAN, 5), // not a position
                spanning_rows(2.0, 20.0, 6),
            ],
            ..Part::default()
        };
        part.bin(4, &camera(40, 64));
        assert_eq!(part.in_band(0), [0, 1, 6]);
        assert_eq!(part.in_band(1), [1, 6]);
        assert_eq!(part.in_band(2), [1]);
        assert_eq!(part.in_band(3), [3]);
        // Binning again (the next frame) starts afresh.
        part.triangles.truncate(1);
        part.bin(4, &camera(40, 64));
        assert_eq!([0, 1, 2, 3].map(|band| part.in_band(band).len()), [1, 0, 0, 0]);
    }

    #[test]
    fn a_screen_index_names_every_triangle_of_every_part_and_never_means_no_hit() {
        let sizes = [3, 0, 1000, 1, 1024];
        let mut source = 0;
        let parts = sizes
            .iter()
            .map(|&n| Part {
                triangles: (0..n)
                    .map(|_| {
                        source += 1;
                        spanning_rows(0.0, 1.0, source)
                    })
                    .collect(),
                ..Part::default()
            })
            .collect();
        let mut screen = Screen { parts, place_bits: 0 };
        screen.index_parts();
        let mut names = std::collections::BTreeSet::new();
        let mut expected_source = 0;
        for (p, &n) in sizes.iter().enumerate() {
            for place in 0..n {
                expected_source += 1;
                let index = screen.index(p, place);
                assert_ne!(index, u32::MAX);
                assert_eq!(screen.triangle(index).source, expected_source, "part {p}, place {place}");
                names.insert(index);
            }
        }
        assert_eq!(names.len(), sizes.iter().sum::<u32>() as usize);
    }

    #[test]
    #[should_panic(expected = "more than a frame's hits can index")]
    fn more_triangles_than_a_hit_can_name_are_refused() {
        // 2¹⁷ parts, one of 2¹⁵ triangles: names would need 17 + 16 bits.
        let mut parts = vec![Part::default(); 1 << 17];
        parts[0].triangles = vec![spanning_rows(0.0, 1.0, 0); 1 << 15];
        Screen { parts, place_bits: 0 }.index_parts();
    }
}
