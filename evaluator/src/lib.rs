//! The scoring core of OSMa-Bench++.
//!
//! Data flows one way: files are parsed once into validated domain types
//! ([`formats`]), ground truth is built from rendered sequences ([`ground_truth`]),
//! and [`semseg`] turns a ground-truth cloud and a predicted map into a confusion
//! matrix and the published metrics, bit for bit. Nothing here knows about HTTP,
//! databases or async runtimes.

pub mod bootstrap;
pub mod bounds;
pub mod csv_writer;
pub mod digest;
pub mod error;
pub mod formats;
pub mod ground_truth;
pub mod label_set;
pub mod numeric;
pub mod scores;
pub mod semseg;
pub mod submission;
pub mod synthetic;
pub mod text;
pub mod vqa;

pub use error::{InputError, Result, ScoreError};

/// Version of the scoring code; recorded with every score so re-scoring is traceable.
pub const EVALUATOR_VERSION: &str = env!("CARGO_PKG_VERSION");
