//! `osmab serve`, `osmab worker` and `osmab migrate`.

use std::path::PathBuf;

use clap::Args;

use crate::config::{Settings, redact_url};

#[derive(Debug, Args)]
pub struct ServiceArgs {
    /// A TOML settings file (see docs/service.md); environment variables override it.
    #[arg(long, env = "OSMAB_CONFIG")]
    pub config: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct WorkerArgs {
    #[command(flatten)]
    pub service: ServiceArgs,
    /// Jobs run at once in this process.
    #[arg(long, default_value_t = 1)]
    pub concurrency: usize,
}

#[derive(Debug, Args)]
pub struct BackupArgs {
    #[command(flatten)]
    pub service: ServiceArgs,
    /// A new or empty folder to write the backup to.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct RestoreArgs {
    #[command(flatten)]
    pub service: ServiceArgs,
    /// A folder written by `osmab backup`.
    pub backup: PathBuf,
    /// Restore a backup taken before backups were sealed (format osmab-backup/1), trusting
    /// the store it was kept in: nothing vouches for its keys, secrets and database.
    #[arg(long)]
    pub trust_unsealed_backup: bool,
}

/// `osmab backup --out DIR`, sealed with `OSMAB_BACKUP_KEY`.
pub fn backup(args: BackupArgs) -> anyhow::Result<()> {
    let settings = settings(&args.service)?;
    let key = crate::backup::BackupKey::from_env()?;
    let manifest = runtime()?.block_on(crate::backup::backup(&settings, &args.out, &key))?;
    let bytes: u64 = manifest.files.iter().map(|f| f.size).sum();
    println!(
        "{}: backup of {} files ({bytes} bytes, {} database), listed in {} and sealed with backup key {}: keep that key apart from the backups",
        args.out.display(),
        manifest.files.len(),
        manifest.database,
        crate::backup::MANIFEST,
        key.id()
    );
    Ok(())
}

/// `osmab restore DIR`.
pub fn restore(args: RestoreArgs) -> anyhow::Result<()> {
    let settings = settings(&args.service)?;
    let trust = crate::backup::Trust { key: crate::backup::BackupKey::from_env_if_set()?, unsealed_store: args.trust_unsealed_backup };
    let manifest = runtime()?.block_on(crate::backup::restore(&settings, &args.backup, &trust))?;
    println!(
        "{}: restored {} files of the backup taken {} into {}; start the service with `osmab serve`",
        args.backup.display(),
        manifest.files.len(),
        manifest.created_at,
        settings.data_dir.display()
    );
    Ok(())
}

/// A multi-threaded runtime for the service.
pub fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_multi_thread().enable_all().build()?)
}

fn settings(args: &ServiceArgs) -> anyhow::Result<Settings> {
    let settings = Settings::load(args.config.as_deref())?;
    crate::telemetry::init(settings.log_format);
    Ok(settings)
}

pub fn serve(args: ServiceArgs) -> anyhow::Result<()> {
    let settings = settings(&args)?;
    runtime()?.block_on(crate::serve::serve(settings))
}

pub fn worker(args: WorkerArgs) -> anyhow::Result<()> {
    let settings = settings(&args.service)?;
    runtime()?.block_on(crate::serve::work(settings, args.concurrency))
}

/// `osmab rotate-receipt-key`: a new key in the data directory's `receipt-keys/`.
pub fn rotate_receipt_key(args: ServiceArgs) -> anyhow::Result<()> {
    let settings = settings(&args)?;
    let dir = settings.data_dir.join(crate::receipts::keys::RECEIPT_KEYS);
    let path = crate::receipts::keys::generate(&dir)?;
    if let Some(config) = &settings.storage {
        // Shared with every node through the object store.
        let blobs = crate::blobs::Blobs::object(&settings.data_dir, config.clone())?;
        runtime()?.block_on(crate::serve::share_receipt_keys(&blobs, &dir))?;
    }
    println!("{}", path.display());
    eprintln!("New receipt-signing key written; restart the servers to sign with it (receipts of the old keys still verify).");
    Ok(())
}

pub fn migrate(args: ServiceArgs) -> anyhow::Result<()> {
    let settings = settings(&args)?;
    runtime()?.block_on(async {
        let state = crate::serve::open(settings).await?;
        println!("{}: migrations applied", redact_url(state.settings.database_url.expose()));
        state.store.close().await;
        Ok(())
    })
}

pub fn import(dir: &std::path::Path, publish: bool, args: ServiceArgs) -> anyhow::Result<()> {
    let settings = settings(&args)?;
    runtime()?.block_on(async {
        let state = crate::serve::open(settings).await?;
        let outcome = crate::releases::import_release(&state.store, &state.blobs, dir, crate::releases::Provenance::External, publish).await;
        state.store.close().await;
        match outcome? {
            crate::releases::Imported::New(version) => println!("release {version} imported{}", if publish { " and published" } else { " as a draft" }),
            crate::releases::Imported::Unchanged(version) => println!("release {version} was already imported (same digest)"),
        }
        Ok(())
    })
}
