//! Starting the service: open the store and the blobs, make sure an admin token exists,
//! queue the demo release on an empty database, run the in-process workers and the HTTP
//! server, and on SIGINT/SIGTERM stop accepting requests, let running jobs finish within
//! the grace period and release the rest for other workers.

use std::io::Write;
use std::time::Duration;

use anyhow::Context;
use tokio::sync::watch;

use crate::auth::issue_token;
use crate::blobs::Blobs;
use crate::clock::now_ms;
use crate::config::{Settings, redact_url};
use crate::jobs::Job;
use crate::jobs::release_build::{BuildRelease, DEMO_CONFIG};
use crate::receipts::keys::RECEIPT_KEYS;
use crate::state::AppState;
use crate::store::{Store, TokenRecord};

/// Open the database (migrated) and the blob storage of `settings`.
pub async fn open(settings: Settings) -> anyhow::Result<AppState> {
    open_data_dir(&settings.data_dir)?;
    let url = settings.database_url.expose().to_string();
    let store = Store::connect(&url).await.with_context(|| format!("cannot open the database {}", redact_url(&url)))?;
    store.migrate().await.context("cannot apply the database migrations")?;
    let blobs = match &settings.storage {
        None => Blobs::local(&settings.data_dir).context("cannot open the blob storage")?,
        Some(config) => Blobs::object(&settings.data_dir, config.clone()).context("cannot open the object storage")?,
    };
    // Scratch of processes that died (kill -9 included) goes now; loose old-layout
    // entries after six hours.
    let swept = blobs.sweep_scratch(Duration::from_secs(6 * 3600));
    if swept > 0 {
        tracing::info!(swept, "removed scratch files left by processes that died");
    }
    if blobs.is_object_store() {
        share_receipt_keys(&blobs, &settings.data_dir.join(RECEIPT_KEYS)).await?;
        crate::split_secret::share(&blobs, &settings.data_dir.join(crate::split_secret::SPLIT_SECRET_DIR)).await?;
    }
    tracing::info!(database = %redact_url(&url), backend = store.backend(), data_dir = %settings.data_dir.display(), blobs = %blobs.describe(), "store opened");
    AppState::new(settings, store, blobs)
}

/// The file in the data directory where `serve` writes the URL it answers at, so the
/// admin commands on the same machine find it whatever `OSMAB_BIND` said.
pub const LISTENING_FILE: &str = "listening";

/// Write the URL this server answers at locally (an unspecified bind address as loopback).
fn write_listening(data_dir: &std::path::Path, address: std::net::SocketAddr) {
    let mut local = address;
    if local.ip().is_unspecified() {
        local.set_ip(if local.is_ipv4() { std::net::Ipv4Addr::LOCALHOST.into() } else { std::net::Ipv6Addr::LOCALHOST.into() });
    }
    if let Err(e) = std::fs::write(data_dir.join(LISTENING_FILE), format!("http://{local}\n")) {
        tracing::warn!(error = %e, "cannot write where the service listens; admin commands need --url");
    }
}

/// The URL a `serve` with this data directory said it answers at, if one did.
pub fn listening_url(data_dir: &std::path::Path) -> Option<String> {
    let text = std::fs::read_to_string(data_dir.join(LISTENING_FILE)).ok()?;
    Some(text.trim().to_string()).filter(|url| url.starts_with("http://") && !url.contains(char::is_whitespace))
}

/// Create the data directory owner-only, or repair it and the secret folders in it: it
/// holds the hidden test ground truth, the database, uploads and the keys, which no other
/// local user may read.
pub fn open_data_dir(data_dir: &std::path::Path) -> anyhow::Result<()> {
    let owner_only =
        |dir: &std::path::Path| crate::secret_files::owner_only_dir(dir).with_context(|| format!("cannot create or make owner-only {}", dir.display()));
    if owner_only(data_dir)? {
        tracing::warn!(dir = %data_dir.display(), "the data directory was readable by other users; made it owner-only (0700)");
    }
    for secrets in [RECEIPT_KEYS, crate::split_secret::SPLIT_SECRET_DIR] {
        let dir = data_dir.join(secrets);
        if dir.is_dir() && owner_only(&dir)? {
            tracing::warn!(dir = %dir.display(), "a secret folder was readable by other users; made it owner-only (0700)");
        }
    }
    Ok(())
}

/// Nodes that share only an object store share its receipt keys, so a receipt any server
/// signed verifies against the keys every server publishes: this node's copy is brought
/// up to date; the first node to start generates the first key and shares it (two
/// starting at once each share one, and both then sign with the newer).
pub async fn share_receipt_keys(blobs: &Blobs, dir: &std::path::Path) -> anyhow::Result<()> {
    let has_key =
        |dir: &std::path::Path| Ok(std::fs::read_dir(dir).map(|d| d.flatten().any(|e| e.path().extension().is_some_and(|x| x == "seed"))).unwrap_or(false));
    crate::secret_files::share_folder(blobs, RECEIPT_KEYS, dir, "receipt keys", has_key, crate::receipts::keys::generate).await
}

/// Record id of the admin token given by `OSMAB_ADMIN_TOKEN`.
const CONFIGURED_ADMIN_TOKEN: &str = "tok_configured_admin";

/// Make sure an admin token exists: the configured one (stored hashed), or on first
/// start a generated one written once to an owner-only file.
pub async fn ensure_admin_token(state: &AppState) -> anyhow::Result<()> {
    if let Some(token) = &state.settings.admin_token {
        // The configured token has a fixed record: changing the setting replaces (and so
        // revokes) the token an earlier configuration set.
        let hash = crate::token::hash(token.expose());
        let current = state.store.tokens(None).await?.into_iter().find(|t| t.id == CONFIGURED_ADMIN_TOKEN);
        if current.is_none_or(|t| t.sha256 != hash || t.revoked_at.is_some()) {
            let record = TokenRecord {
                id: CONFIGURED_ADMIN_TOKEN.into(),
                team_id: None,
                scope: crate::store::TokenScope::Admin,
                sha256: hash,
                hint: crate::token::PREFIX.into(),
                created_at: now_ms(),
                expires_at: None,
                revoked_at: None,
            };
            state.store.replace_token(&record).await?;
        }
        tracing::info!("admin token from the configuration");
        return Ok(());
    }
    let path = state.settings.data_dir.join("admin-token");
    if state.store.tokens(None).await?.iter().any(|t| t.revoked_at.is_none()) {
        tracing::info!(file = %path.display(), "admin token exists (written at first start)");
        return Ok(());
    }
    let (token, record) = issue_token(crate::store::TokenScope::Admin, None, None);
    crate::secret_files::write_new_owner_only(&path, format!("{token}\n").as_bytes())
        .with_context(|| format!("cannot write the admin token to {} (remove a stale file)", path.display()))?;
    state.store.insert_token(&record).await?;
    tracing::warn!(file = %path.display(), "generated an admin token; it is in this owner-only file");
    Ok(())
}

/// On an empty database, queue the demo release build with the baselines.
pub async fn queue_demo(state: &AppState) -> anyhow::Result<()> {
    if !state.store.releases().await?.is_empty() || state.store.jobs(1000).await?.iter().any(|j| j.kind == BuildRelease::KIND) {
        return Ok(());
    }
    crate::jobs::release_build::config_version(DEMO_CONFIG).map_err(anyhow::Error::msg)?;
    say_demo_pack(&state.settings.assets_root);
    let job = crate::jobs::enqueue(state, &BuildRelease { config: DEMO_CONFIG.into(), publish: true, baselines: true }).await?;
    tracing::info!(job = %job, "empty database: the demo release is being built and the baselines scored");
    Ok(())
}

/// Say which asset pack the demo release will draw its furniture from, or that there is
/// none where the settings point (the build would then fail, saying the same).
fn say_demo_pack(assets_root: &std::path::Path) {
    let Ok((config, _)) = osmab_dataset::release::config::ReleaseConfig::parse(DEMO_CONFIG, std::path::Path::new("release-demo.toml")) else { return };
    let Some(pack) = config.synthesis.assets.as_deref() else { return };
    let path = assets_root.join(pack);
    match osmab_dataset::synthesis::source::AssetSource::for_config(Some(pack), assets_root) {
        Ok(source) => tracing::info!(pack = %path.display(), digest = source.digest().unwrap_or_default(), "the demo release draws from this asset pack"),
        Err(e) => tracing::error!(pack = %path.display(), "the demo release cannot be built: {e}"),
    }
}

/// Resolves at SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    let interrupt = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        let mut terminate = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).expect("SIGTERM handler");
        tokio::select! {
            _ = interrupt => {}
            _ = terminate.recv() => {}
        }
    }
    #[cfg(not(unix))]
    let _ = interrupt.await;
    tracing::info!("shutdown requested");
}

fn spawn_workers(state: &AppState, count: usize, shutdown: &watch::Receiver<bool>) -> Vec<tokio::task::JoinHandle<()>> {
    let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "local".into());
    let warmup = std::sync::Arc::new(tokio::sync::Mutex::new(crate::jobs::warmup::Warmup::default()));
    (0..count)
        .map(|i| {
            let owner = format!("{host}:{}:{i}:{}", std::process::id(), crate::clock::random_alphanumeric(6));
            tokio::spawn(crate::jobs::worker::run_worker(state.clone(), owner, warmup.clone(), shutdown.clone()))
        })
        .collect()
}

/// Every minute, on every node (each step is safe to run twice): remove resumable
/// uploads whose time ran out.
fn spawn_housekeeping(state: &AppState, mut shutdown: watch::Receiver<bool>) -> tokio::task::JoinHandle<()> {
    let state = state.clone();
    tokio::spawn(async move {
        loop {
            crate::uploads::sweep_expired(&state).await;
            tokio::select! {
                _ = tokio::time::sleep(Duration::from_secs(60)) => {}
                _ = shutdown.changed() => return,
            }
        }
    })
}

async fn stop_workers(state: &AppState, workers: Vec<tokio::task::JoinHandle<()>>) {
    let grace = Duration::from_secs(state.settings.shutdown_grace_secs + 5);
    for worker in workers {
        if tokio::time::timeout(grace, worker).await.is_err() {
            tracing::warn!("a worker did not stop in time");
        }
    }
}

/// On a service without teams, say where the board is and how the first team is made.
async fn say_how_to_begin(state: &AppState) {
    let Ok(teams) = state.store.teams().await else { return };
    if teams.iter().any(|t| t.name != crate::jobs::release_build::BASELINE_TEAM) {
        return;
    }
    let origin = state.settings.public_url.clone().unwrap_or_default();
    tracing::info!(
        "no teams yet: the leaderboard is at {origin}/ (filled once the demo release is built); create a team with \
         `osmab admin team create \"My lab\" --url {origin}` on this machine (with this server's settings; it prints the team's token once), \
         or through {origin}/admin"
    );
}

/// `osmab serve`.
pub async fn serve(mut settings: Settings) -> anyhow::Result<()> {
    let bind = settings.bind;
    let listener = tokio::net::TcpListener::bind(bind).await.with_context(|| format!("cannot listen on {bind}"))?;
    let address = listener.local_addr()?;
    // Receipts name the service's public origin; without one configured, where it listens.
    settings.public_url.get_or_insert_with(|| format!("http://{address}"));
    let state = open(settings).await?;
    ensure_admin_token(&state).await?;
    // Before anything is served: every stored archive holds exactly its manifest's files.
    let healed = crate::release_archives::heal_stored_archives(&state.store, &state.blobs).await.context("checking the stored releases' archives")?;
    if !healed.repacked.is_empty() {
        tracing::warn!(repacked = healed.repacked.len(), checked = healed.checked, archives = ?healed.repacked, "sequence archives repacked to hold exactly their manifests' files");
    }
    if state.settings.demo {
        queue_demo(&state).await?;
    }
    let (stop, stopped) = watch::channel(false);
    let workers = spawn_workers(&state, state.settings.workers, &stopped);
    let housekeeping = spawn_housekeeping(&state, stopped.clone());
    // One signal stops both: workers stop claiming at once while HTTP drains open requests.
    let http_stopped = stopped.clone();
    tokio::spawn(async move {
        shutdown_signal().await;
        let _ = stop.send(true);
    });
    tracing::info!(%address, workers = state.settings.workers, "serving");
    write_listening(&state.settings.data_dir, address);
    println!("osmab listening on http://{address}");
    say_how_to_begin(&state).await;
    let _ = std::io::stdout().flush();
    let app = crate::routes::router(state.clone());
    let limits = crate::http::Limits {
        header_timeout: Duration::from_secs(state.settings.header_timeout_secs),
        body_idle_timeout: Duration::from_secs(state.settings.body_idle_timeout_secs),
        max_connections: state.settings.max_connections,
    };
    crate::http::serve(listener, app, limits, http_stopped).await;
    stop_workers(&state, workers).await;
    housekeeping.abort();
    state.store.close().await;
    let _ = std::fs::remove_file(state.settings.data_dir.join(LISTENING_FILE));
    tracing::info!("stopped");
    Ok(())
}

/// `osmab worker`: workers only, against the same database and storage.
pub async fn work(settings: Settings, count: usize) -> anyhow::Result<()> {
    let state = open(settings).await?;
    let (stop, stopped) = watch::channel(false);
    let workers = spawn_workers(&state, count.max(1), &stopped);
    let housekeeping = spawn_housekeeping(&state, stopped.clone());
    println!("osmab worker running ({} workers)", count.max(1));
    let _ = std::io::stdout().flush();
    shutdown_signal().await;
    let _ = stop.send(true);
    stop_workers(&state, workers).await;
    housekeeping.abort();
    state.store.close().await;
    Ok(())
}
