//! Logs: human-readable text by default (coloured only on a terminal, so a log file or a
//! collector gets plain text), JSON lines with `OSMAB_LOG_FORMAT=json`; filtered by
//! `RUST_LOG` (default `info`).

use std::io::IsTerminal;

use tracing_subscriber::EnvFilter;

use crate::config::LogFormat;

/// Install the global subscriber (once per process).
pub fn init(format: LogFormat) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info,sqlx=warn,tower_http=warn"));
    let builder = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_target(false).with_ansi(std::io::stderr().is_terminal());
    let _ = if format == LogFormat::Json { builder.json().try_init() } else { builder.try_init() };
}
