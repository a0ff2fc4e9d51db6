//! Quota policies, tokens and releases.

use super::*;

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
