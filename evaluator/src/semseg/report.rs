//! Dataset-level tables: one row per scene, then `overall_mean` (the mean of the
//! scene rows) and `overall` (the metrics of the pooled matrix), as `metrics.csv`.

use serde::{Deserialize, Serialize};

use super::confusion::ConfusionMatrix;
use super::metrics::SegmentationMetrics;
use crate::csv_writer::{CsvWriter, LineEnd};
use crate::numeric::{nan_skipping_mean, python_repr};
use crate::scores::axes::Metric;

/// The three headline numbers. In JSON an undefined (NaN) metric is `null`, and `null`
/// reads back as NaN; fields are in the order of their keys.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MetricTriple {
    /// 95 % bootstrap intervals over scenes, on pooled aggregates that have them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ci95: Option<MetricIntervals>,
    /// Frequency-weighted IoU.
    #[serde(with = "nan_as_null")]
    #[schemars(with = "Option<f64>")]
    pub fmiou: f64,
    /// Mean accuracy (recall).
    #[serde(with = "nan_as_null")]
    #[schemars(with = "Option<f64>")]
    pub macc: f64,
    /// Mean IoU.
    #[serde(with = "nan_as_null")]
    #[schemars(with = "Option<f64>")]
    pub miou: f64,
}

impl Default for MetricTriple {
    /// Every metric undefined.
    fn default() -> Self {
        Self::new(f64::NAN, f64::NAN, f64::NAN)
    }
}

/// The 95 % bootstrap interval of each metric, `[low, high]`; absent where fewer than two
/// resamples define the metric.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, schemars::JsonSchema)]
pub struct MetricIntervals {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmiou: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub macc: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub miou: Option<[f64; 2]>,
}

impl MetricIntervals {
    /// The interval of `metric`.
    pub fn get(&self, metric: Metric) -> Option<[f64; 2]> {
        match metric {
            Metric::Miou => self.miou,
            Metric::Fmiou => self.fmiou,
            Metric::Macc => self.macc,
        }
    }
}

/// A metric as JSON: a number, or `null` where it is undefined.
mod nan_as_null {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() { s.serialize_f64(*v) } else { s.serialize_none() }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}

impl From<&SegmentationMetrics> for MetricTriple {
    fn from(m: &SegmentationMetrics) -> Self {
        Self::new(m.miou, m.fmiou, m.macc)
    }
}

impl MetricTriple {
    /// The three values, without intervals.
    pub fn new(miou: f64, fmiou: f64, macc: f64) -> Self {
        Self { ci95: None, fmiou, macc, miou }
    }

    /// The 95 % interval of `metric`, where there is one.
    pub fn interval(&self, metric: Metric) -> Option<[f64; 2]> {
        self.ci95?.get(metric)
    }

    /// The value of `metric`, NaN where undefined.
    pub fn get(&self, metric: Metric) -> f64 {
        match metric {
            Metric::Miou => self.miou,
            Metric::Fmiou => self.fmiou,
            Metric::Macc => self.macc,
        }
    }

    /// The value of `metric` where it is defined (finite).
    pub fn defined(&self, metric: Metric) -> Option<f64> {
        Some(self.get(metric)).filter(|v| v.is_finite())
    }

    /// The relative change of each metric against `baseline`: (self − baseline) / baseline.
    pub fn relative_change(&self, baseline: &MetricTriple) -> MetricTriple {
        let change = |v: f64, b: f64| (v - b) / b;
        MetricTriple::new(change(self.miou, baseline.miou), change(self.fmiou, baseline.fmiou), change(self.macc, baseline.macc))
    }
}

/// The metrics of one lighting over a set of scenes.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricsTable {
    /// Scene name and its metrics, in the reference's row order.
    pub scenes: Vec<(String, SegmentationMetrics)>,
    /// Mean over the scene rows (NaN rows skipped, as pandas does).
    pub overall_mean: MetricTriple,
    /// Metrics of the pooled confusion matrix.
    pub overall: SegmentationMetrics,
}

/// The reference sorts `<scene>_conf_matrix.pkl` file names; sorting by that key keeps
/// its row order (and so its summation order) for any scene names.
fn reference_sort_key(scene: &str) -> String {
    format!("{scene}_conf_matrix.pkl")
}

impl MetricsTable {
    /// Score every scene and the pool of all of them.
    pub fn from_scenes(mut scenes: Vec<(String, ConfusionMatrix)>) -> Self {
        scenes.sort_by_cached_key(|(name, _)| reference_sort_key(name));
        let pooled = ConfusionMatrix::pooled(scenes.iter().map(|(_, m)| m));
        let rows: Vec<(String, SegmentationMetrics)> = scenes.into_iter().map(|(name, m)| (name, SegmentationMetrics::from_confusion(&m))).collect();
        let column = |f: fn(&SegmentationMetrics) -> f64| nan_skipping_mean(&rows.iter().map(|(_, m)| f(m)).collect::<Vec<_>>());
        let overall_mean = MetricTriple::new(column(|m| m.miou), column(|m| m.fmiou), column(|m| m.macc));
        Self { overall: SegmentationMetrics::from_confusion(&pooled), scenes: rows, overall_mean }
    }

    /// `metrics.csv` as OSMa-Bench writes it: `miou,fmiou,macc,scene`, Python float
    /// repr, NaN as an empty field (pandas' default).
    pub fn to_csv(&self) -> String {
        let cell = |v: f64| if v.is_nan() { String::new() } else { python_repr(v) };
        let mut csv = CsvWriter::new(LineEnd::Lf);
        csv.row(["miou", "fmiou", "macc", "scene"]);
        let mut line = |t: MetricTriple, name: &str| csv.row([cell(t.miou), cell(t.fmiou), cell(t.macc), name.to_string()]);
        for (name, metrics) in &self.scenes {
            line(metrics.into(), name);
        }
        line(self.overall_mean, "overall_mean");
        line((&self.overall).into(), "overall");
        csv.finish()
    }
}

/// The tables of several lightings of one method, compared against a baseline lighting.
#[derive(Debug, Clone, PartialEq)]
pub struct LightingComparison {
    /// The baseline lighting's name.
    pub baseline: String,
    /// Every lighting (the baseline first, then by name) with its table.
    pub lightings: Vec<(String, MetricsTable)>,
}

impl LightingComparison {
    /// Compare `lightings` against the one named `baseline`; `None` when it is absent.
    pub fn new(baseline: &str, mut lightings: Vec<(String, MetricsTable)>) -> Option<Self> {
        lightings.sort_by(|(a, _), (b, _)| (a != baseline, a).cmp(&(b != baseline, b)));
        (lightings.first()?.0 == baseline).then(|| Self { baseline: baseline.to_string(), lightings })
    }

    /// `lighting,aggregate,miou,fmiou,macc,miou_change,fmiou_change,macc_change`: for each
    /// lighting the pooled `overall` and the `overall_mean` rows, with the relative change
    /// against the baseline's same row.
    pub fn to_csv(&self) -> String {
        let cell = |v: f64| if v.is_nan() { String::new() } else { python_repr(v) };
        let rows = |t: &MetricsTable| [("overall", MetricTriple::from(&t.overall)), ("overall_mean", t.overall_mean)];
        let base = rows(&self.lightings[0].1);
        let mut csv = CsvWriter::new(LineEnd::Lf);
        csv.row(["lighting", "aggregate", "miou", "fmiou", "macc", "miou_change", "fmiou_change", "macc_change"]);
        for (name, table) in &self.lightings {
            for ((aggregate, value), (_, baseline)) in rows(table).into_iter().zip(base) {
                let change = value.relative_change(&baseline);
                csv.row([
                    name.clone(),
                    aggregate.to_string(),
                    cell(value.miou),
                    cell(value.fmiou),
                    cell(value.macc),
                    cell(change.miou),
                    cell(change.fmiou),
                    cell(change.macc),
                ]);
            }
        }
        csv.finish()
    }
}
