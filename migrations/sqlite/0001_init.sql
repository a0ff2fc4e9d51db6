-- Records of the osmab service (SQLite). Times are Unix milliseconds; JSON is TEXT.
-- migrations/postgres/0001_init.sql holds the same schema for PostgreSQL.

CREATE TABLE teams (
    id          TEXT PRIMARY KEY,
    name        TEXT NOT NULL UNIQUE,
    daily_quota BIGINT NULL,
    created_at  BIGINT NOT NULL
);

CREATE TABLE tokens (
    id         TEXT PRIMARY KEY,
    team_id    TEXT NULL REFERENCES teams(id),
    scope      TEXT NOT NULL CHECK (scope IN ('admin', 'team')),
    sha256     TEXT NOT NULL UNIQUE,
    hint       TEXT NOT NULL,
    created_at BIGINT NOT NULL,
    expires_at BIGINT NULL,
    revoked_at BIGINT NULL
);

CREATE TABLE releases (
    version      TEXT PRIMARY KEY,
    state        TEXT NOT NULL CHECK (state IN ('draft', 'published')),
    is_current   BOOLEAN NOT NULL DEFAULT FALSE,
    digest       TEXT NOT NULL,
    manifest     TEXT NOT NULL,
    created_at   BIGINT NOT NULL,
    published_at BIGINT NULL
);
-- At most one current release, whatever publications race.
CREATE UNIQUE INDEX releases_one_current ON releases (is_current) WHERE is_current;

CREATE TABLE release_files (
    version TEXT NOT NULL REFERENCES releases(version),
    path    TEXT NOT NULL,
    size    BIGINT NOT NULL,
    sha256  TEXT NOT NULL,
    kind    TEXT NOT NULL CHECK (kind IN ('file', 'archive')),
    PRIMARY KEY (version, path)
);

CREATE TABLE submissions (
    id                 TEXT PRIMARY KEY,
    team_id            TEXT NOT NULL REFERENCES teams(id),
    release            TEXT NOT NULL REFERENCES releases(version),
    state              TEXT NOT NULL CHECK (state IN ('received', 'validating', 'queued', 'scoring', 'scored', 'failed', 'cancelled')),
    reason             TEXT NULL,
    method_name        TEXT NOT NULL,
    method_description TEXT NOT NULL,
    paper_url          TEXT NULL,
    code_url           TEXT NULL,
    public             BOOLEAN NOT NULL,
    baseline           BOOLEAN NOT NULL,
    complete           BOOLEAN NOT NULL,
    archive_size       BIGINT NOT NULL,
    archive_sha256     TEXT NOT NULL,
    created_at         BIGINT NOT NULL,
    updated_at         BIGINT NOT NULL
);
CREATE INDEX submissions_by_team_time ON submissions (team_id, created_at);
CREATE INDEX submissions_by_release_state ON submissions (release, state);

CREATE TABLE submission_events (
    id            INTEGER PRIMARY KEY AUTOINCREMENT,
    submission_id TEXT NOT NULL REFERENCES submissions(id),
    state         TEXT NOT NULL,
    reason        TEXT NULL,
    at            BIGINT NOT NULL
);
CREATE INDEX submission_events_by_submission ON submission_events (submission_id, id);

CREATE TABLE scores (
    id                INTEGER PRIMARY KEY AUTOINCREMENT,
    submission_id     TEXT NOT NULL REFERENCES submissions(id),
    release           TEXT NOT NULL,
    evaluator_version TEXT NOT NULL,
    body              TEXT NOT NULL,
    created_at        BIGINT NOT NULL
);
CREATE INDEX scores_by_submission ON scores (submission_id, id);

CREATE TABLE jobs (
    id            TEXT PRIMARY KEY,
    kind          TEXT NOT NULL,
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
CREATE INDEX jobs_ready ON jobs (state, run_after);
CREATE INDEX jobs_by_subject ON jobs (subject);
-- One live job per kind and subject: a release is not built twice at once, a submission not scored twice.
CREATE UNIQUE INDEX jobs_one_live ON jobs (kind, subject) WHERE state IN ('queued', 'running');
