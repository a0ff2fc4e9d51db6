//! What class the map gives each predicted point: the object's given label, or the
//! class whose text feature has the highest cosine similarity to the object's (or
//! point's) feature, the first maximum winning.

use faer::{Accum, MatRef, Par};
use rayon::prelude::*;

use super::vocabulary::Vocabulary;
use crate::error::{InputError, Result};
use crate::formats::classes::ClassList;
use crate::formats::map::{FeatureMatrix, MapSemantics, PredictedMap, TextFeatures};
use crate::semseg::confusion::UNMATCHED;

/// Rows classified per matrix product (bounds the similarity buffer).
const ROWS_PER_BLOCK: usize = 8192;
/// Candidates within this fraction of a row's norm of the float32 maximum are
/// re-compared in float64, so the argmax does not depend on the SIMD path.
const NEAR_TIE: f64 = 1e-3;

/// One class per predicted point: a vocabulary id, or -1 for a given label that is a
/// release class but not one of this scene's.
pub fn predicted_point_labels(map: &PredictedMap, vocabulary: &Vocabulary, classes: &ClassList, text: Option<&TextFeatures>) -> Result<Vec<i64>> {
    let per_object: Vec<i64>;
    let object_ids = match &map.semantics {
        MapSemantics::ObjectLabels { object_ids, labels } => {
            per_object = labels
                .iter()
                .enumerate()
                .map(|(object, &label)| {
                    if !classes.contains(label) {
                        Err(InputError::new(&map.source, "labels", format!("object {object} has label {label}, which is not a class of the release")))
                    } else if vocabulary.contains(label) {
                        Ok(label)
                    } else {
                        Ok(UNMATCHED)
                    }
                })
                .collect::<Result<_>>()?;
            object_ids
        }
        MapSemantics::ObjectFeatures { object_ids, features } => {
            let text = class_text(map, "features", features, vocabulary, text)?;
            per_object = argmax_classes(features, &text, map, "features")?.into_iter().map(|j| vocabulary.ids()[j]).collect();
            object_ids
        }
        MapSemantics::PointFeatures(features) => {
            let text = class_text(map, "point_features", features, vocabulary, text)?;
            return Ok(argmax_classes(features, &text, map, "point_features")?.into_iter().map(|j| vocabulary.ids()[j]).collect());
        }
    };
    Ok(object_ids.iter().map(|&o| per_object[o as usize]).collect())
}

/// Unit-length text features of the vocabulary, in vocabulary order.
struct ClassText {
    f64_rows: Vec<f64>,
    f32_rows: Vec<f32>,
    dim: usize,
}

fn class_text(map: &PredictedMap, field: &str, features: &FeatureMatrix, vocabulary: &Vocabulary, text: Option<&TextFeatures>) -> Result<ClassText> {
    let text = text.ok_or_else(|| {
        InputError::new(&map.source, field, "the map carries features, so the class text features (text_features.npz, --text-features) are required")
    })?;
    if text.features.dim != features.dim {
        return Err(InputError::new(
            &text.source,
            "features",
            format!("text features have {} dimensions but the map's {field} have {}", text.features.dim, features.dim),
        ));
    }
    let mut f64_rows = Vec::with_capacity(vocabulary.len() * features.dim);
    for &class in vocabulary.ids() {
        let row =
            text.class_ids.iter().position(|&c| c == class).ok_or_else(|| {
                InputError::new(&text.source, "class_ids", format!("class {class}, present in the scene's ground truth, has no text feature"))
            })?;
        let values = text.features.row(row);
        let norm = values.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
        f64_rows.extend(values.iter().map(|&v| v as f64 / norm));
    }
    let f32_rows = f64_rows.iter().map(|&v| v as f32).collect();
    Ok(ClassText { f64_rows, f32_rows, dim: features.dim })
}

/// Index of the most similar class for every feature row.
fn argmax_classes(features: &FeatureMatrix, text: &ClassText, map: &PredictedMap, field: &str) -> Result<Vec<usize>> {
    let classes = text.f64_rows.len() / text.dim;
    let norms: Vec<f64> = (0..features.rows).into_par_iter().map(|i| features.row(i).iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt()).collect();
    if let Some(zero) = norms.iter().position(|&n| n == 0.0) {
        return Err(InputError::new(&map.source, field, format!("row {zero} is all zeros; a feature needs a direction to be classified")));
    }
    let text_t = MatRef::from_row_major_slice(&text.f32_rows, classes, text.dim).transpose();
    let blocks: Vec<Vec<usize>> = (0..features.rows.div_ceil(ROWS_PER_BLOCK))
        .into_par_iter()
        .map(|b| {
            let start = b * ROWS_PER_BLOCK;
            let rows = ROWS_PER_BLOCK.min(features.rows - start);
            let lhs = MatRef::from_row_major_slice(&features.values[start * features.dim..(start + rows) * features.dim], rows, features.dim);
            let mut sims = faer::Mat::<f32>::zeros(rows, classes);
            faer::linalg::matmul::matmul(&mut sims, Accum::Replace, lhs, text_t, 1.0, Par::Seq);
            (0..rows)
                .map(|r| {
                    let max = (0..classes).map(|j| sims[(r, j)]).fold(f32::NEG_INFINITY, f32::max) as f64;
                    let tolerance = NEAR_TIE * norms[start + r];
                    let row = features.row(start + r);
                    let mut best = (f64::NEG_INFINITY, 0usize);
                    for j in 0..classes {
                        if (sims[(r, j)] as f64) < max - tolerance {
                            continue;
                        }
                        let t = &text.f64_rows[j * text.dim..(j + 1) * text.dim];
                        let exact: f64 = row.iter().zip(t).map(|(&a, &b)| a as f64 * b).sum();
                        if exact > best.0 {
                            best = (exact, j);
                        }
                    }
                    best.1
                })
                .collect()
        })
        .collect();
    Ok(blocks.into_iter().flatten().collect())
}
