//! Predicted maps (`maps/<lighting>/<scene>.npz`) and class text features
//! (`text_features.npz`), as product.md section 5 defines them.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::npy::{NpyArray, ReadLimits};
use super::npz::{NpzReader, write_npz};
use crate::error::{InputError, Result};

/// Largest feature dimension accepted (CLIP-style embeddings have 512–1536; the
/// float64 re-check of near-ties in `semseg::labels` is sized for up to this).
pub const MAX_FEATURE_DIM: usize = 8192;

/// A dense row-major float32 matrix of feature vectors.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureMatrix {
    /// Number of vectors.
    pub rows: usize,
    /// Dimension of each vector.
    pub dim: usize,
    /// `rows * dim` values.
    pub values: Vec<f32>,
}

impl FeatureMatrix {
    /// Row `i`.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.values[i * self.dim..(i + 1) * self.dim]
    }

    fn from_array(array: NpyArray, file: &Path, field: &str) -> Result<Self> {
        if array.shape.len() == 2 && !(1..=MAX_FEATURE_DIM).contains(&array.shape[1]) {
            return Err(InputError::new(file, field, format!("feature vectors must have 1..={MAX_FEATURE_DIM} dimensions, found {}", array.shape[1])));
        }
        let (rows, dim, values) = array.into_f32_matrix(file, field, None)?;
        Ok(Self { rows, dim, values })
    }
}

/// How a map says what each point is.
#[derive(Debug, Clone, PartialEq)]
pub enum MapSemantics {
    /// Points grouped into objects, each object with a class id.
    ObjectLabels { object_ids: Vec<u32>, labels: Vec<i64> },
    /// Points grouped into objects, each object with a feature vector.
    ObjectFeatures { object_ids: Vec<u32>, features: FeatureMatrix },
    /// One feature vector per point (per-point methods such as OpenScene).
    PointFeatures(FeatureMatrix),
}

/// A participant's 3D map of one scene under one lighting.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictedMap {
    /// The file it came from, for messages.
    pub source: PathBuf,
    /// Point positions in the release's world frame.
    pub points: Vec<[f32; 3]>,
    /// What the points are.
    pub semantics: MapSemantics,
}

/// Before any array body is read: the shapes of the map's arrays agree with each other
/// (points `(N, 3)`; `object_ids` and `point_features` `N` rows; `labels` and `features`
/// one row per object), `N` is within `limits.max_points`, and the bodies, as they will be
/// held once converted, fit `limits.max_archive_bytes` together — so a small, highly
/// compressed upload cannot make the reader allocate more than the limits allow.
fn check_structure(npz: &mut NpzReader, path: &Path, limits: ReadLimits) -> Result<()> {
    let mut shapes = Vec::new();
    for key in ["points", "object_ids", "labels", "features", "point_features"] {
        if let Some(shape) = npz.shape(key)? {
            shapes.push((key, shape));
        }
    }
    let shape_of = |key: &str| shapes.iter().find(|(k, _)| *k == key).map(|(_, (_, s))| s.clone());
    // A missing or misshapen `points` is reported when it is read (bounded by the limits below).
    if let Some(points) = shape_of("points").filter(|p| p.len() == 2 && p[1] == 3) {
        let n = points[0];
        if n as u64 > limits.max_points {
            return Err(InputError::new(
                path,
                "points",
                format!("{n} points is more than the {} this scene's map may hold (one per pixel of its sequence)", limits.max_points),
            ));
        }
        for key in ["labels", "features"] {
            if let Some(objects) = shape_of(key).map(|s| s.first().copied().unwrap_or(0))
                && objects > n
                && n > 0
            {
                return Err(InputError::new(path, key, format!("{objects} objects for {n} points; every object needs points of its own")));
            }
        }
        for (key, what) in [("object_ids", "one object id per point"), ("point_features", "one row per point")] {
            if let Some(rows) = shape_of(key).map(|s| s.first().copied().unwrap_or(0))
                && rows != n
            {
                return Err(InputError::new(path, key, format!("expected {what} ({n}), found {rows}")));
            }
        }
    }
    // Held in memory as read, plus the float32 (points, features) or int64 (ids, labels)
    // copy a conversion makes.
    let held: u64 = shapes
        .iter()
        .map(|(key, (dtype, shape))| {
            let count = shape.iter().fold(1u64, |a, &d| a.saturating_mul(d as u64));
            let target: u64 = if matches!(*key, "object_ids" | "labels") { 8 } else { 4 };
            let stored = dtype.size() as u64;
            let per_element = if stored == target { target } else { stored + target };
            count.saturating_mul(per_element)
        })
        .fold(0u64, u64::saturating_add);
    if held > limits.max_archive_bytes {
        return Err(InputError::new(
            path,
            "(archive)",
            format!("its arrays take {held} bytes once read, more than the limit of {} bytes for one map", limits.max_archive_bytes),
        ));
    }
    Ok(())
}

impl PredictedMap {
    /// Read and structurally check a map `.npz`.
    pub fn read(path: &Path, limits: ReadLimits) -> Result<Self> {
        let mut npz = NpzReader::open(path, limits)?;
        check_structure(&mut npz, path, limits)?;
        let (n, _, flat) = npz.array("points")?.into_f32_matrix(path, "points", Some(3))?;
        if n == 0 {
            return Err(InputError::new(path, "points", "the map has no points"));
        }
        let points: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        drop(flat);
        let semantics = if npz.contains("point_features") {
            if let Some(other) = ["object_ids", "labels", "features"].into_iter().find(|k| npz.contains(k)) {
                return Err(InputError::new(
                    path,
                    "point_features",
                    format!("the map holds both 'point_features' and '{other}'; per-point and per-object maps are exclusive"),
                ));
            }
            let features = FeatureMatrix::from_array(npz.array("point_features")?, path, "point_features")?;
            if features.rows != n {
                return Err(InputError::new(path, "point_features", format!("expected one row per point ({n}), found {}", features.rows)));
            }
            MapSemantics::PointFeatures(features)
        } else {
            if !npz.contains("object_ids") {
                return Err(InputError::new(
                    path,
                    "object_ids",
                    format!(
                        "missing: a map needs 'object_ids' with 'labels' or 'features', or 'point_features' (the archive holds: {})",
                        npz.keys().join(", ")
                    ),
                ));
            }
            let ids = npz.array("object_ids")?.into_i64_vec(path, "object_ids")?;
            if ids.len() != n {
                return Err(InputError::new(path, "object_ids", format!("expected one object id per point ({n}), found {}", ids.len())));
            }
            let (has_labels, has_features) = (npz.contains("labels"), npz.contains("features"));
            let objects;
            let semantics_of = match (has_labels, has_features) {
                (true, true) => return Err(InputError::new(path, "labels", "the map holds both 'labels' and 'features'; keep exactly one")),
                (false, false) => return Err(InputError::new(path, "labels", "missing: objects need 'labels' (M,) class ids or 'features' (M, D)")),
                (true, false) => {
                    let labels = npz.array("labels")?.into_i64_vec(path, "labels")?;
                    objects = labels.len();
                    Either::Labels(labels)
                }
                (false, true) => {
                    let features = FeatureMatrix::from_array(npz.array("features")?, path, "features")?;
                    objects = features.rows;
                    Either::Features(features)
                }
            };
            let field = if has_labels { "labels" } else { "features" };
            let object_ids = object_indices(&ids, objects, path, field)?;
            match semantics_of {
                Either::Labels(labels) => MapSemantics::ObjectLabels { object_ids, labels },
                Either::Features(features) => MapSemantics::ObjectFeatures { object_ids, features },
            }
        };
        Ok(Self { source: path.to_path_buf(), points, semantics })
    }

    /// Write the map as `.npz` (int64 ids and labels, float32 points and features).
    pub fn write(&self, path: &Path, compress: bool) -> Result<()> {
        let flat: Vec<f32> = self.points.iter().flatten().copied().collect();
        let points = NpyArray::from_f32_matrix(self.points.len(), 3, flat);
        let mut arrays: Vec<(&str, NpyArray)> = vec![("points", points)];
        match &self.semantics {
            MapSemantics::ObjectLabels { object_ids, labels } => {
                arrays.push(("object_ids", NpyArray::from_i64(object_ids.iter().map(|&i| i as i64).collect())));
                arrays.push(("labels", NpyArray::from_i64(labels.clone())));
            }
            MapSemantics::ObjectFeatures { object_ids, features } => {
                arrays.push(("object_ids", NpyArray::from_i64(object_ids.iter().map(|&i| i as i64).collect())));
                arrays.push(("features", NpyArray::from_f32_matrix(features.rows, features.dim, features.values.clone())));
            }
            MapSemantics::PointFeatures(features) => {
                arrays.push(("point_features", NpyArray::from_f32_matrix(features.rows, features.dim, features.values.clone())));
            }
        }
        let refs: Vec<(&str, &NpyArray)> = arrays.iter().map(|(k, v)| (*k, v)).collect();
        write_npz(path, &refs, compress)
    }
}

enum Either {
    Labels(Vec<i64>),
    Features(FeatureMatrix),
}

/// Object ids must index the per-object array.
fn object_indices(ids: &[i64], objects: usize, path: &Path, field: &str) -> Result<Vec<u32>> {
    if objects == 0 {
        return Err(InputError::new(path, field, "the map has points but no objects"));
    }
    ids.iter()
        .enumerate()
        .map(|(i, &id)| {
            if id >= 0 && (id as usize) < objects {
                Ok(id as u32)
            } else {
                Err(InputError::new(path, "object_ids", format!("point {i} has object id {id}, but '{field}' describes objects 0..{} only", objects - 1)))
            }
        })
        .collect()
}

/// The text embedding of every release class in a method's own feature space.
#[derive(Debug, Clone, PartialEq)]
pub struct TextFeatures {
    /// The file it came from, for messages.
    pub source: PathBuf,
    /// Class id of each row.
    pub class_ids: Vec<i64>,
    /// One feature vector per class.
    pub features: FeatureMatrix,
}

impl TextFeatures {
    /// Read and check `text_features.npz` (`class_ids` (C,), `features` (C, D)).
    pub fn read(path: &Path, limits: ReadLimits) -> Result<Self> {
        let mut npz = NpzReader::open(path, limits)?;
        let class_ids = npz.array("class_ids")?.into_i64_vec(path, "class_ids")?;
        let features = FeatureMatrix::from_array(npz.array("features")?, path, "features")?;
        if features.rows != class_ids.len() {
            return Err(InputError::new(path, "features", format!("expected one row per class id ({}), found {}", class_ids.len(), features.rows)));
        }
        let mut seen = HashSet::new();
        if let Some(dup) = class_ids.iter().find(|id| !seen.insert(**id)) {
            return Err(InputError::new(path, "class_ids", format!("class id {dup} appears more than once")));
        }
        for (row, id) in class_ids.iter().enumerate() {
            if features.row(row).iter().all(|&v| v == 0.0) {
                return Err(InputError::new(path, "features", format!("the feature of class {id} (row {row}) is all zeros")));
            }
        }
        Ok(Self { source: path.to_path_buf(), class_ids, features })
    }

    /// Write `text_features.npz`.
    pub fn write(&self, path: &Path) -> Result<()> {
        let ids = NpyArray::from_i64(self.class_ids.clone());
        let features = NpyArray::from_f32_matrix(self.features.rows, self.features.dim, self.features.values.clone());
        write_npz(path, &[("class_ids", &ids), ("features", &features)], false)
    }
}
