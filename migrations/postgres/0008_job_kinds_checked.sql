-- A job's kind is one the service runs (osmab_api::states::JobKind), as every other
-- state or kind column is checked: a job of an unknown kind cannot be queued by hand or
-- by an older or newer binary sharing the database without the database saying so.
ALTER TABLE jobs ADD CONSTRAINT jobs_kind_known CHECK (kind IN ('score_submission', 'build_release', 'render_sequence'));
