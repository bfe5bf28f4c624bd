-- ledflicker.db/2: each run's set-up (docs/campaigns.md, "Like with
-- like"): `setup`, a JSON object of plan-spelled keys and their values
-- as run; `test_hash`, the SHA-256 of its test keys alone, so that the
-- repeats of one test on one device are found by an index. Runs recorded
-- before this step have neither: `compare` says their set-up is unknown.
ALTER TABLE runs ADD COLUMN setup TEXT;
ALTER TABLE runs ADD COLUMN test_hash TEXT;
CREATE INDEX runs_by_test ON runs (plan_id, model, serial, firmware, test_hash);
