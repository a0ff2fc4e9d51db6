-- The rest of a method card (external data, compute), anonymity until the team reveals
-- itself, and an organiser's flag on an entry (its reason, shown on the leaderboard).
ALTER TABLE submissions ADD COLUMN external_data TEXT NULL;
ALTER TABLE submissions ADD COLUMN compute TEXT NULL;
ALTER TABLE submissions ADD COLUMN anonymous BOOLEAN NOT NULL DEFAULT FALSE;
ALTER TABLE submissions ADD COLUMN flag TEXT NULL;
