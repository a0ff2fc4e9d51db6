//! The queue: claims, leases, backoff, standing, and the parts a coordinator fans out.

use super::*;

#[tokio::test]
async fn a_queued_job_knows_how_many_jobs_go_first_and_who_is_busy() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t = now_ms();
        for (k, id) in ["q1", "q2", "q3", "q4"].into_iter().enumerate() {
            store.enqueue(&job(id, t + k as i64)).await.unwrap();
        }
        let none_running = Standing { ahead: 2, running: 0, busy_workers: 0 };
        assert_eq!(store.standing("q3").await.unwrap(), Some(none_running), "{}: claim order is creation order", store.backend());
        store.claim_next_job("worker-a", t + 10, t + 60_000).await.unwrap().unwrap();
        store.claim_next_job("worker-b", t + 10, t + 60_000).await.unwrap().unwrap();
        assert_eq!(store.standing("q4").await.unwrap(), Some(Standing { ahead: 1, running: 2, busy_workers: 2 }));
        assert_eq!(store.standing("q3").await.unwrap(), Some(Standing { ahead: 0, running: 2, busy_workers: 2 }), "next");
        assert_eq!(store.standing("q1").await.unwrap(), None, "a running job is not queued");
        assert_eq!(store.standing("nope").await.unwrap(), None);
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_job_whose_worker_died_is_claimed_again_after_its_lease() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t0 = now_ms();
        store.enqueue(&job("j1", t0)).await.unwrap();
        let first = store.claim_next_job("worker-a", t0, t0 + 1000).await.unwrap().expect("a job is ready");
        assert_eq!((first.id.as_str(), first.attempts), ("j1", 1), "{}", store.backend());
        assert!(store.claim_next_job("worker-b", t0 + 500, t0 + 1500).await.unwrap().is_none(), "the lease still holds");
        // worker-a stops heartbeating; after the lease, worker-b takes the job over.
        let second = store.claim_next_job("worker-b", t0 + 1001, t0 + 2001).await.unwrap().expect("the expired lease frees the job");
        assert_eq!((second.id.as_str(), second.attempts), ("j1", 2));
        assert!(!store.heartbeat("j1", "worker-a", t0 + 3000, t0 + 1002).await.unwrap(), "the dead worker lost its lease");
        assert!(!store.finish_job("j1", "worker-a", JobState::Succeeded, None, None, t0 + 1003).await.unwrap());
        assert!(store.finish_job("j1", "worker-b", JobState::Succeeded, None, None, t0 + 1004).await.unwrap());
        let record = store.job("j1").await.unwrap();
        assert_eq!((record.state, record.lease_owner), (JobState::Succeeded, None));
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_retried_job_waits_for_its_backoff_and_a_released_one_keeps_its_attempts() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t0 = now_ms();
        store.enqueue(&job("j2", t0)).await.unwrap();
        store.claim_next_job("w", t0, t0 + 1000).await.unwrap().unwrap();
        assert!(store.finish_job("j2", "w", JobState::Queued, Some("disk full"), Some(t0 + 5000), t0 + 10).await.unwrap());
        assert!(store.claim_next_job("w", t0 + 4999, t0 + 6000).await.unwrap().is_none(), "not before the backoff");
        let again = store.claim_next_job("w", t0 + 5000, t0 + 6000).await.unwrap().unwrap();
        assert_eq!(again.attempts, 2);
        assert!(store.release_job("j2", "w", t0 + 5001, t0 + 5001).await.unwrap());
        let after_release = store.claim_next_job("w2", t0 + 5002, t0 + 7000).await.unwrap().unwrap();
        assert_eq!(after_release.attempts, 2, "a graceful release does not count as an attempt");
        // A coordinator waiting for its parts goes back to the queue until a later time.
        assert!(store.release_job("j2", "w2", t0 + 9000, t0 + 5003).await.unwrap());
        assert!(store.claim_next_job("w", t0 + 8999, t0 + 10_000).await.unwrap().is_none(), "not before it asked to be woken");
        assert_eq!(store.claim_next_job("w", t0 + 9000, t0 + 10_000).await.unwrap().unwrap().attempts, 2);
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn two_workers_never_claim_the_same_job() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t0 = now_ms();
        for i in 0..20 {
            store.enqueue(&job(&format!("c{i:02}"), t0 + i)).await.unwrap();
        }
        let mut handles = Vec::new();
        for w in 0..4 {
            let store = store.clone();
            handles.push(tokio::spawn(async move {
                let mut got = Vec::new();
                while let Some(j) = store.claim_next_job(&format!("w{w}"), t0 + 100, t0 + 60_000).await.unwrap() {
                    got.push(j.id);
                }
                got
            }));
        }
        let mut all = Vec::new();
        for h in handles {
            all.extend(h.await.unwrap());
        }
        all.sort();
        let expected: Vec<String> = (0..20).map(|i| format!("c{i:02}")).collect();
        assert_eq!(all, expected, "{}: every job claimed exactly once", store.backend());
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_coordinator_finds_the_parts_it_fanned_out_by_kind_prefix_and_time() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t0 = now_ms();
        let part = |id: &str, subject: &str, at: i64| NewJob {
            id: id.into(),
            kind: JobKind::RenderSequence,
            subject: subject.into(),
            payload: "{}".into(),
            max_attempts: 3,
            created_at: at,
        };
        store.enqueue(&part("old", "v_1/scene_000/baseline", t0 - 10)).await.unwrap();
        store.cancel_job("old", t0).await.unwrap();
        store.enqueue(&part("p2", "v_1/scene_001/baseline", t0)).await.unwrap();
        store.enqueue(&part("p1", "v_1/scene_000/baseline", t0 + 1)).await.unwrap();
        // `_` is not a wildcard: v_10 and v21 are other releases.
        store.enqueue(&part("other", "v_10/scene_000/baseline", t0)).await.unwrap();
        store.enqueue(&part("another", "v21/scene_000/baseline", t0)).await.unwrap();
        store.enqueue(&job("score", t0)).await.unwrap();
        let found: Vec<String> = store.jobs_of(JobKind::RenderSequence, "v_1/", t0).await.unwrap().into_iter().map(|j| j.id).collect();
        assert_eq!(found, ["p1", "p2"], "{}", store.backend());
        assert_eq!(store.jobs_of(JobKind::RenderSequence, "v_1/", t0 - 10).await.unwrap().len(), 3, "{}", store.backend());
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn the_database_refuses_a_job_of_a_kind_the_service_does_not_run() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        const INSERT: &str = "INSERT INTO jobs (id, kind, subject, payload, state, attempts, max_attempts, run_after, progress, created_at, updated_at) \
                              VALUES ($1, $2, 's', '{}', 'queued', 0, 3, 0, '{}', 0, 0)";
        let refused = on_pool!(store, |pool| sqlx::query(INSERT).bind("j-unknown").bind("sweep_uploads").execute(pool).await.map(|_| ()));
        let err = refused.expect_err("an unknown kind").to_string();
        assert!(err.to_lowercase().contains("check"), "{}: {err}", store.backend());
        for kind in JobKind::ALL {
            on_pool!(store, |pool| sqlx::query(INSERT).bind(kind.name()).bind(kind.name()).execute(pool).await.map(|_| ())).unwrap();
        }
        assert_eq!(store.jobs(10).await.unwrap().len(), JobKind::ALL.len(), "{}: every kind the service runs is accepted", store.backend());
    }
    stores.drop_all().await;
}
