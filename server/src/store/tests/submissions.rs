//! Submissions, their scores and history: recorded whole or not at all, repeats found, cancellation and failure.

use super::*;

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
        (card.card.external_data, card.card.compute, card.card.anonymous) = (Some("CLIP".into()), Some("1 GPU".into()), true);
        card.card.description = "A method, described.".into();
        store.update_method_card("sub_1", &card, t + 9).await.unwrap();
        store.set_flag("sub_1", Some("check the training data"), t + 9).await.unwrap();
        let kept = store.submission("sub_1").await.unwrap();
        assert_eq!(kept.card, card.card, "the whole card is kept");
        assert_eq!((kept.card.external_data.as_deref(), kept.card.compute.as_deref(), kept.card.anonymous), (Some("CLIP"), Some("1 GPU"), true));
        let row = &store.leaderboard_rows("r1").await.unwrap()[0];
        assert_eq!((&row.card, row.flag.as_deref()), (&kept.card, Some("check the training data")), "the board reads the same card");
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
