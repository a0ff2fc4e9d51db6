//! The OSMa-Bench++ service's wire types: what its JSON API answers, and what its client
//! (`osmab-client`, and `osmab client`) reads back. One definition for both sides, so a
//! field the service adds or renames is a compile error in the client, not a silent `null`.
//!
//! The service builds these from its store; nothing here reads a database or the network.
//! The state enums map to the store's TEXT columns with the `sqlx` feature, which only the
//! service turns on.

pub mod account;
pub mod jws;
pub mod leaderboard;
pub mod problem_code;
pub mod queue;
pub mod receipts;
pub mod states;
pub mod submissions;
pub mod uploads;

pub use osmab_evaluator::digest;
pub use problem_code::ProblemCode;
