//! Confusion matrices as JSON: `{"labels": [..., -1], "matrix": [[...]]}` (the
//! fixture format; rows are ground truth, columns predictions).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{InputError, Result};
use crate::semseg::ConfusionMatrix;

/// Largest total count accepted: 2^53, the largest integer float64 holds exactly.
const MAX_TOTAL: u64 = 1 << 53;

#[derive(Serialize, Deserialize)]
struct ConfusionJson {
    labels: Vec<i64>,
    matrix: Vec<Vec<u64>>,
}

/// Read a `.confusion.json` file.
pub fn read_confusion(path: &Path) -> Result<ConfusionMatrix> {
    let text = std::fs::read(path).map_err(|e| InputError::io(path, &e))?;
    let json: ConfusionJson = serde_json::from_slice(&text)
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

/// The JSON value of a confusion matrix (`labels` and `matrix`).
pub fn confusion_to_json(matrix: &ConfusionMatrix) -> serde_json::Value {
    let n = matrix.labels().len();
    let rows: Vec<Vec<u64>> = (0..n).map(|r| matrix.row(r).to_vec()).collect();
    serde_json::json!({ "labels": matrix.labels(), "matrix": rows })
}

/// Write a `.confusion.json` file.
pub fn write_confusion(path: &Path, matrix: &ConfusionMatrix) -> Result<()> {
    let text = serde_json::to_string(&confusion_to_json(matrix)).expect("confusion matrices serialise");
    std::fs::write(path, text).map_err(|e| InputError::io(path, &e))
}
