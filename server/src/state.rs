//! What every handler and worker shares.

use std::sync::Arc;

use crate::blobs::Blobs;
use crate::config::Settings;
use crate::leaderboard::LeaderboardCache;
use crate::metrics::Metrics;
use crate::rate_limit::RateLimiter;
use crate::receipts::ReceiptKeys;
use crate::store::Store;
use osmab_dataset::release::split::SplitSecret;

/// Shared service state (cheap to clone).
#[derive(Clone)]
pub struct AppState {
    pub settings: Arc<Settings>,
    pub store: Store,
    pub blobs: Blobs,
    pub metrics: Arc<Metrics>,
    pub leaderboard: Arc<LeaderboardCache>,
    pub limiter: Arc<RateLimiter>,
    /// Uploads being unpacked and validated at once.
    pub validation: Arc<tokio::sync::Semaphore>,
    /// The keys that sign score receipts.
    pub receipts: Arc<ReceiptKeys>,
    /// The operator's secret that shapes the test scenes of the releases it builds.
    pub split_secret: SplitSecret,
    /// Resumable uploads a PATCH is arriving for on this server (one at a time each).
    pub uploads_in_flight: Arc<std::sync::Mutex<std::collections::HashSet<String>>>,
}

impl AppState {
    /// State over an opened store and blob directory, with the receipt keys of the data
    /// directory (the first is generated on first start).
    pub fn new(settings: Settings, store: Store, blobs: Blobs) -> anyhow::Result<Self> {
        let limiter = RateLimiter::new(settings.rate_limit, settings.rate_burst);
        let receipts = Arc::new(ReceiptKeys::open(&settings.data_dir.join(crate::receipts::keys::RECEIPT_KEYS))?);
        let split_secret = crate::split_secret::open(&settings.data_dir.join(crate::split_secret::SPLIT_SECRET_DIR))?;
        Ok(Self {
            settings: Arc::new(settings),
            store,
            blobs,
            metrics: Arc::new(Metrics::default()),
            leaderboard: Arc::new(LeaderboardCache::default()),
            limiter: Arc::new(limiter),
            validation: Arc::new(tokio::sync::Semaphore::new(2)),
            receipts,
            split_secret,
            uploads_in_flight: Arc::default(),
        })
    }
}
