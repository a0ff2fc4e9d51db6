//! `osmab`: the OSMa-Bench++ evaluation service and its command line, as a library:
//! [`app`] builds the whole HTTP service over an [`AppState`] (what `osmab serve` runs
//! on a socket, and what in-process tests drive with tower's `oneshot`); [`cli`] is the
//! command line the `osmab` binary runs.

mod access_requests;
mod auth;
mod backup;
mod blobs;
pub mod cli;
mod clock;
pub mod config;
mod http;
mod intake;
mod jobs;
mod leaderboard;
mod llm;
mod metrics;
mod problem;
mod proxies;
mod queue;
mod rate_limit;
mod receipts;
mod release_allow;
mod release_archives;
mod release_names;
mod releases;
mod reserved_names;
mod routes;
mod secret_files;
pub mod serve;
mod split_secret;
mod state;
mod store;
mod telemetry;
mod token;
mod uploads;

pub use state::AppState;

/// The whole HTTP service over `state`: every route, page and middleware.
pub fn app(state: AppState) -> axum::Router {
    routes::router(state)
}
