//! The evaluator's specification, as tests. One binary (fast to build on 2 cores).

mod archives;
mod common;
mod formats;
mod golden;
mod ground_truth;
mod nearest;
mod prepared_cache;
mod semseg;
