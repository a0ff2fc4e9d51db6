//! Confusion matrices as JSON: `{"labels": [..., -1], "matrix": [[...]]}` (the
//! fixture format; rows are ground truth, columns predictions).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{InputError, Result};
use crate::semseg::ConfusionMatrix;

/// Largest total count accepted: 2^53, the largest integer float64 holds exactly.
const MAX_TOTAL: u64 = 1 << 53;

/// A confusion matrix as its file writes it: the labels, and one row of counts per label.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ConfusionDocument {
    pub labels: Vec<i64>,
    pub matrix: Vec<Vec<u64>>,
}

impl From<&ConfusionMatrix> for ConfusionDocument {
    fn from(matrix: &ConfusionMatrix) -> Self {
        let n = matrix.labels().len();
        ConfusionDocument { labels: matrix.labels().to_vec(), matrix: (0..n).map(|r| matrix.row(r).to_vec()).collect() }
    }
}

/// Read a `.confusion.json` file.
pub fn read_confusion(path: &Path) -> Result<ConfusionMatrix> {
    let text = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let json: ConfusionDocument = serde_json::from_slice(&text)
        .map_err(|e| InputError::new(path, "(json)", format!("expected {{\"labels\": [int, ...], \"matrix\": [[non-negative int, ...], ...]}}: {e}")))?;
    let n = json.labels.len();
    if json.matrix.len() != n {
        return Err(InputError::new(path, "matrix", format!("expected {n} rows (one per label), found {}", json.matrix.len())));
    }
    let mut counts = Vec::with_capacity(n * n);
    let mut total = 0u64;
    for (r, row) in json.matrix.iter().enumerate() {
        if row.len() != n {
            return Err(InputError::new(path, format!("matrix[{r}]"), format!("expected {n} columns (one per label), found {}", row.len())));
        }
        // Every sum of counts must stay exact in float64, as it is in NumPy.
        total = row
            .iter()
            .try_fold(total, |t, &c| t.checked_add(c))
            .filter(|&t| t <= MAX_TOTAL)
            .ok_or_else(|| InputError::new(path, format!("matrix[{r}]"), format!("counts add up to more than 2^53 points")))?;
        counts.extend_from_slice(row);
    }
    ConfusionMatrix::new(json.labels, counts).map_err(|m| InputError::new(path, "labels", m))
}

/// Write a `.confusion.json` file.
pub fn write_confusion(path: &Path, matrix: &ConfusionMatrix) -> Result<()> {
    let text = serde_json::to_string(&ConfusionDocument::from(matrix)).expect("confusion matrices serialise");
    std::fs::write(path, text).map_err(|e| InputError::io(path, &e))
}
