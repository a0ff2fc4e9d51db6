//! The distinct class ids of a large label array, fast: class ids are small
//! non-negative integers, so a dense table counts them in one pass over
//! millions of points (a tree set took half a second at 20 M points).

use std::collections::BTreeSet;

use rayon::prelude::*;

/// Ids below this are counted in a dense table; others go to a sorted set.
const DENSE_IDS: i64 = 1 << 16;
/// Labels counted per parallel task.
const CHUNK: usize = 1 << 20;

/// The sorted distinct values of `labels`.
pub fn unique_labels(labels: &[i64]) -> Vec<i64> {
    let (dense, sparse) = labels
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut dense = vec![false; DENSE_IDS as usize];
            let mut sparse = BTreeSet::new();
            for &l in chunk {
                if (0..DENSE_IDS).contains(&l) {
                    dense[l as usize] = true;
                } else {
                    sparse.insert(l);
                }
            }
            (dense, sparse)
        })
        .reduce(
            || (vec![false; DENSE_IDS as usize], BTreeSet::new()),
            |(mut a, mut sa), (b, sb)| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x |= y);
                sa.extend(sb);
                (a, sa)
            },
        );
    let mut ids: BTreeSet<i64> = sparse;
    ids.extend(dense.iter().enumerate().filter(|(_, seen)| **seen).map(|(id, _)| id as i64));
    ids.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distinct_labels_come_out_sorted() {
        assert_eq!(unique_labels(&[5, -1, 70_000, 5, 0, 3, -1]), vec![-1, 0, 3, 5, 70_000]);
        assert_eq!(unique_labels(&[]), Vec::<i64>::new());
    }
}
