//! The Z-order (Morton) curve that puts points in an order visiting neighbours in space one
//! after another: 30-bit keys over a box, sorted by a parallel radix sort. The
//! nearest-neighbour association visits its queries in this order, block by block
//! ([`super::nearest::NearestIndex::nearest_by_block`]), and a cloud scored against several
//! maps is put in it once ([`z_order`]).

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

/// Bits per axis of a Z-order key (3 × 10 = 30 bits: 1,024 cells per axis).
const KEY_BITS: u32 = 10;

/// Spread the low 10 bits of `v` to every third bit.
#[inline(always)]
fn spread_bits(v: u32) -> u32 {
    let mut x = v & 0x3FF;
    x = (x | (x << 16)) & 0x030000FF;
    x = (x | (x << 8)) & 0x0300F00F;
    x = (x | (x << 4)) & 0x030C30C3;
    x = (x | (x << 2)) & 0x09249249;
    x
}

/// A grid of `2^KEY_BITS` cells per axis over a box, numbering cells along a Z-order
/// (Morton) curve.
pub(super) struct ZGrid {
    min: [f32; 3],
    /// Cells per unit length along each axis.
    scale: [f32; 3],
}

/// The last cell's number along an axis.
const LAST_CELL: f32 = ((1u32 << KEY_BITS) - 1) as f32;

impl ZGrid {
    pub(super) fn over(min: [f32; 3], max: [f32; 3]) -> Self {
        let scale = std::array::from_fn(|a| if max[a] > min[a] { LAST_CELL / (max[a] - min[a]) } else { 0.0 });
        Self { min, scale }
    }

    /// The cell of `q` along the curve (points outside the box go to its faces).
    #[inline(always)]
    fn key(&self, q: &[f32; 3]) -> u32 {
        let cell = |a: usize| ((q[a] - self.min[a]) * self.scale[a]).clamp(0.0, LAST_CELL) as u32;
        spread_bits(cell(0)) | (spread_bits(cell(1)) << 1) | (spread_bits(cell(2)) << 2)
    }
}

/// The order visiting `points` along a Z-order curve over their own bounding box (points
/// of one cell of the curve in their input order): `points[order[0]]`, `points[order[1]]`, ….
pub fn z_order(points: &[[f32; 3]]) -> Vec<u32> {
    assert!(points.len() < u32::MAX as usize, "too many points for 32-bit indices");
    let (min, max) = crate::bounds::bounding_box(points);
    let mut keys = ZOrderKeys::default();
    keys.sort(&ZGrid::over(min, max), points);
    keys.sorted.into_par_iter().map(|key| position_of(&key) as u32).collect()
}

/// Where the query of a sorted key is in its block (the key's low half).
#[inline(always)]
pub(super) fn position_of(key: &AtomicU64) -> usize {
    (key.load(Relaxed) & 0xFFFF_FFFF) as usize
}

/// Queries' Z-order keys — the cell's number along the curve in the high half, the
/// query's position in the low half, so no two are equal — sorted by a parallel
/// least-significant-digit radix sort on the cell number's [`KEY_DIGITS`] digits of
/// [`DIGIT_BITS`] bits, between two buffers of 8 bytes a query. The buffers are atomics
/// only so that threads can store into disjoint slots of one buffer: relaxed loads and
/// stores of them are plain moves.
#[derive(Default)]
pub(super) struct ZOrderKeys {
    /// The keys in order, after [`ZOrderKeys::sort`].
    pub(super) sorted: Vec<AtomicU64>,
    /// The other buffer of the sort, free after it (answers are kept there).
    pub(super) spare: Vec<AtomicU64>,
}

/// Bits of the cell number sorted in one pass: 1,024 buckets, whose write positions stay in cache.
const DIGIT_BITS: u32 = 10;
/// Passes of the sort: a digit per pass covers the whole cell number.
const KEY_DIGITS: u32 = 3 * KEY_BITS / DIGIT_BITS;
const _: () = assert!(KEY_DIGITS * DIGIT_BITS == 3 * KEY_BITS && KEY_DIGITS % 2 == 1, "an odd number of whole digits");

impl ZOrderKeys {
    /// Sort the keys of `queries` on `grid` into `self.sorted`.
    pub(super) fn sort(&mut self, grid: &ZGrid, queries: &[[f32; 3]]) {
        const BUCKETS: usize = 1 << DIGIT_BITS;
        for buffer in [&mut self.sorted, &mut self.spare] {
            if buffer.len() != queries.len() {
                buffer.clear();
                buffer.resize_with(queries.len(), || AtomicU64::new(0));
            }
        }
        // One contiguous part a thread; each bucket takes the parts' keys in part order,
        // so every pass is stable.
        let part = queries.len().div_ceil(rayon::current_num_threads()).max(1 << 14);
        self.spare.par_chunks_mut(part).zip(queries.par_chunks(part)).enumerate().for_each(|(p, (keys, qs))| {
            for (i, (key, q)) in keys.iter_mut().zip(qs).enumerate() {
                *key.get_mut() = (u64::from(grid.key(q)) << 32) | (p * part + i) as u64;
            }
        });
        // An odd number of passes from `spare` ends in `sorted`.
        let (mut from, mut to) = (&self.spare, &self.sorted);
        for pass in 0..KEY_DIGITS {
            let shift = 32 + pass * DIGIT_BITS;
            let digit = move |key: &AtomicU64| ((key.load(Relaxed) >> shift) as usize) & (BUCKETS - 1);
            let counts: Vec<[u32; BUCKETS]> = from
                .par_chunks(part)
                .map(|keys| {
                    let mut counts = [0u32; BUCKETS];
                    for key in keys {
                        counts[digit(key)] += 1;
                    }
                    counts
                })
                .collect();
            let mut next_slots = counts.clone();
            let mut next = 0u32;
            for bucket in 0..BUCKETS {
                for (slots, counts) in next_slots.iter_mut().zip(&counts) {
                    slots[bucket] = next;
                    next += counts[bucket];
                }
            }
            from.par_chunks(part).zip(next_slots.into_par_iter()).for_each(|(keys, mut next)| {
                for key in keys {
                    let slot = &mut next[digit(key)];
                    to[*slot as usize].store(key.load(Relaxed), Relaxed);
                    *slot += 1;
                }
            });
            (from, to) = (to, from);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radix_sorted_keys_are_the_keys_in_order_with_one_cells_queries_in_input_order() {
        // 100,000 queries on 997 places: most share their cell with many others, so both
        // the cells' order and the input order within a cell are checked, across parts.
        let points: Vec<[f32; 3]> = (0..100_000u32)
            .map(|i| {
                let place = i.wrapping_mul(2_654_435_761) % 997;
                [(place % 10) as f32 * 0.37, (place / 10 % 10) as f32 * 1.1, (place / 100) as f32 * 0.05]
            })
            .collect();
        let grid = ZGrid::over([0.0; 3], [4.0, 11.0, 0.5]);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().expect("a pool");
        let mut keys = ZOrderKeys::default();
        pool.install(|| keys.sort(&grid, &points));
        let sorted: Vec<u64> = keys.sorted.iter().map(|key| key.load(Relaxed)).collect();
        let mut expected: Vec<u64> = points.iter().enumerate().map(|(i, q)| (u64::from(grid.key(q)) << 32) | i as u64).collect();
        expected.sort_unstable();
        assert_eq!(sorted, expected);
        // A second, shorter sort with the same buffers.
        pool.install(|| keys.sort(&grid, &points[..40_000]));
        assert_eq!(keys.sorted.len(), 40_000);
        assert!(keys.sorted.windows(2).all(|w| w[0].load(Relaxed) < w[1].load(Relaxed)), "increasing keys");
    }
}
