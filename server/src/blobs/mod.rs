//! Blob storage: release files, sequence archives, ground truth, uploaded submissions,
//! resumable-upload parts and release builds, addressed by '/'-separated keys. Two
//! backends behind one set of methods: a local directory (the embedded default, or a
//! volume every node shares) and an S3-compatible bucket (`OSMAB_STORAGE_URL=s3://…`),
//! with which nodes share nothing but the bucket and the database. Either way each
//! process has scratch space of its own ([`ScratchSpace`]), and work that needs files on
//! disk (validation, scoring, rendering) gets local copies: [`Blobs::fetch`] for one blob,
//! [`Blobs::release`] for the part of a release a scorer reads, [`Blobs::pull_tree`] and
//! [`Blobs::push_tree`] for a release build shared by the nodes that render it.

mod local;
mod object;
mod scratch;

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use bytes::Bytes;
use futures_util::stream::{BoxStream, StreamExt, TryStreamExt};

pub use object::{ObjectConfig, StoredObject, Unavailable};
pub use scratch::{Scratch, ScratchSpace};

use local::LocalBlobs;
use object::{ObjectBlobs, files_under};

#[derive(Debug, Clone)]
enum Backend {
    Local(LocalBlobs),
    Object(ObjectBlobs),
}

/// The blob store of this node.
#[derive(Debug, Clone)]
pub struct Blobs {
    backend: Backend,
    scratch: ScratchSpace,
    /// Local copies of object-store content (the object backend only).
    cache: PathBuf,
    /// One release download into the cache at a time in this process.
    caching: Arc<tokio::sync::Mutex<()>>,
}

fn check_key(key: &str) -> io::Result<()> {
    let bad = key.is_empty() || key.starts_with('/') || key.split('/').any(|part| part.is_empty() || part == "." || part == "..") || key.contains('\\');
    if bad { Err(io::Error::new(io::ErrorKind::InvalidInput, format!("'{key}' is not a blob key"))) } else { Ok(()) }
}

/// Whether `error` is the object store being away (answered 503, retried), not a defect.
pub fn unavailable(error: &io::Error) -> bool {
    error.get_ref().is_some_and(|inner| inner.is::<Unavailable>())
}

/// A blob as a local file: the stored file itself (local backend) or a downloaded copy,
/// removed when this is dropped.
pub struct Fetched {
    path: PathBuf,
    _copy: Option<Scratch>,
}

impl Fetched {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Whether a scorer needs the release file at `path` (relative to the release): all but
/// the sequence frames and archives, which participants download and scoring never reads.
fn scorer_reads(path: &str) -> bool {
    match path.split('/').next() {
        Some("archives") => false,
        Some("sequences") => path.ends_with("/camera_params.yaml"),
        _ => true,
    }
}

impl Blobs {
    /// The local directory `data_dir/blobs`, with scratch space inside it (one filesystem,
    /// so stored files are renames).
    pub fn local(data_dir: &Path) -> io::Result<Self> {
        let root = data_dir.join("blobs");
        let scratch = ScratchSpace::open(&root.join(".incoming"))?;
        Ok(Self { backend: Backend::Local(LocalBlobs { root }), scratch, cache: data_dir.join("cache"), caching: Arc::default() })
    }

    /// The bucket of `config`, with scratch space and a cache in `data_dir`.
    pub fn object(data_dir: &Path, config: ObjectConfig) -> anyhow::Result<Self> {
        let store = ObjectBlobs::open(config).map_err(|e| anyhow::anyhow!(e))?;
        let scratch = ScratchSpace::open(&data_dir.join("scratch"))?;
        Ok(Self { backend: Backend::Object(store), scratch, cache: data_dir.join("cache"), caching: Arc::default() })
    }

    /// Where the blobs are, for logs and the readiness answer.
    pub fn describe(&self) -> String {
        match &self.backend {
            Backend::Local(local) => format!("local directory {}", local.root.display()),
            Backend::Object(object) => {
                let at = object.config.endpoint.as_deref().unwrap_or("AWS");
                format!("s3://{}/{} at {at}", object.config.bucket, object.config.prefix)
            }
        }
    }

    /// Whether nodes share nothing but this store (an object store), so builds and caches
    /// are synchronised through it.
    pub fn is_object_store(&self) -> bool {
        matches!(self.backend, Backend::Object(_))
    }

    /// A fresh path in this process's scratch space.
    pub fn scratch(&self, name: &str) -> PathBuf {
        self.scratch.path(name)
    }

    /// Remove scratch left by processes that ended; see [`ScratchSpace::sweep`].
    pub fn sweep_scratch(&self, age: std::time::Duration) -> usize {
        self.scratch.sweep(age)
    }

    /// Store `source` (a scratch file, consumed) as `key`; a key is written once.
    pub async fn put_file(&self, key: &str, source: &Path) -> io::Result<()> {
        check_key(key)?;
        match &self.backend {
            Backend::Local(local) => {
                let (local, key, source) = (local.clone(), key.to_string(), source.to_path_buf());
                tokio::task::spawn_blocking(move || local.put_file(&key, &source)).await.map_err(io::Error::other)?
            }
            Backend::Object(object) => {
                if object.exists(key).await? {
                    return Err(io::Error::new(io::ErrorKind::AlreadyExists, format!("blob '{key}' exists")));
                }
                object.upload(key, source).await?;
                let _ = tokio::fs::remove_file(source).await;
                Ok(())
            }
        }
    }

    /// Store `source` (a scratch file, consumed) as `key` in place of the blob there: only
    /// for a repair that keeps the key's meaning (an archive repacked to hold exactly what
    /// its manifest lists), never to change published content.
    pub async fn replace_file(&self, key: &str, source: &Path) -> io::Result<()> {
        check_key(key)?;
        match &self.backend {
            Backend::Local(local) => {
                let (local, key, source) = (local.clone(), key.to_string(), source.to_path_buf());
                tokio::task::spawn_blocking(move || local.replace_file(&key, &source)).await.map_err(io::Error::other)?
            }
            Backend::Object(object) => {
                object.upload(key, source).await?;
                let _ = tokio::fs::remove_file(source).await;
                Ok(())
            }
        }
    }

    /// Store the folder `source` (a scratch folder, consumed) under `prefix`, which holds
    /// nothing yet.
    pub async fn put_dir(&self, prefix: &str, source: &Path) -> io::Result<()> {
        check_key(prefix)?;
        match &self.backend {
            Backend::Local(local) => {
                let (local, prefix, source) = (local.clone(), prefix.to_string(), source.to_path_buf());
                tokio::task::spawn_blocking(move || local.put_dir(&prefix, &source)).await.map_err(io::Error::other)?
            }
            Backend::Object(object) => {
                object.upload_dir(prefix, source).await?;
                let source = source.to_path_buf();
                let _ = tokio::task::spawn_blocking(move || std::fs::remove_dir_all(source)).await;
                Ok(())
            }
        }
    }

    /// Remove every blob under `prefix/`.
    pub async fn remove_prefix(&self, prefix: &str) -> io::Result<()> {
        check_key(prefix)?;
        match &self.backend {
            Backend::Local(local) => {
                let (local, prefix) = (local.clone(), prefix.to_string());
                tokio::task::spawn_blocking(move || local.remove_prefix(&prefix)).await.map_err(io::Error::other)?
            }
            Backend::Object(object) => object.remove_prefix(prefix).await,
        }
    }

    /// `key` as a local file (`NotFound` when there is no such blob).
    pub async fn fetch(&self, key: &str) -> io::Result<Fetched> {
        check_key(key)?;
        match &self.backend {
            Backend::Local(local) => {
                let path = local.path(key);
                if !tokio::fs::try_exists(&path).await? {
                    return Err(io::Error::new(io::ErrorKind::NotFound, format!("blob '{key}' is missing")));
                }
                Ok(Fetched { path, _copy: None })
            }
            Backend::Object(object) => {
                let copy = Scratch(self.scratch("fetch"));
                object.download(key, &copy.0).await?;
                Ok(Fetched { path: copy.0.clone(), _copy: Some(copy) })
            }
        }
    }

    /// `length` bytes of `key` from `start`, streamed.
    pub async fn read(&self, key: &str, start: u64, length: u64) -> io::Result<BoxStream<'static, io::Result<Bytes>>> {
        use tokio::io::{AsyncReadExt, AsyncSeekExt};
        check_key(key)?;
        match &self.backend {
            Backend::Local(local) => {
                let mut file = tokio::fs::File::open(local.path(key)).await?;
                if start > 0 {
                    file.seek(io::SeekFrom::Start(start)).await?;
                }
                Ok(tokio_util::io::ReaderStream::with_capacity(file.take(length), 256 * 1024).boxed())
            }
            Backend::Object(object) => object.read(key, start, length).await,
        }
    }

    /// A local folder with what scoring and validation read of release `version`
    /// (manifest, classes, questions, ground truth, camera parameters), or `None` when
    /// there is no such release in the store. From the object store it is downloaded
    /// once per node and kept (a stored release never changes).
    pub async fn release(&self, version: &str) -> io::Result<Option<PathBuf>> {
        crate::release_names::check_version(version).map_err(|m| io::Error::new(io::ErrorKind::InvalidInput, m))?;
        let prefix = crate::release_names::release_prefix(version);
        let object = match &self.backend {
            Backend::Local(local) => {
                let dir = local.path(&prefix);
                return Ok(tokio::fs::try_exists(dir.join("manifest.json")).await?.then_some(dir));
            }
            Backend::Object(object) => object,
        };
        let dir = self.cache.join("releases").join(version);
        if tokio::fs::try_exists(dir.join("manifest.json")).await? {
            return Ok(Some(dir));
        }
        let _one_at_a_time = self.caching.lock().await;
        if tokio::fs::try_exists(dir.join("manifest.json")).await? {
            return Ok(Some(dir));
        }
        let listed = object.list(&prefix).await?;
        if !listed.iter().any(|(path, _)| path == "manifest.json") {
            return Ok(None);
        }
        let partial = self.cache.join("releases").join(format!(".partial-{version}-{}", crate::clock::random_alphanumeric(8)));
        let wanted: Vec<String> = listed.into_iter().map(|(path, _)| path).filter(|path| scorer_reads(path)).collect();
        let count = wanted.len();
        let downloads: Vec<(String, PathBuf)> = wanted.into_iter().map(|path| (format!("{prefix}/{path}"), partial.join(&path))).collect();
        let downloaded = futures_util::stream::iter(downloads.into_iter().map(|(key, target)| async move { object.download(&key, &target).await }))
            .buffer_unordered(object::CONCURRENT_REQUESTS)
            .try_collect::<Vec<()>>()
            .await;
        if let Err(e) = downloaded {
            let _ = tokio::fs::remove_dir_all(&partial).await;
            return Err(e);
        }
        tokio::fs::rename(&partial, &dir).await?;
        tracing::info!(release = version, files = count, "release cached from the object store");
        Ok(Some(dir))
    }

    /// [`Blobs::release`] from blocking code running on the runtime's blocking threads.
    pub fn release_blocking(&self, version: &str) -> io::Result<Option<PathBuf>> {
        tokio::runtime::Handle::current().block_on(self.release(version))
    }

    /// Upload the files under `dir` that the store lacks under `prefix/` (or holds with
    /// another size): how a node shares a release build with the others. Nothing to do on
    /// a local store, whose nodes share the data directory.
    pub async fn push_tree(&self, prefix: &str, dir: &Path) -> io::Result<usize> {
        check_key(prefix)?;
        let Backend::Object(object) = &self.backend else { return Ok(0) };
        let stored: std::collections::HashMap<String, u64> = object.list(prefix).await?.into_iter().collect();
        let dir_owned = dir.to_path_buf();
        let local = tokio::task::spawn_blocking(move || files_under(&dir_owned)).await.map_err(io::Error::other)??;
        let mut missing = Vec::new();
        for (rel, path) in local {
            let size = tokio::fs::metadata(&path).await?.len();
            if stored.get(&rel) != Some(&size) {
                missing.push((rel, path));
            }
        }
        let count = missing.len();
        futures_util::stream::iter(missing.into_iter().map(|(rel, path)| async move { object.upload(&format!("{prefix}/{rel}"), &path).await }))
            .buffer_unordered(object::CONCURRENT_REQUESTS)
            .try_collect::<Vec<()>>()
            .await?;
        Ok(count)
    }

    /// Download the files under `prefix/` that `dir` lacks (or holds with another size).
    /// Nothing to do on a local store.
    pub async fn pull_tree(&self, prefix: &str, dir: &Path) -> io::Result<usize> {
        check_key(prefix)?;
        let Backend::Object(object) = &self.backend else { return Ok(0) };
        let mut missing = Vec::new();
        for (rel, size) in object.list(prefix).await? {
            check_key(&rel)?;
            let target = dir.join(&rel);
            if tokio::fs::metadata(&target).await.map(|m| m.len()).ok() != Some(size) {
                missing.push((rel, target));
            }
        }
        let count = missing.len();
        futures_util::stream::iter(missing.into_iter().map(|(rel, target)| async move { object.download(&format!("{prefix}/{rel}"), &target).await }))
            .buffer_unordered(object::CONCURRENT_REQUESTS)
            .try_collect::<Vec<()>>()
            .await?;
        Ok(count)
    }

    /// Every object of an object store (none for a local store, whose files a backup copies).
    pub async fn inventory(&self) -> io::Result<Option<Vec<StoredObject>>> {
        match &self.backend {
            Backend::Object(object) => object.inventory().await.map(Some),
            Backend::Local(_) => Ok(None),
        }
    }

    /// `key` as an object store holds it (a local store answers `None`).
    pub async fn stored(&self, key: &str) -> io::Result<Option<StoredObject>> {
        check_key(key)?;
        match &self.backend {
            Backend::Object(object) => object.stored(key).await,
            Backend::Local(_) => Ok(None),
        }
    }

    /// Whether scratch space can be written and the store answers (readiness).
    pub async fn check(&self) -> io::Result<()> {
        self.scratch.check()?;
        match &self.backend {
            Backend::Local(_) => Ok(()),
            Backend::Object(object) => object.check().await,
        }
    }

    /// Whether `key` is stored (the local path for tests and tools).
    #[cfg(test)]
    fn local_path(&self, key: &str) -> Option<PathBuf> {
        match &self.backend {
            Backend::Local(local) => Some(local.path(key)),
            Backend::Object(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_cannot_leave_the_store() {
        for key in ["../x", "a/../../x", "/etc/passwd", "a//b", "", "a\\b"] {
            assert!(check_key(key).is_err(), "{key}");
        }
        assert!(check_key("releases/v1/manifest.json").is_ok());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 1)]
    async fn a_blob_is_written_once() {
        let dir = tempfile::tempdir().unwrap();
        let blobs = Blobs::local(dir.path()).unwrap();
        let scratch = blobs.scratch("t");
        std::fs::write(&scratch, b"one").unwrap();
        blobs.put_file("a/b", &scratch).await.unwrap();
        let again = blobs.scratch("t");
        std::fs::write(&again, b"two").unwrap();
        assert_eq!(blobs.put_file("a/b", &again).await.unwrap_err().kind(), io::ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(blobs.local_path("a/b").unwrap()).unwrap(), b"one");
        assert_eq!(std::fs::read(blobs.fetch("a/b").await.unwrap().path()).unwrap(), b"one");
        let middle: Vec<Bytes> = blobs.read("a/b", 1, 1).await.unwrap().try_collect().await.unwrap();
        assert_eq!(middle.concat(), b"n");
        assert_eq!(blobs.fetch("a/c").await.err().unwrap().kind(), io::ErrorKind::NotFound);
    }

    #[test]
    fn a_scorer_reads_ground_truth_and_camera_parameters_not_frames() {
        assert!(scorer_reads("manifest.json") && scorer_reads("ground_truth/s1/semantic.npy") && scorer_reads("questions/s1.json"));
        assert!(scorer_reads("sequences/baseline/s1/camera_params.yaml"));
        assert!(!scorer_reads("sequences/baseline/s1/results/frame000001.jpg") && !scorer_reads("archives/sequences/baseline/s1.tar"));
    }

    #[test]
    fn only_the_object_store_s_own_error_is_unavailable() {
        assert!(unavailable(&io::Error::other(Unavailable("connection refused".into()))));
        assert!(!unavailable(&io::Error::other("disk full")) && !unavailable(&io::Error::from(io::ErrorKind::NotFound)));
    }
}
