-- Resumable (tus 1.0.0) uploads: how far each has come, where its parts are (one line
-- "OFFSET LENGTH BLOB-KEY" per part, appended in the same statement that moves the
-- offset, so two servers appending at once cannot both win), when it expires, and the
-- submission it became.
CREATE TABLE uploads (
    id TEXT PRIMARY KEY,
    team_id TEXT NOT NULL REFERENCES teams(id),
    length BIGINT NOT NULL,
    upload_offset BIGINT NOT NULL DEFAULT 0,
    metadata TEXT NOT NULL DEFAULT '',
    parts TEXT NOT NULL DEFAULT '',
    created_at BIGINT NOT NULL,
    expires_at BIGINT NOT NULL,
    submission_id TEXT NULL
);
CREATE INDEX uploads_expiry ON uploads (expires_at);
