-- Requests for access from the "Take part" page: a team asks (name, contact, affiliation,
-- method link), the operator approves or declines, and the requester collects its first
-- token once with the claim code it was shown (only its SHA-256 is kept). Nothing else is
-- created until the request is approved: approving creates the team, collecting issues the
-- token. `client` is who asked (the rate limiter's key), so one client holds few pending.
CREATE TABLE access_requests (
    id            TEXT PRIMARY KEY,
    team_name     TEXT NOT NULL,
    contact       TEXT NOT NULL,
    affiliation   TEXT NOT NULL,
    method_url    TEXT,
    claim_sha256  TEXT NOT NULL UNIQUE,
    client        TEXT NOT NULL,
    state         TEXT NOT NULL CHECK (state IN ('pending', 'approved', 'declined', 'collected')),
    reason        TEXT,
    team_id       TEXT REFERENCES teams (id),
    created_at    BIGINT NOT NULL,
    decided_at    BIGINT,
    collected_at  BIGINT
);
CREATE INDEX access_requests_by_state ON access_requests (state, created_at);
