//! Diverse selection as OSMa-Bench++ does it: near-duplicates removed greedily in
//! pool order (a prompt goes if its cosine similarity to an earlier kept prompt is at
//! least the threshold, 0.90), then farthest-first traversal on cosine distance
//! `1 − cos` from the first kept prompt until the requested number is reached.

use faer::{Accum, Mat, MatRef, Par};
use serde::{Deserialize, Serialize};

/// The threshold of OSMa-Bench++.
pub const NEAR_DUPLICATE_COSINE: f32 = 0.90;

/// A prompt removed as a near-duplicate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NearDuplicate {
    pub id: String,
    /// The earlier kept prompt it is too close to.
    pub duplicate_of: String,
    pub cosine: f32,
}

/// A selected prompt and how far it was from those selected before it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Selected {
    pub id: String,
    /// Cosine distance to the nearest earlier selection (the first has none).
    pub distance_to_earlier: Option<f32>,
}

/// What selection did to one pool.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelectionReport {
    pub candidates: usize,
    pub threshold: f32,
    pub near_duplicates: Vec<NearDuplicate>,
    pub selected: Vec<Selected>,
    /// Kept prompts that farthest-first did not reach.
    pub not_selected: Vec<String>,
    /// How many fewer than requested could be selected.
    pub shortfall: usize,
}

/// Cosine similarities of unit vectors (rows of `embeddings`), as a faer product.
pub fn cosine_matrix(embeddings: &[Vec<f32>]) -> Mat<f32> {
    let n = embeddings.len();
    let dim = embeddings.first().map_or(0, Vec::len);
    let flat: Vec<f32> = embeddings.iter().flatten().copied().collect();
    let e = MatRef::from_row_major_slice(&flat, n, dim);
    let mut sims = Mat::<f32>::zeros(n, n);
    faer::linalg::matmul::matmul(&mut sims, Accum::Replace, e, e.transpose(), 1.0, Par::Seq);
    sims
}

/// Select `target` diverse items from `ids` (pool order) with unit `embeddings`.
pub fn select(ids: &[String], embeddings: &[Vec<f32>], target: usize, threshold: f32) -> SelectionReport {
    assert_eq!(ids.len(), embeddings.len(), "one embedding per prompt");
    let sims = cosine_matrix(embeddings);
    let mut kept: Vec<usize> = Vec::new();
    let mut near_duplicates = Vec::new();
    for i in 0..ids.len() {
        let closest = kept.iter().map(|&j| (sims[(i, j)], j)).fold(None, |best: Option<(f32, usize)>, (s, j)| match best {
            Some((b, _)) if b >= s => best,
            _ => Some((s, j)),
        });
        match closest {
            Some((cosine, j)) if cosine >= threshold => near_duplicates.push(NearDuplicate { id: ids[i].clone(), duplicate_of: ids[j].clone(), cosine }),
            _ => kept.push(i),
        }
    }
    let mut selected = Vec::new();
    let mut min_distance: Vec<f32> = vec![f32::INFINITY; kept.len()];
    let mut taken = vec![false; kept.len()];
    let mut next = if kept.is_empty() { None } else { Some(0) };
    while let Some(k) = next {
        if selected.len() == target {
            break;
        }
        taken[k] = true;
        let distance = (!selected.is_empty()).then_some(min_distance[k]);
        selected.push(Selected { id: ids[kept[k]].clone(), distance_to_earlier: distance });
        for (m, &i) in kept.iter().enumerate() {
            min_distance[m] = min_distance[m].min(1.0 - sims[(i, kept[k])]);
        }
        // The farthest remaining one; ties go to the earliest in pool order.
        next = (0..kept.len()).filter(|&m| !taken[m]).fold(None, |best: Option<usize>, m| match best {
            Some(b) if min_distance[b] >= min_distance[m] => Some(b),
            _ => Some(m),
        });
    }
    let not_selected = (0..kept.len()).filter(|&m| !taken[m]).map(|m| ids[kept[m]].clone()).collect();
    SelectionReport { candidates: ids.len(), threshold, near_duplicates, shortfall: target.saturating_sub(selected.len()), selected, not_selected }
}
