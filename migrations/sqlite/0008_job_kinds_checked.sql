-- A job's kind is one the service runs (osmab_api::states::JobKind), as every other
-- state or kind column is checked. SQLite adds a CHECK only by rebuilding the table:
-- the same columns and indexes, the rows copied as they are.
CREATE TABLE jobs_checked (
    id            TEXT PRIMARY KEY,
    kind          TEXT NOT NULL CHECK (kind IN ('score_submission', 'build_release', 'render_sequence')),
    subject       TEXT NOT NULL,
    payload       TEXT NOT NULL,
    state         TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    attempts      BIGINT NOT NULL DEFAULT 0,
    max_attempts  BIGINT NOT NULL,
    run_after     BIGINT NOT NULL,
    lease_owner   TEXT NULL,
    lease_expires BIGINT NULL,
    progress      TEXT NOT NULL DEFAULT '{}',
    error         TEXT NULL,
    created_at    BIGINT NOT NULL,
    updated_at    BIGINT NOT NULL
);
INSERT INTO jobs_checked (id, kind, subject, payload, state, attempts, max_attempts, run_after, lease_owner, lease_expires, progress, error, created_at, updated_at)
    SELECT id, kind, subject, payload, state, attempts, max_attempts, run_after, lease_owner, lease_expires, progress, error, created_at, updated_at FROM jobs;
DROP TABLE jobs;
ALTER TABLE jobs_checked RENAME TO jobs;
CREATE INDEX jobs_ready ON jobs (state, run_after);
CREATE INDEX jobs_by_subject ON jobs (subject);
-- One live job per kind and subject: a release is not built twice at once, a submission not scored twice.
CREATE UNIQUE INDEX jobs_one_live ON jobs (kind, subject) WHERE state IN ('queued', 'running');
