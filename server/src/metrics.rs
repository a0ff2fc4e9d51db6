//! Prometheus metrics: request counts and latency per route, plus gauges read from the
//! store at scrape time (jobs and submissions per state).

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::Mutex;
use std::time::Duration;

/// Latency histogram bucket bounds in seconds.
const BUCKETS: [f64; 10] = [0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0, 10.0];

#[derive(Debug, Default)]
struct RouteStats {
    count: u64,
    sum: f64,
    buckets: [u64; BUCKETS.len()],
}

/// Counters kept by the HTTP middleware.
#[derive(Debug, Default)]
pub struct Metrics {
    requests: Mutex<BTreeMap<(String, String, u16), u64>>,
    latency: Mutex<BTreeMap<String, RouteStats>>,
}

impl Metrics {
    /// Count one request of `route` (the matched template, low-cardinality).
    pub fn observe(&self, method: &str, route: &str, status: u16, elapsed: Duration) {
        *self.requests.lock().expect("metrics lock").entry((method.to_string(), route.to_string(), status)).or_default() += 1;
        let mut latency = self.latency.lock().expect("metrics lock");
        let stats = latency.entry(route.to_string()).or_default();
        let seconds = elapsed.as_secs_f64();
        stats.count += 1;
        stats.sum += seconds;
        for (i, bound) in BUCKETS.iter().enumerate() {
            if seconds <= *bound {
                stats.buckets[i] += 1;
            }
        }
    }

    /// The Prometheus text exposition, with `gauges` (name, help, label values) appended.
    pub fn render(&self, gauges: &[(&str, &str, Vec<(String, i64)>)]) -> String {
        let mut out = String::new();
        out.push_str("# HELP osmab_http_requests_total HTTP requests by method, route and status.\n# TYPE osmab_http_requests_total counter\n");
        for ((method, route, status), n) in self.requests.lock().expect("metrics lock").iter() {
            let _ = writeln!(out, "osmab_http_requests_total{{method=\"{method}\",route=\"{}\",status=\"{status}\"}} {n}", escape(route));
        }
        out.push_str("# HELP osmab_http_request_duration_seconds HTTP request latency by route.\n# TYPE osmab_http_request_duration_seconds histogram\n");
        for (route, stats) in self.latency.lock().expect("metrics lock").iter() {
            let route = escape(route);
            for (bound, n) in BUCKETS.iter().zip(stats.buckets) {
                let _ = writeln!(out, "osmab_http_request_duration_seconds_bucket{{route=\"{route}\",le=\"{bound}\"}} {n}");
            }
            let _ = writeln!(out, "osmab_http_request_duration_seconds_bucket{{route=\"{route}\",le=\"+Inf\"}} {}", stats.count);
            let _ = writeln!(out, "osmab_http_request_duration_seconds_sum{{route=\"{route}\"}} {}", stats.sum);
            let _ = writeln!(out, "osmab_http_request_duration_seconds_count{{route=\"{route}\"}} {}", stats.count);
        }
        for (name, help, values) in gauges {
            let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} gauge");
            for (state, n) in values {
                let _ = writeln!(out, "{name}{{state=\"{}\"}} {n}", escape(state));
            }
        }
        out
    }
}

fn escape(text: &str) -> String {
    text.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}
