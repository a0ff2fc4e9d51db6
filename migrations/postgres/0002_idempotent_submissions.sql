-- A repeated upload (same team, same archive, or the same Idempotency-Key) answers with
-- the submission it made the first time.
ALTER TABLE submissions ADD COLUMN idempotency_key TEXT NULL;
CREATE INDEX submissions_by_team_archive ON submissions (team_id, archive_sha256);
CREATE INDEX submissions_by_team_key ON submissions (team_id, idempotency_key);
