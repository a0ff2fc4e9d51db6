//! Service settings: defaults, then an optional TOML file, then `OSMAB_*` environment
//! variables (and `DATABASE_URL`), so deployments override files. Secrets are wrapped so
//! they never reach logs or `Debug` output.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// A value that must never be printed.
#[derive(Clone, Default, PartialEq, Eq)]
pub struct Secret(String);

impl Secret {
    /// Wrap a secret.
    pub fn new(value: impl Into<String>) -> Self {
        Self(value.into())
    }

    /// The secret itself, for the one place that needs it.
    pub fn expose(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("[redacted]")
    }
}

/// A database URL without its password, for logs.
pub fn redact_url(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let credentials = &url[scheme + 3..at];
            let user = credentials.split(':').next().unwrap_or("");
            let hidden = if credentials.contains(':') { ":[redacted]" } else { "" };
            format!("{}{user}{hidden}{}", &url[..scheme + 3], &url[at..])
        }
        _ => url.to_string(),
    }
}

/// Every setting of `osmab serve` and `osmab worker`.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Address of the HTTP listener (`OSMAB_BIND`).
    pub bind: SocketAddr,
    /// The origin people reach the service at (`OSMAB_PUBLIC_URL`, e.g.
    /// `https://osmab.example.org`; unset, `osmab serve` fills in `http://` + the address it
    /// listens on): the issuer receipts name, which `osmab client verify` checks against
    /// where the keys came from.
    pub public_url: Option<String>,
    /// Local storage and the embedded database (`OSMAB_DATA_DIR`).
    pub data_dir: PathBuf,
    /// The folder a release config's relative asset pack path (`synthesis.assets`, the
    /// demo's `assets`) is read under (`OSMAB_ASSETS_ROOT`; the working folder when unset;
    /// `/app` in the Docker image, which holds the repository's pack in `/app/assets`).
    pub assets_root: PathBuf,
    /// `DATABASE_URL`; SQLite in the data directory when unset.
    pub database_url: Secret,
    /// `OSMAB_ADMIN_TOKEN`; generated on first start when unset.
    pub admin_token: Option<Secret>,
    /// In-process workers of `osmab serve` (`OSMAB_WORKERS`).
    pub workers: usize,
    /// Build the demo release and score the baselines on an empty database (`OSMAB_DEMO`).
    pub demo: bool,
    /// Test-split submissions per team per 24 hours unless an administrator set the
    /// split's policy or the team has its own limit (`OSMAB_DAILY_QUOTA`).
    pub daily_quota: i64,
    /// Val-split submissions per team per 24 hours, likewise (`OSMAB_VAL_QUOTA`).
    pub val_quota: i64,
    /// Largest upload in bytes (`OSMAB_MAX_UPLOAD_BYTES`).
    pub max_upload_bytes: u64,
    /// Bytes an upload may unpack to, as a multiple of its own size (`OSMAB_MAX_EXPANSION_RATIO`).
    pub max_expansion_ratio: u64,
    /// Resumable uploads a team may hold open at once (`OSMAB_MAX_OPEN_UPLOADS`).
    pub max_open_uploads: i64,
    /// Declared bytes of a team's open resumable uploads at most (`OSMAB_MAX_OPEN_UPLOAD_BYTES`).
    pub max_open_upload_bytes: u64,
    /// Largest unpacked submission in bytes (`OSMAB_MAX_UNPACKED_BYTES`).
    pub max_unpacked_bytes: u64,
    /// How long a job's lease lasts without a heartbeat (`OSMAB_JOB_LEASE_SECS`).
    pub job_lease_secs: u64,
    /// Attempts before a job fails for good (`OSMAB_JOB_MAX_ATTEMPTS`).
    pub job_max_attempts: i64,
    /// How often an idle worker looks for work (`OSMAB_POLL_MS`).
    pub poll_ms: u64,
    /// How long shutdown waits for running jobs before releasing them (`OSMAB_SHUTDOWN_GRACE_SECS`).
    pub shutdown_grace_secs: u64,
    /// Write requests per second per client address (`OSMAB_RATE_LIMIT`), with a burst of
    /// `OSMAB_RATE_BURST`; 0 turns rate limiting off.
    pub rate_limit: f64,
    pub rate_burst: f64,
    /// Seconds a client has to send a request's headers (`OSMAB_HEADER_TIMEOUT_SECS`);
    /// a connection that trickles them is closed.
    pub header_timeout_secs: u64,
    /// Seconds a request body may stay silent between chunks (`OSMAB_BODY_IDLE_TIMEOUT_SECS`).
    pub body_idle_timeout_secs: u64,
    /// Connections served at once (`OSMAB_MAX_CONNECTIONS`); more wait in the listen queue.
    pub max_connections: usize,
    /// `text` or `json` logs (`OSMAB_LOG_FORMAT`).
    pub log_format: LogFormat,
    /// OpenAI-compatible endpoint and model of the optional VQA answerer and judge
    /// (`OSMAB_LLM_URL`, `OSMAB_LLM_MODEL`; the key in `OSMAB_LLM_API_KEY`, never in files).
    pub llm_url: Option<String>,
    pub llm_model: Option<String>,
    /// `OSMAB_STORAGE_URL=s3://BUCKET/PREFIX`: blobs in an S3-compatible bucket (with the
    /// standard `AWS_*` variables) instead of the data directory, so nodes share nothing
    /// but the bucket and the database.
    pub storage: Option<crate::blobs::ObjectConfig>,
    /// Seconds an unfinished resumable upload is kept after its last byte
    /// (`OSMAB_UPLOAD_EXPIRY_SECS`).
    pub upload_expiry_secs: u64,
    /// Bytes of ground truth a node keeps prepared for scoring (in Z-order) under
    /// `DATA_DIR/cache/prepared-ground-truth` (`OSMAB_GROUND_TRUTH_CACHE_BYTES`); 0 keeps none.
    pub ground_truth_cache_bytes: u64,
    /// What a release config posted through the API or the console may run, call or read
    /// (`OSMAB_RELEASE_ALLOW`, a TOML file; nothing but the bundled asset pack when unset).
    pub release_allow: crate::release_allow::ReleaseAllowList,
    /// Reverse proxies whose `X-Forwarded-Host` and `X-Forwarded-Proto` count
    /// (`OSMAB_TRUSTED_PROXIES`, comma-separated addresses or CIDR networks; none when unset).
    pub trusted_proxies: crate::proxies::TrustedProxies,
}

/// How the service writes its log lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LogFormat {
    /// Plain text, one event a line (what a terminal or a plain collector reads).
    Text,
    /// JSON lines.
    Json,
}

impl std::str::FromStr for LogFormat {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "text" => Ok(LogFormat::Text),
            "json" => Ok(LogFormat::Json),
            other => Err(format!("the log format is 'text' or 'json', not '{other}'")),
        }
    }
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSettings {
    bind: Option<String>,
    public_url: Option<String>,
    data_dir: Option<PathBuf>,
    assets_root: Option<PathBuf>,
    database_url: Option<String>,
    admin_token: Option<String>,
    workers: Option<usize>,
    demo: Option<bool>,
    daily_quota: Option<i64>,
    val_quota: Option<i64>,
    max_upload_bytes: Option<u64>,
    max_unpacked_bytes: Option<u64>,
    max_expansion_ratio: Option<u64>,
    max_open_uploads: Option<i64>,
    max_open_upload_bytes: Option<u64>,
    job_lease_secs: Option<u64>,
    job_max_attempts: Option<i64>,
    poll_ms: Option<u64>,
    shutdown_grace_secs: Option<u64>,
    rate_limit: Option<f64>,
    rate_burst: Option<f64>,
    header_timeout_secs: Option<u64>,
    body_idle_timeout_secs: Option<u64>,
    max_connections: Option<usize>,
    log_format: Option<LogFormat>,
    llm_url: Option<String>,
    llm_model: Option<String>,
    storage_url: Option<String>,
    upload_expiry_secs: Option<u64>,
    ground_truth_cache_bytes: Option<u64>,
    release_allow: Option<PathBuf>,
    trusted_proxies: Option<Vec<String>>,
}

/// `url` as an origin (`https://host[:port]`, the default port left out), or why it is not
/// one: the service's public address, without a path, query or credentials.
pub fn public_origin(url: &str) -> anyhow::Result<String> {
    osmab_api::receipts::origin(url).map_err(|why| anyhow::anyhow!("OSMAB_PUBLIC_URL: {why}"))
}

/// The value of setting `name` from its text.
fn parse<T: std::str::FromStr>(name: &str, text: &str) -> anyhow::Result<T>
where
    T::Err: std::fmt::Display,
{
    text.trim().parse().map_err(|e| anyhow::anyhow!("{name}: cannot read '{text}': {e}"))
}

impl FileSettings {
    /// The settings of `file`; none without one.
    fn read(file: Option<&Path>) -> anyhow::Result<FileSettings> {
        let Some(path) = file else { return Ok(FileSettings::default()) };
        let text = std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: cannot read the configuration: {e}", path.display()))?;
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }
}

impl Settings {
    /// Defaults, then `file` (if given), then the environment.
    pub fn load(file: Option<&Path>) -> anyhow::Result<Self> {
        Self::load_from(file, &|name| std::env::var(name).ok())
    }

    /// As [`Settings::load`] with the environment given as a lookup (for tests).
    pub fn load_from(file: Option<&Path>, env: &dyn Fn(&str) -> Option<String>) -> anyhow::Result<Self> {
        let from_file = FileSettings::read(file)?;
        macro_rules! layer {
            ($env:literal, $file:expr, $default:expr) => {
                match env($env) {
                    Some(text) if !text.trim().is_empty() => parse($env, &text)?,
                    _ => $file.unwrap_or($default),
                }
            };
        }
        let bind_text: String = layer!("OSMAB_BIND", from_file.bind.clone(), "127.0.0.1:8080".to_string());
        let bind = parse("OSMAB_BIND", &bind_text)?;
        let public_url = match env("OSMAB_PUBLIC_URL").filter(|s| !s.trim().is_empty()).or(from_file.public_url.clone()) {
            Some(url) => Some(public_origin(url.trim())?),
            None => None,
        };
        let data_dir: PathBuf = layer!("OSMAB_DATA_DIR", from_file.data_dir.clone(), PathBuf::from("./osmab-data"));
        let database_url: String = match env("DATABASE_URL").filter(|s| !s.trim().is_empty()).or(from_file.database_url.clone()) {
            Some(url) => url,
            None => format!("sqlite://{}", data_dir.join("osmab.db").display()),
        };
        let storage = match env("OSMAB_STORAGE_URL").filter(|s| !s.trim().is_empty()).or(from_file.storage_url.clone()) {
            Some(url) => Some(crate::blobs::ObjectConfig::parse(url.trim(), env).map_err(|e| anyhow::anyhow!(e))?),
            None => None,
        };
        let release_allow = match env("OSMAB_RELEASE_ALLOW").filter(|s| !s.trim().is_empty()).map(PathBuf::from).or(from_file.release_allow.clone()) {
            Some(path) => crate::release_allow::ReleaseAllowList::read(&path)?,
            None => Default::default(),
        };
        let trusted_proxies = match env("OSMAB_TRUSTED_PROXIES").filter(|s| !s.trim().is_empty()) {
            Some(text) => crate::proxies::TrustedProxies::parse(&text)?,
            None => crate::proxies::TrustedProxies::from_entries(from_file.trusted_proxies.iter().flatten().map(String::as_str))?,
        };
        let admin_token = env("OSMAB_ADMIN_TOKEN").filter(|s| !s.trim().is_empty()).or(from_file.admin_token.clone()).map(Secret::new);
        let settings = Self {
            bind,
            public_url,
            data_dir,
            assets_root: layer!("OSMAB_ASSETS_ROOT", from_file.assets_root.clone(), PathBuf::from(".")),
            database_url: Secret::new(database_url),
            admin_token,
            workers: layer!("OSMAB_WORKERS", from_file.workers, 1),
            demo: layer!("OSMAB_DEMO", from_file.demo, true),
            daily_quota: layer!("OSMAB_DAILY_QUOTA", from_file.daily_quota, 5),
            val_quota: layer!("OSMAB_VAL_QUOTA", from_file.val_quota, 50),
            max_upload_bytes: layer!("OSMAB_MAX_UPLOAD_BYTES", from_file.max_upload_bytes, 4 << 30),
            max_unpacked_bytes: layer!("OSMAB_MAX_UNPACKED_BYTES", from_file.max_unpacked_bytes, 16 << 30),
            max_expansion_ratio: layer!("OSMAB_MAX_EXPANSION_RATIO", from_file.max_expansion_ratio, 200),
            max_open_uploads: layer!("OSMAB_MAX_OPEN_UPLOADS", from_file.max_open_uploads, 4),
            max_open_upload_bytes: layer!("OSMAB_MAX_OPEN_UPLOAD_BYTES", from_file.max_open_upload_bytes, 8 << 30),
            job_lease_secs: layer!("OSMAB_JOB_LEASE_SECS", from_file.job_lease_secs, 60),
            job_max_attempts: layer!("OSMAB_JOB_MAX_ATTEMPTS", from_file.job_max_attempts, 3),
            poll_ms: layer!("OSMAB_POLL_MS", from_file.poll_ms, 500),
            shutdown_grace_secs: layer!("OSMAB_SHUTDOWN_GRACE_SECS", from_file.shutdown_grace_secs, 30),
            rate_limit: layer!("OSMAB_RATE_LIMIT", from_file.rate_limit, 20.0),
            rate_burst: layer!("OSMAB_RATE_BURST", from_file.rate_burst, 60.0),
            header_timeout_secs: layer!("OSMAB_HEADER_TIMEOUT_SECS", from_file.header_timeout_secs, 30),
            body_idle_timeout_secs: layer!("OSMAB_BODY_IDLE_TIMEOUT_SECS", from_file.body_idle_timeout_secs, 60),
            max_connections: layer!("OSMAB_MAX_CONNECTIONS", from_file.max_connections, 1024),
            log_format: layer!("OSMAB_LOG_FORMAT", from_file.log_format, LogFormat::Text),
            llm_url: env("OSMAB_LLM_URL").filter(|s| !s.trim().is_empty()).or(from_file.llm_url.clone()),
            llm_model: env("OSMAB_LLM_MODEL").filter(|s| !s.trim().is_empty()).or(from_file.llm_model.clone()),
            storage,
            upload_expiry_secs: layer!("OSMAB_UPLOAD_EXPIRY_SECS", from_file.upload_expiry_secs, 24 * 3600),
            ground_truth_cache_bytes: layer!("OSMAB_GROUND_TRUTH_CACHE_BYTES", from_file.ground_truth_cache_bytes, 8 << 30),
            release_allow,
            trusted_proxies,
        };
        settings.check()?;
        Ok(settings)
    }

    fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(self.daily_quota >= 0, "daily_quota must be 0 or more, found {}", self.daily_quota);
        anyhow::ensure!(self.val_quota >= 0, "val_quota must be 0 or more, found {}", self.val_quota);
        anyhow::ensure!(self.job_lease_secs >= 1, "job_lease_secs must be at least 1");
        anyhow::ensure!(self.job_max_attempts >= 1, "job_max_attempts must be at least 1");
        anyhow::ensure!(self.poll_ms >= 10, "poll_ms must be at least 10");
        anyhow::ensure!(self.rate_limit >= 0.0 && self.rate_burst >= 1.0, "rate_limit must be 0 or more and rate_burst at least 1");
        anyhow::ensure!(self.header_timeout_secs >= 1 && self.body_idle_timeout_secs >= 1, "header_timeout_secs and body_idle_timeout_secs must be at least 1");
        anyhow::ensure!(self.upload_expiry_secs >= 60, "upload_expiry_secs must be at least 60");
        anyhow::ensure!(self.max_open_uploads >= 1, "max_open_uploads must be at least 1");
        anyhow::ensure!(self.max_expansion_ratio >= 2, "max_expansion_ratio must be at least 2");
        anyhow::ensure!(
            self.max_open_upload_bytes >= self.max_upload_bytes,
            "max_open_upload_bytes ({}) must be at least max_upload_bytes ({}), or no upload of the largest size could start",
            self.max_open_upload_bytes,
            self.max_upload_bytes
        );
        anyhow::ensure!(self.max_connections >= 1, "max_connections must be at least 1");
        anyhow::ensure!(self.llm_url.is_some() == self.llm_model.is_some(), "llm_url and llm_model go together (OSMAB_LLM_URL, OSMAB_LLM_MODEL)");
        if let Some(token) = &self.admin_token {
            crate::token::check_configured(token.expose()).map_err(|why| anyhow::anyhow!("OSMAB_ADMIN_TOKEN {why}"))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &'static [(&'static str, &'static str)]) -> impl Fn(&str) -> Option<String> {
        move |name| pairs.iter().find(|(k, _)| *k == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn defaults_are_the_embedded_service() {
        let s = Settings::load_from(None, &env(&[])).unwrap();
        assert_eq!(s.bind.to_string(), "127.0.0.1:8080");
        assert_eq!(s.data_dir, PathBuf::from("./osmab-data"));
        assert_eq!(s.assets_root, PathBuf::from("."), "a relative asset pack is read in the working folder");
        assert_eq!(s.database_url.expose(), "sqlite://./osmab-data/osmab.db");
        assert_eq!((s.workers, s.demo, s.daily_quota), (1, true, 5));
        assert_eq!(s.public_url, None, "`serve` names the address it listens on");
    }

    #[test]
    fn the_public_url_is_an_origin() {
        let s = Settings::load_from(None, &env(&[("OSMAB_PUBLIC_URL", "HTTPS://Osmab.Example.org:443/")])).unwrap();
        assert_eq!(s.public_url.as_deref(), Some("https://osmab.example.org"));
        for bad in ["osmab.example.org", "ftp://osmab.example.org", "https://osmab.example.org/board", "https://u:p@osmab.example.org", "https://x.org/?a=1"] {
            let err = public_origin(bad).unwrap_err().to_string();
            assert!(err.starts_with("OSMAB_PUBLIC_URL") && err.contains(bad), "{bad}: {err}");
        }
    }

    #[test]
    fn environment_overrides_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("osmab.toml");
        std::fs::write(&file, "bind = \"0.0.0.0:9000\"\ndaily_quota = 7\nworkers = 2\n").unwrap();
        let s = Settings::load_from(Some(&file), &env(&[("OSMAB_DAILY_QUOTA", "9")])).unwrap();
        assert_eq!(s.bind.to_string(), "0.0.0.0:9000");
        assert_eq!((s.daily_quota, s.workers), (9, 2));
    }

    #[test]
    fn unknown_file_keys_and_bad_values_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("osmab.toml");
        std::fs::write(&file, "bnd = \"x\"\n").unwrap();
        assert!(Settings::load_from(Some(&file), &env(&[])).unwrap_err().to_string().contains("bnd"));
        let err = Settings::load_from(None, &env(&[("OSMAB_WORKERS", "many")])).unwrap_err().to_string();
        assert!(err.contains("OSMAB_WORKERS") && err.contains("many"), "{err}");
    }

    #[test]
    fn a_log_format_is_text_or_json_and_a_typo_is_refused() {
        assert_eq!(Settings::load_from(None, &env(&[])).unwrap().log_format, LogFormat::Text);
        assert_eq!(Settings::load_from(None, &env(&[("OSMAB_LOG_FORMAT", "json")])).unwrap().log_format, LogFormat::Json);
        let err = Settings::load_from(None, &env(&[("OSMAB_LOG_FORMAT", "jsno")])).unwrap_err().to_string();
        assert!(err.contains("OSMAB_LOG_FORMAT") && err.contains("'text' or 'json', not 'jsno'"), "{err}");
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("osmab.toml");
        std::fs::write(&file, "log_format = \"JSON\"\n").unwrap();
        let err = format!("{:#}", Settings::load_from(Some(&file), &env(&[])).unwrap_err());
        assert!(err.contains("log_format") || err.contains("JSON"), "{err}");
    }

    #[test]
    fn secrets_never_print() {
        let s =
            Settings::load_from(None, &env(&[("OSMAB_ADMIN_TOKEN", "osmab_adminadminadminadminadmin1"), ("DATABASE_URL", "postgres://u:pw@db/x")])).unwrap();
        let shown = format!("{s:?}");
        assert!(!shown.contains("adminadmin") && !shown.contains("pw@"), "{shown}");
        assert_eq!(redact_url("postgres://u:pw@db:5432/x"), "postgres://u:[redacted]@db:5432/x");
    }
}
