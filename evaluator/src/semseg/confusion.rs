//! The confusion matrix: rows are ground-truth labels, columns predicted labels, both
//! in the order of `labels` (the scene vocabulary ascending, then -1).

use std::collections::{BTreeSet, HashMap};

use rayon::prelude::*;

/// The label of "no class from the vocabulary" (the last row and column).
pub const UNMATCHED: i64 = -1;

/// Most points counted per parallel task, so that a task's counts fit 32 bits: callers of
/// [`NearestCount::add`] give parts of at most this many points (integer counts add up
/// exactly in any order).
pub const COUNT_CHUNK: usize = 1 << 20;

/// A square matrix of point counts indexed by class label.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfusionMatrix {
    labels: Vec<i64>,
    counts: Vec<u64>,
}

impl ConfusionMatrix {
    /// A matrix over `labels` (unique) with `counts` in row-major order.
    pub fn new(labels: Vec<i64>, counts: Vec<u64>) -> Result<Self, String> {
        let n = labels.len();
        if counts.len() != n * n {
            return Err(format!("{} labels need {} counts, found {}", n, n * n, counts.len()));
        }
        let unique: BTreeSet<i64> = labels.iter().copied().collect();
        if unique.len() != n {
            return Err("labels must be unique".into());
        }
        Ok(Self { labels, counts })
    }

    /// Count every ground-truth point whose label is in `vocabulary`, or is -1 (its own
    /// row), against its predicted label (points of other classes, such as 0, are
    /// dropped); a prediction outside the vocabulary counts in the -1 column.
    pub fn from_labels(ground_truth: &[i64], predicted: &[i64], vocabulary: &[i64]) -> Self {
        assert_eq!(ground_truth.len(), predicted.len(), "one prediction per ground-truth point");
        let counter = MatrixCounter::new(vocabulary);
        let columns = counter.columns();
        let parts = ground_truth.par_chunks(COUNT_CHUNK).zip(predicted.par_chunks(COUNT_CHUNK));
        let counts = counter.count(parts.map(|(gt, predicted)| gt.iter().zip(predicted).map(|(&g, &p)| (g, columns.get(p)))));
        counter.into_matrix(counts)
    }

    /// As [`ConfusionMatrix::from_labels`], where ground-truth point `i` is predicted the
    /// label `point_labels[nearest[i]]` of its nearest map point (no per-point copy: each
    /// map point's column is looked up once).
    pub fn from_nearest(ground_truth: &[i64], nearest: &[u32], point_labels: &[i64], vocabulary: &[i64]) -> Self {
        assert_eq!(ground_truth.len(), nearest.len(), "one nearest map point per ground-truth point");
        let mut count = NearestCount::new(vocabulary, point_labels);
        let parts = ground_truth.par_chunks(COUNT_CHUNK).zip(nearest.par_chunks(COUNT_CHUNK));
        count.add(parts.map(|(gt, nearest)| gt.iter().copied().zip(nearest.iter().copied())));
        count.into_matrix()
    }

    /// The pooled matrix of several scenes: labels are the sorted union (so -1 comes
    /// first), each scene's counts added in by label.
    pub fn pooled<'a>(matrices: impl IntoIterator<Item = &'a ConfusionMatrix>) -> Self {
        let matrices: Vec<&ConfusionMatrix> = matrices.into_iter().collect();
        let labels: Vec<i64> = matrices.iter().flat_map(|m| m.labels.iter().copied()).collect::<BTreeSet<_>>().into_iter().collect();
        let n = labels.len();
        let position: HashMap<i64, usize> = labels.iter().enumerate().map(|(i, &l)| (l, i)).collect();
        let mut counts = vec![0u64; n * n];
        for m in matrices {
            let map: Vec<usize> = m.labels.iter().map(|l| position[l]).collect();
            let k = m.labels.len();
            for r in 0..k {
                for c in 0..k {
                    counts[map[r] * n + map[c]] += m.counts[r * k + c];
                }
            }
        }
        Self { labels, counts }
    }

    /// Row and column labels.
    pub fn labels(&self) -> &[i64] {
        &self.labels
    }

    /// Row `r` (ground truth of `labels[r]`).
    pub fn row(&self, r: usize) -> &[u64] {
        let n = self.labels.len();
        &self.counts[r * n..(r + 1) * n]
    }

    /// Count at row `r`, column `c`.
    pub fn count(&self, r: usize, c: usize) -> u64 {
        self.counts[r * self.labels.len() + c]
    }

    /// Ground-truth points of `labels[r]`.
    pub fn row_sum(&self, r: usize) -> u64 {
        self.row(r).iter().sum()
    }

    /// Points predicted as `labels[c]`, over all rows.
    pub fn column_sum(&self, c: usize) -> u64 {
        (0..self.labels.len()).map(|r| self.count(r, c)).sum()
    }

    /// All counted points.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }
}

/// A confusion matrix counted from the nearest map point of each ground-truth point, in
/// parts of any order and size as the association gives them ([`NearestIndex::nearest_by_block`]):
/// [`ConfusionMatrix::from_nearest`] with no answer array for the whole cloud.
///
/// [`NearestIndex::nearest_by_block`]: super::nearest::NearestIndex::nearest_by_block
pub struct NearestCount {
    counter: MatrixCounter,
    /// Each map point's column (its label's position in the matrix).
    point_columns: Vec<u32>,
    counts: Vec<u64>,
}

impl NearestCount {
    /// An empty count over `[vocabulary..., -1]` of ground-truth points against the labels
    /// `point_labels` of the map points nearest to them.
    pub fn new(vocabulary: &[i64], point_labels: &[i64]) -> Self {
        let counter = MatrixCounter::new(vocabulary);
        let columns = counter.columns();
        let point_columns = point_labels.par_iter().map(|&l| columns.get(l) as u32).collect();
        let counts = counter.zeros();
        Self { counter, point_columns, counts }
    }

    /// Count ground-truth points given as (label, index of the nearest map point) pairs, in
    /// parts of at most [`COUNT_CHUNK`] taken in parallel.
    pub fn add<P>(&mut self, parts: impl ParallelIterator<Item = P>)
    where
        P: Iterator<Item = (i64, u32)> + Send,
    {
        let columns = &self.point_columns;
        let counts = self.counter.count(parts.map(|part| part.map(|(label, nearest)| (label, columns[nearest as usize] as usize))));
        self.counts.iter_mut().zip(counts).for_each(|(total, c)| *total += c);
    }

    /// Each map point's column: the class an association that answers classes needs
    /// ([`NearestIndex::point_classes`]), whose answers [`NearestCount::add_columns`] counts.
    ///
    /// [`NearestIndex::point_classes`]: super::nearest::NearestIndex::point_classes
    pub fn point_columns(&self) -> &[u32] {
        &self.point_columns
    }

    /// Count ground-truth points given as (label, column of the nearest map point) pairs,
    /// in parts of at most [`COUNT_CHUNK`] taken in parallel.
    pub fn add_columns<P>(&mut self, parts: impl ParallelIterator<Item = P>)
    where
        P: Iterator<Item = (i64, u32)> + Send,
    {
        let counts = self.counter.count(parts.map(|part| part.map(|(label, column)| (label, column as usize))));
        self.counts.iter_mut().zip(counts).for_each(|(total, c)| *total += c);
    }

    /// The matrix of every point counted.
    pub fn into_matrix(self) -> ConfusionMatrix {
        self.counter.into_matrix(self.counts)
    }
}

/// Counting points into a matrix over `[vocabulary..., -1]` by their ground-truth label's
/// row and a column. Points of classes outside the matrix are counted in an extra row,
/// dropped at the end: no branch a point. The -1 row is kept (it only arises from mesh
/// ground truth), as the reference does.
struct MatrixCounter {
    /// The matrix's labels: the vocabulary, then -1.
    labels: Vec<i64>,
    /// Each ground-truth label's row, the extra row for labels outside the matrix.
    rows: LabelPositions,
}

impl MatrixCounter {
    fn new(vocabulary: &[i64]) -> Self {
        let mut labels = vocabulary.to_vec();
        labels.push(UNMATCHED);
        let rows = LabelPositions::new(&labels, labels.len());
        Self { labels, rows }
    }

    /// Each predicted label's column: its position in the matrix, the -1 column for labels
    /// outside it.
    fn columns(&self) -> LabelPositions {
        LabelPositions::new(&self.labels, self.labels.len() - 1)
    }

    /// Counts of the matrix with its extra row, all zero.
    fn zeros(&self) -> Vec<u64> {
        let n = self.labels.len();
        vec![0u64; (n + 1) * n]
    }

    /// Count (ground-truth label, column) pairs given in parts of at most [`COUNT_CHUNK`]
    /// (a part's counts fit 32 bits), taken in parallel; integer counts add up exactly in
    /// any order.
    fn count<P>(&self, parts: impl ParallelIterator<Item = P>) -> Vec<u64>
    where
        P: Iterator<Item = (i64, usize)> + Send,
    {
        let n = self.labels.len();
        parts
            .fold(
                || self.zeros(),
                |mut total, part| {
                    let mut counts = vec![0u32; (n + 1) * n];
                    let mut counted = 0usize;
                    let mut add = |(label, column): (i64, usize), length: u32| {
                        counts[self.rows.get(label) * n + column] += length;
                        counted += length as usize;
                    };
                    // Neighbouring points mostly share their pair (a cloud in Z-order, an
                    // object at a time): a run of equal pairs is counted in a register and
                    // added once, where adding each point to its cell would wait on the
                    // store of the point before it.
                    let mut part = part;
                    if let Some(first) = part.next() {
                        let (mut same, mut length) = (first, 1u32);
                        for pair in part {
                            if pair == same {
                                length += 1;
                            } else {
                                add(same, length);
                                (same, length) = (pair, 1);
                            }
                        }
                        add(same, length);
                    }
                    assert!(counted <= COUNT_CHUNK, "a part of at most {COUNT_CHUNK} points");
                    total.iter_mut().zip(counts).for_each(|(t, c)| *t += u64::from(c));
                    total
                },
            )
            .reduce(
                || self.zeros(),
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                    a
                },
            )
    }

    /// The matrix of `counts`, its extra row dropped.
    fn into_matrix(self, mut counts: Vec<u64>) -> ConfusionMatrix {
        let n = self.labels.len();
        counts.truncate(n * n);
        ConfusionMatrix { labels: self.labels, counts }
    }
}

/// Label → position in a matrix's labels, or `missing` for a label not among them; a
/// dense table when labels are small non-negative ids.
struct LabelPositions {
    table: Vec<u32>,
    unmatched: usize,
    sparse: HashMap<i64, usize>,
    missing: usize,
}

impl LabelPositions {
    const DENSE_LIMIT: i64 = 1 << 20;

    fn new(labels: &[i64], missing: usize) -> Self {
        let max = labels.iter().copied().filter(|&l| (0..Self::DENSE_LIMIT).contains(&l)).max().unwrap_or(0);
        let mut table = vec![missing as u32; max as usize + 1];
        let mut sparse = HashMap::new();
        let mut unmatched = missing;
        for (position, &label) in labels.iter().enumerate() {
            if (0..Self::DENSE_LIMIT).contains(&label) {
                table[label as usize] = position as u32;
            } else if label == UNMATCHED {
                unmatched = position;
            } else {
                sparse.insert(label, position);
            }
        }
        Self { table, unmatched, sparse, missing }
    }

    #[inline]
    fn get(&self, label: i64) -> usize {
        if (label as u64) < self.table.len() as u64 {
            self.table[label as usize] as usize
        } else if label == UNMATCHED {
            self.unmatched
        } else {
            self.sparse.get(&label).copied().unwrap_or(self.missing)
        }
    }
}
