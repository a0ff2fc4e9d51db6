-- A submission that failed through no fault of its team (its worker kept dying, or the
-- infrastructure failed every attempt) gives its quota unit back.
ALTER TABLE submissions ADD COLUMN quota_refunded BOOLEAN NOT NULL DEFAULT FALSE;
