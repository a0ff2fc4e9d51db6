//! The store's behaviour, run against both backends: a temporary SQLite file and a fresh
//! PostgreSQL database (`OSMAB_TEST_DATABASE_URL`, default the local server; the test
//! fails, it does not skip, when PostgreSQL is unreachable).

use super::*;
use crate::clock::now_ms;
use osmab_evaluator::scores::{Scores, Split};

/// A store of each backend; PostgreSQL databases are dropped when the guard goes.
pub struct TestStores {
    pub stores: Vec<Store>,
    _dir: tempfile::TempDir,
    pg_admin: String,
    pg_database: String,
}

pub fn postgres_base_url() -> String {
    std::env::var("OSMAB_TEST_DATABASE_URL").unwrap_or_else(|_| "postgres://postgres@127.0.0.1:5432/test".into())
}

impl TestStores {
    pub async fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let sqlite = Store::connect(&format!("sqlite://{}", dir.path().join("t.db").display())).await.unwrap();
        sqlite.migrate().await.unwrap();
        let base = postgres_base_url();
        let admin =
            sqlx::PgPool::connect(&base).await.unwrap_or_else(|e| panic!("PostgreSQL at {base} is needed for the store tests (.ci/run starts it): {e}"));
        let name = format!("osmab_test_{}", crate::clock::random_alphanumeric(12).to_ascii_lowercase());
        sqlx::query(sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}"))).execute(&admin).await.unwrap();
        admin.close().await;
        let url = match base.rfind('/') {
            Some(i) => format!("{}/{name}", &base[..i]),
            None => panic!("{base} names no database"),
        };
        let postgres = Store::connect(&url).await.unwrap();
        postgres.migrate().await.unwrap();
        Self { stores: vec![sqlite, postgres], _dir: dir, pg_admin: base, pg_database: name }
    }

    pub async fn drop_all(self) {
        for store in &self.stores {
            store.close().await;
        }
        if let Ok(admin) = sqlx::PgPool::connect(&self.pg_admin).await {
            let _ = sqlx::query(sqlx::AssertSqlSafe(format!("DROP DATABASE IF EXISTS {} WITH (FORCE)", self.pg_database))).execute(&admin).await;
            admin.close().await;
        }
    }
}

/// A public, complete submission of `team_id` to release r1, every step at `t`.
fn submission(id: &str, team_id: &str, t: i64) -> NewSubmission {
    NewSubmission {
        id: id.into(),
        team_id: team_id.into(),
        release: "r1".into(),
        method_name: "M".into(),
        method_description: String::new(),
        paper_url: None,
        code_url: None,
        public: true,
        baseline: false,
        complete: true,
        archive_size: 1,
        archive_sha256: "00".into(),
        idempotency_key: None,
        external_data: None,
        compute: None,
        anonymous: false,
        split: Split::Test,
        received_at: t,
        validating_at: t,
        queued_at: t,
    }
}

fn job(id: &str, at: i64) -> NewJob {
    NewJob { id: id.into(), kind: JobKind::ScoreSubmission, subject: format!("sub_{id}"), payload: "{}".into(), max_attempts: 3, created_at: at }
}

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

/// A score document told apart by `mark`.
fn score(mark: u32) -> Scores {
    Scores { release: "r1".into(), evaluator_version: "0.1.0".into(), missing_maps: vec![format!("mark-{mark}")], ..Scores::default() }
}

fn release(version: &str) -> ReleaseRecord {
    ReleaseRecord {
        version: version.into(),
        state: ReleaseState::Draft,
        is_current: false,
        digest: format!("digest-{version}"),
        manifest: "{}".into(),
        created_at: now_ms(),
        published_at: None,
    }
}

#[tokio::test]
async fn submissions_scores_and_releases_keep_their_history() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let team = Team { id: "team_a".into(), name: "Team A".into(), daily_quota: None, created_at: now_ms() };
        store.create_team(&team).await.unwrap();
        assert!(matches!(store.create_team(&Team { id: "team_b".into(), ..team.clone() }).await, Err(StoreError::Conflict(_))), "names are unique");
        store
            .insert_release(
                &release("r1"),
                &[ReleaseFile { version: "r1".into(), path: "a.txt".into(), size: 1, sha256: "00".into(), kind: ReleaseFileKind::File }],
            )
            .await
            .unwrap();
        store.insert_release(&release("r2"), &[]).await.unwrap();
        store.publish_release("r1", 1).await.unwrap();
        store.publish_release("r2", 2).await.unwrap();
        assert_eq!(store.current_release().await.unwrap().version, "r2", "the last publication is current");
        assert!(!store.release("r1").await.unwrap().is_current);

        let t = now_ms();
        let new = NewSubmission { archive_size: 10, archive_sha256: "ab".into(), validating_at: t + 1, queued_at: t + 2, ..submission("sub_1", &team.id, t) };
        assert_eq!(store.create_submission(&new, &job("js1", t), Some((1, t - 1))).await.unwrap(), Recorded::New("sub_1".into()));
        let second = NewSubmission { id: "sub_2".into(), archive_sha256: "cd".into(), ..new.clone() };
        assert_eq!(store.create_submission(&second, &job("js9", t), Some((1, t - 1))).await.unwrap(), Recorded::QuotaExceeded, "the quota of 1 is used");
        assert!(matches!(store.submission("sub_2").await, Err(StoreError::NotFound)), "nothing of the refused submission stays");
        assert!(matches!(store.job("js9").await, Err(StoreError::NotFound)));
        let s = store.submission("sub_1").await.unwrap();
        assert_eq!(s.state, SubmissionState::Queued);
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), 1);
        // Each split has its own count, and the same archive to the other split is a new submission.
        let to_val = NewSubmission { id: "sub_v".into(), split: Split::Val, ..new.clone() };
        assert_eq!(store.create_submission(&to_val, &job("jsv", t), Some((1, t - 1))).await.unwrap(), Recorded::New("sub_v".into()));
        assert_eq!(store.submission("sub_v").await.unwrap().split, Split::Val);
        assert_eq!(store.submissions_since(&team.id, Split::Val, t - 1).await.unwrap(), [t + 2], "counted from when it was recorded (queued)");
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), 1, "val does not count against test");
        let again = NewSubmission { id: "sub_v2".into(), ..to_val.clone() };
        assert_eq!(store.repeated_submission(&team.id, "ab", Split::Val, None).await.unwrap(), Some(Recorded::Repeat("sub_v".into())));
        assert_eq!(store.create_submission(&again, &job("jsv2", t), None).await.unwrap(), Recorded::Repeat("sub_v".into()));
        store.cancel_job("jsv", t).await.unwrap();

        // Scoring: the score lands with the job's success, only for the lease holder.
        let claimed = store.claim_next_job("w", t + 3, t + 60_000).await.unwrap().unwrap();
        assert_eq!(claimed.id, "js1");
        assert!(store.set_submission_state("sub_1", &[SubmissionState::Queued], SubmissionState::Scoring, None, t + 3).await.unwrap());
        assert!(
            !store.set_submission_state("sub_1", &[SubmissionState::Queued], SubmissionState::Cancelled, Some("late"), t + 4).await.unwrap(),
            "only from the named states"
        );
        assert!(!store.complete_scoring("js1", "intruder", "sub_1", &score(0), t + 5).await.unwrap(), "not without the lease");
        assert!(store.scores("sub_1").await.unwrap().is_empty());
        assert!(store.complete_scoring("js1", "w", "sub_1", &score(1), t + 5).await.unwrap());
        assert!(!store.complete_scoring("js1", "w", "sub_1", &score(1), t + 5).await.unwrap(), "never twice");

        // Re-scoring adds a score; a second live scoring job is refused.
        assert!(store.requeue_submission("sub_1", &[SubmissionState::Scored], "rescore", &job("js2", t + 6), t + 6).await.unwrap());
        let mut duplicate = job("js3", t + 6);
        duplicate.subject = "sub_js2".into();
        assert!(matches!(store.enqueue(&duplicate).await, Err(StoreError::Conflict(_))), "one live job per subject");
        store.claim_next_job("w", t + 7, t + 60_000).await.unwrap().unwrap();
        store.set_submission_state("sub_1", &[SubmissionState::Queued], SubmissionState::Scoring, None, t + 7).await.unwrap();
        assert!(store.complete_scoring("js2", "w", "sub_1", &score(2), t + 8).await.unwrap());
        let states: Vec<&str> = store.submission_events("sub_1").await.unwrap().into_iter().map(|e| e.state.name()).collect();
        assert_eq!(states, ["received", "validating", "queued", "scoring", "scored", "queued", "scoring", "scored"]);
        assert_eq!(store.scores("sub_1").await.unwrap().len(), 2, "re-scoring adds a score");
        assert_eq!(store.recent_scoring_durations(10).await.unwrap(), [1, 2], "each scoring timed from its own start, newest first");
        assert_eq!(store.scoring_since("sub_1").await.unwrap(), Some(t + 7));
        let rows = store.leaderboard_rows("r1").await.unwrap();
        assert_eq!((rows.len(), &rows[0].scores, rows[0].team.as_str()), (1, &score(2), "Team A"), "the latest score counts");
        // The card's later fields and the organisers' flag are kept and reach the board.
        let mut card = store.submission("sub_1").await.unwrap();
        (card.external_data, card.compute, card.anonymous) = (Some("CLIP".into()), Some("1 GPU".into()), true);
        store.update_method_card("sub_1", &card, t + 9).await.unwrap();
        store.set_flag("sub_1", Some("check the training data"), t + 9).await.unwrap();
        let kept = store.submission("sub_1").await.unwrap();
        assert_eq!((kept.external_data.as_deref(), kept.compute.as_deref(), kept.anonymous), (Some("CLIP"), Some("1 GPU"), true));
        let row = &store.leaderboard_rows("r1").await.unwrap()[0];
        assert_eq!((row.anonymous, row.flag.as_deref()), (true, Some("check the training data")));
        store.set_flag("sub_1", None, t + 10).await.unwrap();
        assert_eq!(store.submission("sub_1").await.unwrap().flag, None);
        assert!(matches!(store.set_flag("nope", Some("x"), t).await, Err(StoreError::NotFound)));

        // A document some other writer left that does not read is left out, not fatal.
        on_pool!(store, |pool| sqlx::query(
            "INSERT INTO scores (submission_id, release, evaluator_version, body, created_at) VALUES ('sub_1', 'r1', 'x', '{\"semseg\": 7}', 0)"
        )
        .execute(pool)
        .await
        .map(|_| ()))
        .unwrap();
        assert!(store.leaderboard_rows("r1").await.unwrap().is_empty(), "its submission leaves the board");
        let kept = store.scores("sub_1").await.unwrap();
        assert_eq!((kept.len(), kept[1].scores.as_ref(), kept[2].scores.as_ref()), (3, Some(&score(2)), None), "the readable ones stay");
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_failed_transaction_leaves_no_submission_behind() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t = now_ms();
        let team = Team { id: "team_x".into(), name: "X".into(), daily_quota: None, created_at: t };
        store.create_team(&team).await.unwrap();
        store.insert_release(&release("r1"), &[]).await.unwrap();
        store.enqueue(&job("taken", t)).await.unwrap();
        let new = submission("sub_x", &team.id, t);
        // The job id collides, so the whole transaction must roll back.
        assert!(store.create_submission(&new, &job("taken", t), None).await.is_err());
        assert!(matches!(store.submission("sub_x").await, Err(StoreError::NotFound)), "{}", store.backend());
        assert!(store.submission_events("sub_x").await.unwrap().is_empty());
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn an_administrators_quota_policy_replaces_the_one_before() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        assert!(store.quota_policies().await.unwrap().is_empty(), "no policy: the service's defaults");
        let test = QuotaPolicyRecord { split: Split::Test, max_submissions: 3, window_secs: 86_400, updated_at: 1 };
        store.set_quota_policy(&test).await.unwrap();
        store.set_quota_policy(&QuotaPolicyRecord { max_submissions: 2, window_secs: 7_200, updated_at: 2, ..test.clone() }).await.unwrap();
        let val = QuotaPolicyRecord { split: Split::Val, max_submissions: 40, window_secs: 86_400, updated_at: 3 };
        store.set_quota_policy(&val).await.unwrap();
        let policies = store.quota_policies().await.unwrap();
        assert_eq!(policies, [QuotaPolicyRecord { split: Split::Test, max_submissions: 2, window_secs: 7_200, updated_at: 2 }, val], "{}", store.backend());
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn tokens_are_found_by_hash_and_revocation_is_kept() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let (token, record) = crate::auth::issue_token(crate::store::TokenScope::Admin, None, None);
        store.insert_token(&record).await.unwrap();
        let found = store.token_by_hash(&crate::token::hash(&token)).await.unwrap();
        assert_eq!(found.id, record.id);
        store.revoke_token(&record.id, 5).await.unwrap();
        store.revoke_token(&record.id, 9).await.unwrap();
        assert_eq!(store.token_by_hash(&record.sha256).await.unwrap().revoked_at, Some(5), "the first revocation time stays");
        assert!(matches!(store.revoke_token("tok_missing", 1).await, Err(StoreError::NotFound)));
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_cancelled_submission_is_not_scored_and_a_failed_job_fails_its_submission() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t = now_ms();
        let team = Team { id: "team_c".into(), name: "C".into(), daily_quota: None, created_at: t };
        store.create_team(&team).await.unwrap();
        store.insert_release(&release("r1"), &[]).await.unwrap();
        let new = |id: &str| submission(id, &team.id, t);
        let mut first = job("k1", t);
        first.subject = "sub_a".into();
        store.create_submission(&new("sub_a"), &first, None).await.unwrap();
        store.claim_next_job("w", t, t + 60_000).await.unwrap().unwrap();
        assert!(store.set_submission_state("sub_a", &[SubmissionState::Queued], SubmissionState::Cancelled, Some("by the team"), t + 1).await.unwrap());
        assert!(!store.complete_scoring("k1", "w", "sub_a", &score(0), t + 2).await.unwrap(), "a cancelled submission stays cancelled");
        assert!(store.scores("sub_a").await.unwrap().is_empty());
        assert_eq!(store.submission("sub_a").await.unwrap().state, SubmissionState::Cancelled);

        let mut second = job("k2", t + 1);
        second.subject = "sub_b".into();
        store.create_submission(&new("sub_b"), &second, None).await.unwrap();
        store.claim_next_job("w", t + 3, t + 60_000).await.unwrap().unwrap();
        assert!(store.fail_job("k2", "w", "maps/baseline/scene_000.npz: points: NaN", Some("sub_b"), false, t + 4).await.unwrap());
        let failed = store.submission("sub_b").await.unwrap();
        assert_eq!((failed.state, failed.reason.as_deref()), (SubmissionState::Failed, Some("maps/baseline/scene_000.npz: points: NaN")));
        assert_eq!(store.job("k2").await.unwrap().state, JobState::Failed);
        assert!(!failed.quota_refunded, "a failure of the input counts against the quota");
        let counted = store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len();

        // A failure that was not the team's gives the quota unit back.
        let mut third = job("k3", t + 5);
        third.subject = "sub_c".into();
        store.create_submission(&NewSubmission { archive_sha256: "01".into(), ..new("sub_c") }, &third, None).await.unwrap();
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), counted + 1);
        store.claim_next_job("w", t + 6, t + 60_000).await.unwrap().unwrap();
        assert!(store.fail_job("k3", "w", "Stopped after 3 attempts.", Some("sub_c"), true, t + 7).await.unwrap());
        assert!(store.submission("sub_c").await.unwrap().quota_refunded);
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), counted, "{}: refunded", store.backend());

        // An organiser gives back the unit of a failure the team was charged for, once.
        assert!(store.refund_quota("sub_b", t + 8).await.unwrap());
        assert!(!store.refund_quota("sub_b", t + 9).await.unwrap(), "a second refund changes nothing");
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), counted - 1);
        assert!(matches!(store.refund_quota("sub_missing", t + 9).await, Err(StoreError::NotFound)));
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
async fn a_repeated_upload_or_idempotency_key_finds_the_earlier_submission_and_records_nothing() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let team = Team { id: "team_r".into(), name: "Team R".into(), daily_quota: None, created_at: now_ms() };
        store.create_team(&team).await.unwrap();
        store.insert_release(&release("r1"), &[]).await.unwrap();
        let t = now_ms();
        let upload = |id: &str, archive: &str, key: Option<&str>| NewSubmission {
            archive_sha256: archive.into(),
            idempotency_key: key.map(str::to_string),
            ..submission(id, &team.id, t)
        };
        let quota = Some((1, t - 1));
        assert_eq!(store.create_submission(&upload("sub_1", "aa", Some("key-1")), &job("j1", t), quota).await.unwrap(), Recorded::New("sub_1".into()));
        // The same archive again, with the quota used up, with or without a key: the first.
        for key in [None, Some("key-1"), Some("key-2")] {
            assert_eq!(store.create_submission(&upload("sub_2", "aa", key), &job("j2", t), quota).await.unwrap(), Recorded::Repeat("sub_1".into()), "{key:?}");
        }
        // The key with another archive is a reuse; another archive without it is new.
        assert_eq!(store.create_submission(&upload("sub_2", "bb", Some("key-1")), &job("j2", t), None).await.unwrap(), Recorded::KeyReused("sub_1".into()));
        assert_eq!(store.repeated_submission(&team.id, "bb", Split::Test, Some("key-1")).await.unwrap(), Some(Recorded::KeyReused("sub_1".into())));
        assert_eq!(store.repeated_submission(&team.id, "aa", Split::Test, None).await.unwrap(), Some(Recorded::Repeat("sub_1".into())));
        assert_eq!(store.repeated_submission(&team.id, "", Split::Test, Some("key-9")).await.unwrap(), None);
        // Keys are scoped by split: the same key (and archive) to val is a new submission.
        assert_eq!(store.repeated_submission(&team.id, "aa", Split::Val, Some("key-1")).await.unwrap(), None, "{}", store.backend());
        assert!(matches!(store.submission("sub_2").await, Err(StoreError::NotFound)), "{}: nothing recorded", store.backend());
        assert!(matches!(store.job("j2").await, Err(StoreError::NotFound)));
        assert_eq!(store.submissions_since(&team.id, Split::Test, t - 1).await.unwrap().len(), 1, "one quota unit");
        // A cancelled submission's archive may be submitted anew.
        assert!(store.set_submission_state("sub_1", &[SubmissionState::Queued], SubmissionState::Cancelled, Some("by the team"), t + 1).await.unwrap());
        assert_eq!(store.create_submission(&upload("sub_3", "aa", None), &job("j3", t), None).await.unwrap(), Recorded::New("sub_3".into()));
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_resumable_upload_moves_once_per_offset_and_keeps_its_parts_in_order() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t = now_ms();
        store.create_team(&Team { id: "team_u".into(), name: "U".into(), daily_quota: None, created_at: t }).await.unwrap();
        let upload = UploadRecord {
            id: "upl_1".into(),
            team_id: "team_u".into(),
            length: 10,
            upload_offset: 0,
            metadata: String::new(),
            parts: String::new(),
            created_at: t,
            expires_at: t + 1000,
            submission_id: None,
        };
        let roomy = OpenUploadLimits { uploads: 10, bytes: 1 << 30 };
        assert_eq!(store.insert_upload_within(&upload, roomy, t).await.unwrap(), Ok(()));
        let part = |offset: i64, length: i64, key: &str| UploadPart { offset, length, key: key.into() };
        assert!(store.append_upload_part("upl_1", &part(0, 6, "uploads/upl_1/a"), t + 2000).await.unwrap());
        assert!(!store.append_upload_part("upl_1", &part(0, 6, "uploads/upl_1/b"), t + 2000).await.unwrap(), "{}: one append per offset", store.backend());
        assert!(!store.append_upload_part("upl_1", &part(6, 5, "uploads/upl_1/c"), t + 2000).await.unwrap(), "never past the length");
        assert!(store.append_upload_part("upl_1", &part(6, 4, "uploads/upl_1/d"), t + 3000).await.unwrap());
        let stored = store.upload("upl_1").await.unwrap();
        assert_eq!((stored.upload_offset, stored.expires_at), (10, t + 3000));
        assert_eq!(stored.parts().unwrap(), vec![part(0, 6, "uploads/upl_1/a"), part(6, 4, "uploads/upl_1/d")]);
        assert_eq!(store.expired_uploads(t + 2500, 10).await.unwrap(), Vec::<String>::new(), "the last chunk extended it");
        store.finish_upload("upl_1", "sub_1").await.unwrap();
        let finished = store.upload("upl_1").await.unwrap();
        assert_eq!((finished.submission_id.as_deref(), finished.parts.as_str()), (Some("sub_1"), ""));
        assert!(!store.append_upload_part("upl_1", &part(10, 0, "x"), t).await.unwrap(), "a finished upload takes nothing");
        assert_eq!(store.expired_uploads(t + 3001, 10).await.unwrap(), vec!["upl_1".to_string()]);
        store.delete_upload("upl_1").await.unwrap();
        assert!(matches!(store.upload("upl_1").await, Err(StoreError::NotFound)));
    }
}

#[tokio::test]
async fn a_team_holds_at_most_its_open_uploads_even_when_they_start_at_once() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        let t = now_ms();
        store.create_team(&Team { id: "team_o".into(), name: "O".into(), daily_quota: None, created_at: t }).await.unwrap();
        store.create_team(&Team { id: "team_p".into(), name: "P".into(), daily_quota: None, created_at: t }).await.unwrap();
        let upload = |id: String, team: &str, length: i64| UploadRecord {
            id,
            team_id: team.into(),
            length,
            upload_offset: 0,
            metadata: String::new(),
            parts: String::new(),
            created_at: t,
            expires_at: t + 60_000,
            submission_id: None,
        };
        let limits = OpenUploadLimits { uploads: 3, bytes: 1000 };
        // Ten at once: three are recorded, whatever the interleaving.
        let attempts = (0..10).map(|k| {
            let store = store.clone();
            let record = upload(format!("upl_o{k}"), "team_o", 100);
            tokio::spawn(async move { store.insert_upload_within(&record, limits, t).await })
        });
        let mut recorded = 0;
        for attempt in attempts.collect::<Vec<_>>() {
            match attempt.await.unwrap() {
                Ok(Ok(())) => recorded += 1,
                Ok(Err(open)) => assert_eq!(open, OpenUploads { uploads: 3, bytes: 300 }, "{}", store.backend()),
                // SQLite may answer "busy" to a writer that waited too long: refused, not recorded.
                Err(e) => assert_eq!(store.backend(), "sqlite", "{e}"),
            }
        }
        assert_eq!(recorded, 3, "{}", store.backend());
        // Bytes count too; another team is not affected; finished and expired uploads free room.
        assert_eq!(store.insert_upload_within(&upload("upl_p1".into(), "team_p", 900), limits, t).await.unwrap(), Ok(()));
        assert_eq!(store.insert_upload_within(&upload("upl_p2".into(), "team_p", 200), limits, t).await.unwrap(), Err(OpenUploads { uploads: 1, bytes: 900 }));
        store.finish_upload("upl_p1", "sub_p1").await.unwrap();
        assert_eq!(store.insert_upload_within(&upload("upl_p3".into(), "team_p", 200), limits, t).await.unwrap(), Ok(()));
        assert_eq!(store.insert_upload_within(&upload("upl_o_late".into(), "team_o", 1), limits, t + 60_001).await.unwrap(), Ok(()), "the three expired");
    }
    stores.drop_all().await;
}

#[tokio::test]
async fn a_release_records_every_file_or_none() {
    let stores = TestStores::new().await;
    for store in &stores.stores {
        // More files than one statement writes, so the rows go in several statements.
        let file = |i: usize| ReleaseFile {
            version: "big".into(),
            path: format!("sequences/s/{i:05}.jpg"),
            size: i as i64,
            sha256: format!("{i:064x}"),
            kind: ReleaseFileKind::File,
        };
        let files: Vec<ReleaseFile> = (0..2_345).map(file).collect();
        store.insert_release(&release("big"), &files).await.unwrap();
        for i in [0, 999, 1_000, 2_344] {
            assert_eq!(store.release_file("big", &file(i).path).await.unwrap(), file(i), "{}", store.backend());
        }
        // A path listed twice, in the last statement: nothing of the release is recorded.
        let mut twice: Vec<ReleaseFile> = (0..2_345).map(|i| ReleaseFile { version: "twice".into(), ..file(i) }).collect();
        twice.push(twice[2_000].clone());
        assert!(store.insert_release(&release("twice"), &twice).await.is_err(), "{}", store.backend());
        assert!(matches!(store.release("twice").await, Err(StoreError::NotFound)), "{}", store.backend());
        assert!(matches!(store.release_file("twice", &file(3).path).await, Err(StoreError::NotFound)), "{}", store.backend());
    }
    stores.drop_all().await;
}
