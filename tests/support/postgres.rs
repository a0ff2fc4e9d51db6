//! A fresh PostgreSQL database for one test, on the server of `OSMAB_TEST_DATABASE_URL`
//! (`.ci/run` starts it), dropped with its guard. Shared by the `cli` and `app` test
//! targets (`#[path]`); it works inside an async test as well as outside one.

/// The server's URL, naming a database the tests may connect to and create others from.
pub fn postgres_base() -> String {
    std::env::var("OSMAB_TEST_DATABASE_URL").unwrap_or_else(|_| "postgres://postgres@127.0.0.1:5432/test".into())
}

/// A fresh database, dropped with the guard.
pub struct PgDatabase {
    pub url: String,
    name: String,
}

impl PgDatabase {
    pub fn create() -> Self {
        let base = postgres_base();
        let name = format!("osmab_e2e_{}_{}", std::process::id(), rand_suffix());
        let (server, database) = (base.clone(), name.clone());
        on_own_runtime(async move {
            let admin = sqlx::PgPool::connect(&server).await.unwrap_or_else(|e| panic!("PostgreSQL at {server} is needed (.ci/run starts it): {e}"));
            sqlx::query(sqlx::AssertSqlSafe(format!("CREATE DATABASE {database}"))).execute(&admin).await.unwrap();
            admin.close().await;
        });
        let url = format!("{}/{name}", &base[..base.rfind('/').unwrap()]);
        Self { url, name }
    }
}

impl Drop for PgDatabase {
    fn drop(&mut self) {
        let (base, name) = (postgres_base(), self.name.clone());
        on_own_runtime(async move {
            if let Ok(admin) = sqlx::PgPool::connect(&base).await {
                let _ = sqlx::query(sqlx::AssertSqlSafe(format!("DROP DATABASE IF EXISTS {name} WITH (FORCE)"))).execute(&admin).await;
                admin.close().await;
            }
        });
    }
}

/// A suffix no other call in this process returns.
pub fn rand_suffix() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().subsec_nanos();
    format!("{nanos:x}{}", N.fetch_add(1, Ordering::SeqCst))
}

/// Run `work` to completion on a runtime of its own thread (callable from inside a test's runtime).
fn on_own_runtime<F: std::future::Future<Output = ()> + Send + 'static>(work: F) {
    std::thread::spawn(move || tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap().block_on(work)).join().unwrap();
}
