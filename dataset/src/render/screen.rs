//! The triangles a frame draws, after clipping and projection, kept by task of the
//! transform that made them: each task's triangles sorted by the bands of rows they touch
//! (so each band of the visibility pass visits only its own, and no step gathers them all
//! in one place), and one `u32` that names any of them for the per-pixel hit buffer.

/// Rows per band: the visibility pass gives each band of rows to one thread.
pub(super) const BAND: usize = 16;

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

impl ScreenTriangle {
    /// The corners of its screen box: smallest x and y, largest x and y (`f64::min` and
    /// `max` pass over a NaN coordinate).
    pub(super) fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        let [a, b, c] = self.xy;
        let axis = |k: usize| (a[k].min(b[k]).min(c[k]), a[k].max(b[k]).max(c[k]));
        let ((xmin, xmax), (ymin, ymax)) = (axis(0), axis(1));
        ([xmin, ymin], [xmax, ymax])
    }
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
    /// Sorts the triangles' places by the bands of rows they touch in an image of `width` ×
    /// `height` pixels.
    pub(super) fn bin(&mut self, width: u32, height: u32) {
        let bands = (height as usize).div_ceil(BAND);
        let Part { triangles, binned, band_starts, cursors } = self;
        band_starts.clear();
        band_starts.resize(bands + 1, 0);
        for t in triangles.iter() {
            for band in bands_touched(t, width, height) {
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
            for band in bands_touched(t, width, height) {
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

/// The bands of rows a screen triangle's box touches in an image of `width` × `height`
/// pixels (none when it misses the image).
fn bands_touched(t: &ScreenTriangle, width: u32, height: u32) -> std::ops::RangeInclusive<usize> {
    let (wf, hf) = (width as f64, height as f64);
    let ([xmin, ymin], [xmax, ymax]) = t.bounds();
    let off_the_image = ymax < 0.0 || ymin > hf - 1.0 || xmax < 0.0 || xmin > wf - 1.0;
    if width == 0 || height == 0 || off_the_image || !(ymin.is_finite() && ymax.is_finite()) {
        #[allow(clippy::reversed_empty_ranges)]
        return 1..=0;
    }
    let first = (ymin.ceil().max(0.0) as usize) / BAND;
    let last = ((ymax.floor().min(hf - 1.0)) as usize) / BAND;
    first..=last
}

/// A frame's clipped, projected triangles, by task of the transform, and how one `u32`
/// (what `Frame::hit` holds) names one of them: the triangles numbered across the parts in
/// order, each part's first number kept.
#[derive(Debug, Clone, Default)]
pub(super) struct Screen {
    pub(super) parts: Vec<Part>,
    /// The number of each part's first triangle, and after them the count of all.
    starts: Vec<u32>,
}

impl Screen {
    /// Numbers the triangles as the transform left them in the parts.
    pub(super) fn index_parts(&mut self) {
        self.starts = numbering(self.parts.iter().map(|p| p.triangles.len()));
    }

    /// The number of the triangle at `place` in `part`.
    pub(super) fn index(&self, part: usize, place: u32) -> u32 {
        self.starts[part] + place
    }

    /// Looks up triangles by number.
    pub(super) fn finder(&self) -> Finder<'_> {
        Finder { screen: self, part: 0 }
    }
}

/// The number of each part's first triangle, given the parts' lengths, and the count of
/// all. Every number stays below `u32::MAX`, which stands for no hit: a frame of more
/// triangles is refused.
fn numbering(lengths: impl IntoIterator<Item = usize>) -> Vec<u32> {
    let mut starts = vec![0u32];
    let mut next = 0u64;
    for length in lengths {
        next += length as u64;
        assert!(next <= u64::from(u32::MAX), "more than {} clipped triangles in one frame are more than its hits can index", u32::MAX);
        starts.push(next as u32);
    }
    starts
}

/// Finds screen triangles by number, remembering the part of the last one found:
/// neighbouring pixels mostly hit the same part.
pub(super) struct Finder<'a> {
    screen: &'a Screen,
    part: usize,
}

impl<'a> Finder<'a> {
    /// The triangle numbered `index` (a number `Screen::index` gave).
    #[inline]
    pub(super) fn triangle(&mut self, index: u32) -> &'a ScreenTriangle {
        let starts = &self.screen.starts;
        if !(starts[self.part] <= index && index < starts[self.part + 1]) {
            self.part = starts.partition_point(|&start| start <= index) - 1;
        }
        &self.screen.parts[self.part].triangles[(index - starts[self.part]) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        part.bin(40, 64);
        assert_eq!(part.in_band(0), [0, 1, 6]);
        assert_eq!(part.in_band(1), [1, 6]);
        assert_eq!(part.in_band(2), [1]);
        assert_eq!(part.in_band(3), [3]);
        // Binning again (the next frame) starts afresh.
        part.triangles.truncate(1);
        part.bin(40, 64);
        assert_eq!([0, 1, 2, 3].map(|band| part.in_band(band).len()), [1, 0, 0, 0]);
        // An image without rows has no bands to bin into.
        part.bin(40, 0);
        assert_eq!(part.band_starts, [0]);
    }

    #[test]
    fn a_screen_index_names_every_triangle_of_every_part_in_any_order_of_lookups() {
        let sizes = [3, 0, 1000, 1, 0, 1024];
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
        let mut screen = Screen { parts, starts: Vec::new() };
        screen.index_parts();
        let mut named = Vec::new();
        for (p, &n) in sizes.iter().enumerate() {
            named.extend((0..n).map(|place| screen.index(p, place)));
        }
        // Numbered in order, each triangle once: the numbers are 0, 1, 2, …
        assert_eq!(named, (0..sizes.iter().sum::<u32>()).collect::<Vec<_>>());
        // Looked up in order, backwards and jumping between parts.
        let mut finder = screen.finder();
        let mut jumping = named.clone();
        jumping.sort_by_key(|&i| (i * 7919) % 2029);
        for order in [named.clone(), named.iter().rev().copied().collect(), jumping] {
            for index in order {
                assert_eq!(finder.triangle(index).source, index + 1, "triangle {index}");
            }
        }
    }

    #[test]
    fn a_frame_numbers_up_to_one_triangle_less_than_a_u32_can_hold() {
        let most = u32::MAX as usize;
        assert_eq!(numbering([most - 1, 0, 1]), [0, u32::MAX - 1, u32::MAX - 1, u32::MAX]);
        let refused = std::panic::catch_unwind(|| numbering([most, 1]));
        let message = *refused.expect_err("one more is refused").downcast::<String>().expect("a message");
        assert!(message.contains("more than its hits can index"), "{message}");
    }
}
