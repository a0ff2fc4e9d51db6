//! Resumable uploads: parts in order, one move per offset, and the limits of a team's open uploads.

use super::*;

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
