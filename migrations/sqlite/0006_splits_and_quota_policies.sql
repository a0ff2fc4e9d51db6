-- The split a submission was made to: 'test' (the hidden scenes, ranked on the main
-- board) or 'val' (the open scenes, their own board). Releases built before splits
-- existed have val scenes only, so earlier submissions are val submissions.
ALTER TABLE submissions ADD COLUMN split TEXT NOT NULL DEFAULT 'val';

-- An administrator's limit per split: submissions per rolling window. A split without a
-- row uses the service's defaults (OSMAB_DAILY_QUOTA for test, OSMAB_VAL_QUOTA for val,
-- per 24 hours).
CREATE TABLE quota_policies (
    split          TEXT PRIMARY KEY,
    max_submissions BIGINT NOT NULL,
    window_secs    BIGINT NOT NULL,
    updated_at     BIGINT NOT NULL
);
