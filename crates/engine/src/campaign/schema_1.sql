-- ledflicker.db/1: runs, their cases, ROIs, metrics and checks
-- (docs/campaigns.md). Shipped steps are never edited; a change is a new
-- migration.
CREATE TABLE runs (
    id              INTEGER PRIMARY KEY,
    recorded_unix_s INTEGER NOT NULL,
    source          TEXT NOT NULL,
    date            TEXT NOT NULL,
    plan_id         TEXT NOT NULL,
    plan_title      TEXT NOT NULL,
    plan_hash       TEXT NOT NULL,
    seed            INTEGER NOT NULL,
    tool            TEXT NOT NULL,
    backend         TEXT NOT NULL,
    supplier        TEXT NOT NULL,
    model           TEXT NOT NULL,
    serial          TEXT NOT NULL,
    firmware        TEXT NOT NULL,
    signer          TEXT,
    signature       TEXT NOT NULL,
    report_dir      TEXT NOT NULL,
    results_sha256  TEXT NOT NULL,
    manifest_sha256 TEXT,
    verdict         TEXT NOT NULL,
    cases_total     INTEGER NOT NULL,
    cases_pass      INTEGER NOT NULL,
    cases_fail      INTEGER NOT NULL,
    cases_info      INTEGER NOT NULL
);
CREATE INDEX runs_by_device ON runs (model, firmware, serial);
CREATE INDEX runs_by_plan ON runs (plan_id, date);
CREATE TABLE cases (
    run_id       INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    idx          INTEGER NOT NULL,
    id           TEXT NOT NULL,
    light_lux    REAL NOT NULL,
    frequency_hz REAL NOT NULL,
    duty         REAL NOT NULL,
    verdict      TEXT NOT NULL,
    not_judged   TEXT,
    trace        TEXT NOT NULL,
    PRIMARY KEY (run_id, idx)
) WITHOUT ROWID;
CREATE TABLE rois (
    run_id     INTEGER NOT NULL,
    idx        INTEGER NOT NULL,
    roi        TEXT NOT NULL,
    kind       TEXT NOT NULL,
    saturated  INTEGER NOT NULL,
    level_off  REAL,
    level_on   REAL,
    level_min  REAL NOT NULL,
    level_max  REAL NOT NULL,
    noise_on_dn  REAL,
    noise_off_dn REAL,
    off_frames   INTEGER NOT NULL,
    PRIMARY KEY (run_id, idx, roi),
    FOREIGN KEY (run_id, idx) REFERENCES cases(run_id, idx) ON DELETE CASCADE
) WITHOUT ROWID;
CREATE TABLE metrics (
    run_id INTEGER NOT NULL,
    idx    INTEGER NOT NULL,
    roi    TEXT NOT NULL,
    metric TEXT NOT NULL,
    value  REAL,
    PRIMARY KEY (run_id, idx, roi, metric),
    FOREIGN KEY (run_id, idx, roi) REFERENCES rois(run_id, idx, roi) ON DELETE CASCADE
) WITHOUT ROWID;
CREATE TABLE checks (
    run_id     INTEGER NOT NULL,
    idx        INTEGER NOT NULL,
    roi        TEXT NOT NULL,
    metric     TEXT NOT NULL,
    comparison TEXT NOT NULL,
    threshold  REAL NOT NULL,
    value      REAL,
    unbounded  INTEGER NOT NULL,
    pass       INTEGER NOT NULL,
    PRIMARY KEY (run_id, idx, roi, metric, comparison),
    FOREIGN KEY (run_id, idx) REFERENCES cases(run_id, idx) ON DELETE CASCADE
) WITHOUT ROWID;
