//! The S3-compatible backend (`OSMAB_STORAGE_URL=s3://BUCKET/PREFIX`): blobs as objects
//! under a key prefix, through `object_store`. Uploads above [`PART_SIZE`] go as multipart
//! uploads; a folder goes as many concurrent puts with its top-level `manifest.json` last,
//! so a reader that finds the manifest finds the rest. Failures other than "not found"
//! are [`Unavailable`]: the edge answers them with a 503 the client may retry.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use bytes::Bytes;
use futures_util::stream::{BoxStream, StreamExt, TryStreamExt};
use object_store::aws::{AmazonS3, AmazonS3Builder};
use object_store::path::Path as ObjectPath;
use object_store::{ClientOptions, GetOptions, GetRange, ObjectStore, ObjectStoreExt, PutPayload, RetryConfig, WriteMultipart};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// An object as the object store lists it: what a backup of a bucket deployment records.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct StoredObject {
    pub key: String,
    pub size: u64,
    /// The store's entity tag (for single-part uploads to S3, the MD5 of the bytes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub e_tag: Option<String>,
}

/// Objects larger than this are uploaded in parts of this size.
const PART_SIZE: usize = 8 * 1024 * 1024;
/// Requests of one folder's transfer in flight at once. Against moto (the tests' store) 32
/// imported the 5,000-file test release no faster than 8 (41 s vs 47 s): moto takes ~110
/// small PUTs a second however they come.
pub const CONCURRENT_REQUESTS: usize = 8;

/// The object store could not be reached or refused a request (other than "not found").
#[derive(Debug, thiserror::Error)]
#[error("object storage: {0}")]
pub struct Unavailable(pub String);

fn io_error(e: object_store::Error) -> io::Error {
    match e {
        object_store::Error::NotFound { .. } => io::Error::new(io::ErrorKind::NotFound, e.to_string()),
        object_store::Error::AlreadyExists { .. } => io::Error::new(io::ErrorKind::AlreadyExists, e.to_string()),
        other => io::Error::other(Unavailable(other.to_string())),
    }
}

/// Where the objects are and how to reach them: the storage URL and the standard AWS
/// variables.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ObjectConfig {
    pub bucket: String,
    /// Key prefix (no leading or trailing '/'), maybe empty.
    pub prefix: String,
    /// `AWS_ENDPOINT_URL` (an S3-compatible server), or `None` for AWS itself.
    pub endpoint: Option<String>,
    pub allow_http: bool,
}

impl ObjectConfig {
    /// Parse `s3://BUCKET/PREFIX` with `AWS_ENDPOINT_URL` and `AWS_ALLOW_HTTP` from `env`.
    /// A plain `http://` endpoint is allowed on loopback or with `AWS_ALLOW_HTTP=true`.
    pub fn parse(url: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<Self, String> {
        let rest = url
            .strip_prefix("s3://")
            .ok_or_else(|| format!("OSMAB_STORAGE_URL: '{url}' is not s3://BUCKET/PREFIX (leave it unset for the local data directory)"))?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        let bucket_ok = (3..=63).contains(&bucket.len()) && bucket.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '.');
        if !bucket_ok {
            return Err(format!("OSMAB_STORAGE_URL: '{bucket}' is not an S3 bucket name (3-63 lower-case letters, digits, '-' and '.')"));
        }
        let prefix = prefix.trim_matches('/').to_string();
        if prefix.split('/').any(|p| p == "." || p == ".." || (p.is_empty() && !prefix.is_empty())) {
            return Err(format!("OSMAB_STORAGE_URL: the prefix '{prefix}' has an empty, '.' or '..' segment"));
        }
        let endpoint = env("AWS_ENDPOINT_URL").or_else(|| env("AWS_ENDPOINT")).filter(|e| !e.trim().is_empty());
        let allow_http = match env("AWS_ALLOW_HTTP").as_deref().map(str::trim) {
            None | Some("") => false,
            Some("true") => true,
            Some("false") => false,
            Some(other) => return Err(format!("AWS_ALLOW_HTTP: '{other}' is not true or false")),
        };
        let mut allow_plain = allow_http;
        if let Some(endpoint) = &endpoint {
            let Some(host) = endpoint.strip_prefix("http://").or_else(|| endpoint.strip_prefix("https://")) else {
                return Err(format!("AWS_ENDPOINT_URL: '{endpoint}' is not an http:// or https:// URL"));
            };
            if endpoint.starts_with("http://") {
                let authority = host.split('/').next().unwrap_or("");
                let host = match authority.strip_prefix('[') {
                    Some(v6) => v6.split(']').next().unwrap_or(""),
                    None => authority.split(':').next().unwrap_or(""),
                };
                let loopback = host == "localhost" || host.parse::<std::net::IpAddr>().is_ok_and(|ip| ip.is_loopback());
                if !loopback && !allow_http {
                    return Err(format!(
                        "AWS_ENDPOINT_URL: '{endpoint}' is plain http on a host other than loopback; use https, or set AWS_ALLOW_HTTP=true on a private network"
                    ));
                }
                allow_plain = true;
            }
        }
        Ok(Self { bucket: bucket.to_string(), prefix, endpoint, allow_http: allow_plain })
    }
}

/// Blobs as objects under a prefix of one bucket.
#[derive(Debug, Clone)]
pub struct ObjectBlobs {
    store: Arc<AmazonS3>,
    prefix: String,
    pub config: ObjectConfig,
}

impl ObjectBlobs {
    /// A client of the bucket; credentials and region come from the standard AWS
    /// variables (`AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_REGION`, or a web
    /// identity / container role).
    pub fn open(config: ObjectConfig) -> Result<Self, String> {
        let mut builder = AmazonS3Builder::from_env().with_bucket_name(&config.bucket).with_allow_http(config.allow_http);
        if let Ok(region) = std::env::var("AWS_REGION") {
            builder = builder.with_region(region);
        }
        if let Some(endpoint) = &config.endpoint {
            builder = builder.with_endpoint(endpoint).with_virtual_hosted_style_request(false);
        }
        // Fail within seconds when the store is away, so the request gets its 503 and the
        // job its retry rather than hanging.
        let retry = RetryConfig { max_retries: 3, retry_timeout: Duration::from_secs(10), ..Default::default() };
        let options = ClientOptions::new()
            .with_allow_http(config.allow_http)
            .with_connect_timeout(Duration::from_secs(3))
            .with_timeout(Duration::from_secs(120))
            .with_pool_idle_timeout(Duration::from_secs(30));
        let store = builder.with_retry(retry).with_client_options(options).build().map_err(|e| format!("object storage: {e}"))?;
        Ok(Self { store: Arc::new(store), prefix: config.prefix.clone(), config })
    }

    fn location(&self, key: &str) -> ObjectPath {
        if self.prefix.is_empty() { ObjectPath::from(key) } else { ObjectPath::from(format!("{}/{key}", self.prefix)) }
    }

    /// Whether `key` exists.
    pub async fn exists(&self, key: &str) -> io::Result<bool> {
        match self.store.head(&self.location(key)).await {
            Ok(_) => Ok(true),
            Err(object_store::Error::NotFound { .. }) => Ok(false),
            Err(e) => Err(io_error(e)),
        }
    }

    /// Upload the file `source` as `key` (replacing an object of that key).
    pub async fn upload(&self, key: &str, source: &Path) -> io::Result<()> {
        let location = self.location(key);
        let mut file = tokio::fs::File::open(source).await?;
        let size = file.metadata().await?.len();
        if size <= PART_SIZE as u64 {
            let mut bytes = Vec::with_capacity(size as usize);
            file.read_to_end(&mut bytes).await?;
            self.store.put(&location, PutPayload::from(bytes)).await.map_err(io_error)?;
            return Ok(());
        }
        let upload = self.store.put_multipart(&location).await.map_err(io_error)?;
        let mut writer = WriteMultipart::new_with_chunk_size(upload, PART_SIZE);
        let mut buffer = vec![0u8; PART_SIZE];
        let written = async {
            loop {
                let n = file.read(&mut buffer).await?;
                if n == 0 {
                    break;
                }
                writer.wait_for_capacity(4).await.map_err(io_error)?;
                writer.write(&buffer[..n]);
            }
            Ok::<(), io::Error>(())
        }
        .await;
        match written {
            Ok(()) => writer.finish().await.map(|_| ()).map_err(io_error),
            Err(e) => {
                let _ = writer.abort().await;
                Err(e)
            }
        }
    }

    /// Upload every file under `source` to `prefix/<relative path>`, the top-level
    /// `manifest.json` last.
    pub async fn upload_dir(&self, prefix: &str, source: &Path) -> io::Result<usize> {
        let source_owned = source.to_path_buf();
        let mut files = tokio::task::spawn_blocking(move || files_under(&source_owned)).await.map_err(io::Error::other)??;
        let manifest_last = files.iter().position(|(rel, _)| rel == "manifest.json").map(|i| files.remove(i));
        let count = files.len() + usize::from(manifest_last.is_some());
        futures_util::stream::iter(files.into_iter().map(|(rel, path)| async move { self.upload(&format!("{prefix}/{rel}"), &path).await }))
            .buffer_unordered(CONCURRENT_REQUESTS)
            .try_collect::<Vec<()>>()
            .await?;
        if let Some((rel, path)) = manifest_last {
            self.upload(&format!("{prefix}/{rel}"), &path).await?;
        }
        Ok(count)
    }

    /// Every object under `prefix/`: its path relative to the prefix and its size.
    pub async fn list(&self, prefix: &str) -> io::Result<Vec<(String, u64)>> {
        let base = self.location(prefix);
        let strip = format!("{}/", base.as_ref());
        self.store
            .list(Some(&base))
            .map_err(io_error)
            .map_ok(|meta| (meta.location.as_ref().strip_prefix(&strip).unwrap_or(meta.location.as_ref()).to_string(), meta.size))
            .try_collect()
            .await
    }

    /// Every object of this deployment (under its key prefix), sorted by key.
    pub async fn inventory(&self) -> io::Result<Vec<StoredObject>> {
        let base = (!self.prefix.is_empty()).then(|| ObjectPath::from(self.prefix.as_str()));
        let strip = if self.prefix.is_empty() { String::new() } else { format!("{}/", base.as_ref().expect("a prefix").as_ref()) };
        let mut objects: Vec<StoredObject> = self
            .store
            .list(base.as_ref())
            .map_err(io_error)
            .map_ok(|meta| StoredObject {
                key: meta.location.as_ref().strip_prefix(&strip).unwrap_or(meta.location.as_ref()).to_string(),
                size: meta.size,
                e_tag: meta.e_tag,
            })
            .try_collect()
            .await?;
        objects.sort_by(|a, b| a.key.cmp(&b.key));
        Ok(objects)
    }

    /// `key` as stored (its size and ETag), if it is.
    pub async fn stored(&self, key: &str) -> io::Result<Option<StoredObject>> {
        match self.store.head(&self.location(key)).await {
            Ok(meta) => Ok(Some(StoredObject { key: key.to_string(), size: meta.size, e_tag: meta.e_tag })),
            Err(object_store::Error::NotFound { .. }) => Ok(None),
            Err(e) => Err(io_error(e)),
        }
    }

    /// Remove every object under `prefix/` (and `prefix` itself).
    pub async fn remove_prefix(&self, prefix: &str) -> io::Result<()> {
        let base = self.location(prefix);
        let locations = self.store.list(Some(&base)).map_ok(|meta| meta.location).boxed();
        self.store.delete_stream(locations).try_collect::<Vec<_>>().await.map_err(io_error)?;
        match self.store.delete(&base).await {
            Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
            Err(e) => Err(io_error(e)),
        }
    }

    /// Download `key` into the file `target` (written whole, then renamed into place).
    pub async fn download(&self, key: &str, target: &Path) -> io::Result<()> {
        let result = self.store.get(&self.location(key)).await.map_err(io_error)?;
        let partial = target.with_extension(format!("partial-{}", crate::clock::random_alphanumeric(6)));
        if let Some(parent) = target.parent() {
            tokio::fs::create_dir_all(parent).await?;
        }
        let written = async {
            let mut file = tokio::fs::File::create(&partial).await?;
            let mut stream = result.into_stream();
            while let Some(chunk) = stream.next().await {
                file.write_all(&chunk.map_err(io_error)?).await?;
            }
            file.flush().await?;
            tokio::fs::rename(&partial, target).await
        }
        .await;
        if written.is_err() {
            let _ = tokio::fs::remove_file(&partial).await;
        }
        written
    }

    /// `length` bytes of `key` from `start`, as a stream.
    pub async fn read(&self, key: &str, start: u64, length: u64) -> io::Result<BoxStream<'static, io::Result<Bytes>>> {
        if length == 0 {
            return Ok(futures_util::stream::empty().boxed());
        }
        let options = GetOptions { range: Some(GetRange::Bounded(start..start + length)), ..Default::default() };
        let result = self.store.get_opts(&self.location(key), options).await.map_err(io_error)?;
        Ok(result.into_stream().map_err(io_error).boxed())
    }

    /// Whether the bucket answers (a listing of the prefix, one page).
    pub async fn check(&self) -> io::Result<()> {
        let prefix = (!self.prefix.is_empty()).then(|| ObjectPath::from(self.prefix.as_str()));
        match tokio::time::timeout(Duration::from_secs(3), self.store.list_with_delimiter(prefix.as_ref())).await {
            Ok(listed) => listed.map(|_| ()).map_err(io_error),
            Err(_) => Err(io::Error::other(Unavailable("no answer within 3 s".into()))),
        }
    }
}

/// The files under `root` with their '/'-separated paths relative to it.
pub fn files_under(root: &Path) -> io::Result<Vec<(String, PathBuf)>> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir)? {
            let entry = entry?;
            let kind = entry.file_type()?;
            if kind.is_dir() {
                stack.push(entry.path());
            } else if kind.is_file() {
                let rel = entry
                    .path()
                    .strip_prefix(root)
                    .expect("under the root")
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect::<Vec<_>>();
                out.push((rel.join("/"), entry.path()));
            }
        }
    }
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &'static [(&'static str, &'static str)]) -> impl Fn(&str) -> Option<String> {
        move |name| pairs.iter().find(|(k, _)| *k == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn a_storage_url_names_bucket_and_prefix() {
        let config = ObjectConfig::parse("s3://osmab-data/prod/v1/", &env(&[])).unwrap();
        assert_eq!((config.bucket.as_str(), config.prefix.as_str(), config.endpoint, config.allow_http), ("osmab-data", "prod/v1", None, false));
        assert_eq!(ObjectConfig::parse("s3://osmab-data", &env(&[])).unwrap().prefix, "");
    }

    #[test]
    fn plain_http_is_allowed_on_loopback_or_when_asked() {
        let local = ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "http://127.0.0.1:9000")])).unwrap();
        assert!(local.allow_http);
        assert!(ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "http://[::1]:9000/")])).unwrap().allow_http);
        assert!(ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "http://localhost:9000")])).unwrap().allow_http);
        let remote = ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "http://minio.internal:9000")])).unwrap_err();
        assert!(remote.contains("AWS_ENDPOINT_URL") && remote.contains("AWS_ALLOW_HTTP=true"), "{remote}");
        let asked = ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "http://minio.internal:9000"), ("AWS_ALLOW_HTTP", "true")])).unwrap();
        assert!(asked.allow_http);
        assert!(!ObjectConfig::parse("s3://bucket/p", &env(&[("AWS_ENDPOINT_URL", "https://s3.example.org")])).unwrap().allow_http);
    }

    #[test]
    fn bad_storage_settings_are_named() {
        for (url, vars, names) in [
            ("file:///data", &[][..], "OSMAB_STORAGE_URL"),
            ("s3://UPPER/x", &[][..], "bucket name"),
            ("s3://bucket/a/../b", &[][..], "'..'"),
            ("s3://bucket/p", &[("AWS_ALLOW_HTTP", "yes")][..], "AWS_ALLOW_HTTP"),
            ("s3://bucket/p", &[("AWS_ENDPOINT_URL", "ftp://x")][..], "AWS_ENDPOINT_URL"),
        ] {
            let vars: Vec<(&str, &str)> = vars.to_vec();
            let lookup = move |name: &str| vars.iter().find(|(k, _)| *k == name).map(|(_, v)| v.to_string());
            let error = ObjectConfig::parse(url, &lookup).unwrap_err();
            assert!(error.contains(names), "{url}: {error}");
        }
    }
}
