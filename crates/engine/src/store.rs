//! The case store: every finished case goes to an SQLite file as soon as
//! it finishes, so a run holds a few cases in memory, a killed run can be
//! resumed, and the report directory keeps its cases in a form a database
//! reads (docs/store.md).
//!
//! ```text
//! Store::create ──▶ put (each case, any order) ──▶ finish ──▶ cases.sqlite
//!   (cases.partial.sqlite, status "running")        (status "complete",
//!                                                    rebuilt in case order)
//! ```
//!
//! While a run works, its store is `cases.partial.sqlite` in the report's
//! staging directory: a name no reader takes for finished results. Cases
//! are committed in small transactions, so a run killed at any instant
//! leaves every case committed before it whole. [`Store::finish`] writes
//! `cases.sqlite` afresh in case order (`VACUUM INTO`), so that the file's
//! bytes depend on the cases only, not on the order they finished in.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rusqlite::config::DbConfig;
use rusqlite::{Connection, OptionalExtension, params};

use ledflicker_core::runner::{CaseReadError, CaseResult, CaseSource};

mod record;
mod same;

/// Schema of the store, in its `run` table under `schema`.
pub const SCHEMA: &str = "ledflicker.store/4";
/// The finished store's file name in a report directory.
pub const FILE: &str = "cases.sqlite";
/// The store's file name while its run works.
pub const PARTIAL: &str = "cases.partial.sqlite";
/// SQLite's write-ahead log of [`PARTIAL`].
pub const PARTIAL_WAL: &str = "cases.partial.sqlite-wal";
/// SQLite's shared-memory index of [`PARTIAL`].
pub const PARTIAL_SHM: &str = "cases.partial.sqlite-shm";

/// Cases written in one transaction at most; a transaction also ends after
/// [`COMMIT_EVERY`], and when the run is idle ([`Store::flush`]), so that a
/// killed run loses little.
const BATCH: usize = 64;
/// Longest time a finished case waits uncommitted.
const COMMIT_EVERY: Duration = Duration::from_millis(500);

const CREATE: &str = "
CREATE TABLE run (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE cases (
    idx          INTEGER PRIMARY KEY,
    id           TEXT NOT NULL UNIQUE,
    light_lux    REAL NOT NULL,
    frequency_hz REAL NOT NULL,
    duty         REAL NOT NULL,
    verdict      TEXT NOT NULL,
    result       BLOB NOT NULL
);
CREATE TABLE roi_metrics (
    idx    INTEGER NOT NULL REFERENCES cases(idx),
    roi    TEXT NOT NULL,
    metric TEXT NOT NULL,
    value  REAL,
    PRIMARY KEY (idx, roi, metric)
) WITHOUT ROWID;
";

/// A case of a store, as an error names it: by its id where known, and
/// its position in the plan's case order (from 0).
fn case_name(idx: usize, id: &str) -> String {
    match id {
        "" => format!("at position {idx}"),
        id => format!("`{id}` (position {idx})"),
    }
}

/// What identifies a run: a store is resumed only by a run of the same
/// plan, inputs, tool and backend.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunKey {
    /// Plan id.
    pub plan_id: String,
    /// Hash of the plan and every input it names
    /// ([`crate::shard::record::plan_hash`]).
    pub plan_hash: String,
    /// `ledflicker <version>`.
    pub tool: String,
    /// Backend id.
    pub backend: String,
    /// Cases in the plan.
    pub case_count: usize,
}

impl RunKey {
    fn rows(&self) -> [(&'static str, String); 6] {
        [
            ("schema", SCHEMA.to_string()),
            ("plan_id", self.plan_id.clone()),
            ("plan_hash", self.plan_hash.clone()),
            ("tool", self.tool.clone()),
            ("backend", self.backend.clone()),
            ("case_count", self.case_count.to_string()),
        ]
    }
}

/// Why the store failed.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// SQLite failed on the file.
    #[error("case store `{}`", path.display())]
    Sqlite {
        /// The store file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: rusqlite::Error,
    },
    /// A case could not be encoded or decoded.
    #[error("case store `{}`: case {}: {message}", path.display(), case_name(*idx, id))]
    Record {
        /// The store file.
        path: PathBuf,
        /// The case's index.
        idx: usize,
        /// The case's id, where the store names it (else empty).
        id: String,
        /// What is wrong.
        message: String,
    },
    /// The store belongs to another run, or is not a store at all.
    #[error("case store `{}` cannot be resumed: {message}", path.display())]
    Mismatch {
        /// The store file.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// The finished store could not replace the partial one.
    #[error("case store `{}`", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// A store being written.
pub struct Store {
    conn: Connection,
    path: PathBuf,
    /// Cases written in the open transaction.
    pending: usize,
    /// When the open transaction began.
    opened: Instant,
}

impl Store {
    /// Creates the partial store of a new run in `dir`.
    pub fn create(dir: &Path, key: &RunKey) -> Result<Store, StoreError> {
        let path = dir.join(PARTIAL);
        remove_partial(&path)?;
        let conn = Connection::open(&path).map_err(sqlite(&path))?;
        let mut store = Store::tuned(conn, path)?;
        let sql = sqlite(&store.path);
        // One transaction: one append to the log instead of one per table
        // and row.
        let tx = store.conn.transaction().map_err(&sql)?;
        tx.execute_batch(CREATE).map_err(&sql)?;
        for (k, v) in key
            .rows()
            .iter()
            .chain([&("status", "running".to_string())])
        {
            tx.execute(
                "INSERT INTO run (key, value) VALUES (?1, ?2)",
                params![k, v],
            )
            .map_err(&sql)?;
        }
        tx.commit().map_err(&sql)?;
        drop(sql);
        Ok(store)
    }

    /// Opens the partial store an interrupted run left in `dir`, once it
    /// was made by a run of `key`; returns it with the positions of the
    /// cases it holds.
    pub fn resume(dir: &Path, key: &RunKey) -> Result<(Store, BTreeSet<usize>), StoreError> {
        let path = dir.join(PARTIAL);
        let finished = dir.join(FILE);
        if !path.is_file() && finished.is_file() {
            // A run stopped in its report stage: every case is stored in
            // the finished store. They go into a new partial store, as a
            // run stores them (so that the finished store made again is
            // the same file, byte for byte), then are judged again.
            return Store::resume_finished(dir, &finished, key);
        }
        if !path.is_file() {
            return Err(StoreError::Mismatch {
                path,
                message:
                    "there is no partial case store (the run finished, or never stored a case)"
                        .to_string(),
            });
        }
        let conn = Connection::open(&path).map_err(sqlite(&path))?;
        let store = Store::tuned(conn, path)?;
        let stored = store.run_rows()?;
        for (k, want) in key.rows() {
            let have = stored
                .iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.as_str());
            if have != Some(want.as_str()) {
                return Err(StoreError::Mismatch {
                    path: store.path.clone(),
                    message: format!(
                        "its {k} is {}, this run's is `{want}`",
                        have.map_or("missing".to_string(), |h| format!("`{h}`"))
                    ),
                });
            }
        }
        // Metric rows of no stored case (a case row deleted by hand) are
        // no case's data; left in place, they would collide with that
        // case's metrics when it is run, and every resume would fail.
        store
            .conn
            .execute(
                "DELETE FROM roi_metrics WHERE idx NOT IN (SELECT idx FROM cases)",
                [],
            )
            .map_err(sqlite(&store.path))?;
        let done = store.positions()?;
        Ok((store, done))
    }

    /// [`Store::resume`] of a run stopped after its run stage: the cases of
    /// the finished store `finished` (of a run of `key`) moved into a new
    /// partial store, the finished one removed.
    fn resume_finished(
        dir: &Path,
        finished: &Path,
        key: &RunKey,
    ) -> Result<(Store, BTreeSet<usize>), StoreError> {
        let old = StoredCases::open(finished)?;
        {
            let conn = old.conn.lock().unwrap_or_else(|p| p.into_inner());
            let sql = sqlite(finished);
            for (k, want) in key.rows() {
                let have: Option<String> = conn
                    .query_row("SELECT value FROM run WHERE key = ?1", [k], |r| {
                        r.get("value")
                    })
                    .optional()
                    .map_err(&sql)?;
                if have.as_deref() != Some(want.as_str()) {
                    return Err(StoreError::Mismatch {
                        path: finished.to_path_buf(),
                        message: format!(
                            "its {k} is {}, this run's is `{want}`",
                            have.map_or("missing".to_string(), |h| format!("`{h}`"))
                        ),
                    });
                }
            }
        }
        let mut store = Store::create(dir, key)?;
        let count = old.len;
        let mut start = 0;
        while start < count {
            let end = (start + 256).min(count);
            for (i, case) in (start..end).zip(old.read_range(start..end)?) {
                store.put(i, case)?;
            }
            start = end;
        }
        store.commit()?;
        drop(old);
        remove_file(finished)?;
        let done = store.positions()?;
        Ok((store, done))
    }

    fn tuned(conn: Connection, path: PathBuf) -> Result<Store, StoreError> {
        // WAL: a commit is one append; NORMAL: a killed process loses no
        // committed case (only a machine crash could), and commits do not
        // wait for the disk. No checkpoints: the partial store is read once,
        // by `finish`'s VACUUM INTO, which reads the log as well as the
        // database file, so copying the log into the file as the run goes
        // (each time with two fsyncs) would be work thrown away; it took
        // about a third of the writer's time on a sweep of small cases.
        // Turning a new file to WAL is not synced either (four fsyncs, 15 ms
        // here): a machine crash at that instant leaves a partial store that
        // `--resume` refuses, and the run starts afresh.
        conn.execute_batch(
            "PRAGMA synchronous = OFF; PRAGMA journal_mode = WAL; \
             PRAGMA synchronous = NORMAL; PRAGMA wal_autocheckpoint = 0;",
        )
        .map_err(sqlite(&path))?;
        Ok(Store {
            conn,
            path,
            pending: 0,
            opened: Instant::now(),
        })
    }

    fn run_rows(&self) -> Result<Vec<(String, String)>, StoreError> {
        let sql = sqlite(&self.path);
        let mut q = self
            .conn
            .prepare("SELECT key, value FROM run")
            .map_err(|e| StoreError::Mismatch {
                path: self.path.clone(),
                message: format!("it is not a ledflicker case store ({e})"),
            })?;
        let rows = q
            .query_map([], |r| Ok((r.get("key")?, r.get("value")?)))
            .map_err(&sql)?;
        rows.collect::<Result<_, _>>().map_err(sql)
    }

    /// Positions of the cases stored.
    fn positions(&self) -> Result<BTreeSet<usize>, StoreError> {
        let sql = sqlite(&self.path);
        let mut q = self.conn.prepare("SELECT idx FROM cases").map_err(&sql)?;
        let rows = q.query_map([], |r| r.get::<_, i64>("idx")).map_err(&sql)?;
        rows.map(|r| r.map(|i| i as usize))
            .collect::<Result<_, _>>()
            .map_err(sql)
    }

    /// Stores the case at position `idx` of the run.
    pub fn put(&mut self, idx: usize, result: CaseResult) -> Result<(), StoreError> {
        self.put_encoded(idx, Encoded::new(result))
    }

    /// Stores the case at position `idx` of the run, encoded by
    /// [`Encoded::new`] (in its worker, while the run goes on).
    pub fn put_encoded(&mut self, idx: usize, case: Encoded) -> Result<(), StoreError> {
        self.write_case(idx, case, false)
    }

    /// Writes the case at `idx` into the open batch (replacing the one
    /// stored there when `replace`), and commits the batch when it is
    /// full or old enough.
    ///
    /// The batch is a transaction held open across many calls, which a
    /// guard cannot be (it would borrow the connection the store owns):
    /// it is begun and committed by statement. Each case goes into it
    /// under a savepoint guard instead, so that a case that fails halfway
    /// is rolled back whole, and the batch that is committed later (by
    /// [`Store::close`] after the error, so that a resumed run keeps the
    /// cases before it) never holds part of a case.
    fn write_case(&mut self, idx: usize, case: Encoded, replace: bool) -> Result<(), StoreError> {
        let row = case.0.map_err(|message| StoreError::Record {
            path: self.path.clone(),
            idx,
            id: String::new(),
            message,
        })?;
        let sql = sqlite(&self.path);
        if self.conn.is_autocommit() {
            self.conn.execute_batch("BEGIN").map_err(&sql)?;
            self.opened = Instant::now();
        }
        let case = self.conn.savepoint().map_err(&sql)?;
        if replace {
            for table in ["roi_metrics", "cases"] {
                case.prepare_cached(&format!("DELETE FROM {table} WHERE idx = ?1"))
                    .and_then(|mut q| q.execute(params![idx as i64]))
                    .map_err(&sql)?;
            }
        }
        insert(&case, idx, &row).map_err(&sql)?;
        case.commit().map_err(&sql)?;
        drop(sql);
        self.pending += 1;
        if self.pending >= BATCH || self.opened.elapsed() >= COMMIT_EVERY {
            self.commit()?;
        }
        Ok(())
    }

    /// Commits the cases written since the last commit: called when no case
    /// has finished for a moment, so that a run killed during a long case
    /// keeps every case before it.
    pub fn flush(&mut self) -> Result<(), StoreError> {
        self.commit()
    }

    /// Commits the open batch, if any. A batch holds whole cases only
    /// ([`Store::write_case`]), so a failed commit leaves it open and
    /// whole, for the next commit to try again.
    fn commit(&mut self) -> Result<(), StoreError> {
        if !self.conn.is_autocommit() {
            self.conn
                .execute_batch("COMMIT")
                .map_err(sqlite(&self.path))?;
            self.pending = 0;
        }
        Ok(())
    }

    /// Judges every stored case again with `judge` (its position in the
    /// run and the case as stored) and stores what it gives in its place:
    /// a partial store is input, which anyone could have edited, so a
    /// resumed run takes its data (the acquisitions), never its
    /// conclusions. Returns how many cases were kept. A case `judge`
    /// refuses is an error naming it.
    pub fn rejudge(
        &mut self,
        judge: &(dyn Fn(usize, CaseResult) -> Result<CaseResult, String> + Sync),
    ) -> Result<usize, StoreError> {
        use rayon::prelude::*;
        /// Cases decoded and judged at once: bounded memory on a store of
        /// a large sweep.
        const CHUNK: usize = 256;
        let positions: Vec<usize> = self.positions()?.into_iter().collect();
        for chunk in positions.chunks(CHUNK) {
            let stored = self.read_rows(chunk)?;
            // Decoded on the workers too: inflating and decoding a chunk on
            // this thread took longer than judging it.
            let judged: Vec<(usize, String, Result<Option<Encoded>, String>)> = stored
                .into_par_iter()
                .map(|(idx, row)| {
                    let judged = record::decode_plain(&row.bytes).and_then(|(case, plain)| {
                        let judged = Row::plain(judge(idx, case)?)?;
                        // A case whose judgement gives back the very row
                        // stored (its record, as inflated, its columns and
                        // its metrics) is left in place: rewriting every
                        // stored case made a resumed run slower than a
                        // fresh one, and deflating each judgement again
                        // only to compare it cost as much as running it.
                        Ok((!judged.same_as(&row, &plain)).then(|| Encoded(Ok(judged.deflated()))))
                    });
                    (idx, row.id, judged)
                })
                .collect();
            for (idx, id, judged) in judged {
                let judged = judged.map_err(|message| StoreError::Record {
                    path: self.path.clone(),
                    idx,
                    id,
                    message,
                })?;
                if let Some(encoded) = judged {
                    self.write_case(idx, encoded, true)?;
                }
            }
        }
        self.commit()?;
        Ok(positions.len())
    }

    /// Commits what is pending: after an interruption, so that a resumed
    /// run finds every case that finished.
    pub fn close(mut self) -> Result<(), StoreError> {
        self.commit()
    }

    /// Marks the run complete and writes the finished store, in case
    /// order, as [`FILE`] beside the partial one, which is removed.
    /// Returns the finished store's path.
    pub fn finish(mut self) -> Result<PathBuf, StoreError> {
        self.commit()?;
        let sql = sqlite(&self.path);
        self.conn
            .execute("UPDATE run SET value = 'complete' WHERE key = 'status'", [])
            .map_err(&sql)?;
        let dir = self.path.parent().unwrap_or(Path::new("."));
        let done = dir.join(FILE);
        remove_file(&done)?;
        self.conn
            .execute("VACUUM INTO ?1", params![done.to_string_lossy()])
            .map_err(&sql)?;
        // The partial store is removed next: copying its log into it on
        // close would be thrown away.
        self.conn
            .set_db_config(DbConfig::SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, true)
            .map_err(&sql)?;
        let partial = self.path.clone();
        drop(self.conn);
        remove_partial(&partial)?;
        Ok(done)
    }
}

/// A case encoded for the store: its record and its columns, or why it
/// could not be encoded.
pub struct Encoded(Result<Row, String>);

struct Row {
    id: String,
    light_lux: f64,
    frequency_hz: f64,
    duty: f64,
    verdict: &'static str,
    bytes: Vec<u8>,
    metrics: Vec<(String, &'static str, Option<f64>)>,
}

impl Encoded {
    /// Encodes `result`: the work of storing a case that needs no
    /// database, so that a run's workers can do it in parallel.
    pub fn new(result: CaseResult) -> Encoded {
        Encoded(Row::plain(result).map(Row::deflated))
    }
}

impl Row {
    /// The row of `result`, its `bytes` the record not yet deflated.
    fn plain(result: CaseResult) -> Result<Row, String> {
        let metrics = roi_metrics(&result);
        let c = &result.case;
        let (id, light_lux, frequency_hz, duty) =
            (c.id.clone(), c.light_lux, c.frequency_hz, c.duty);
        let verdict = result.verdict.as_str();
        record::encode_plain(result).map(|bytes| Row {
            id,
            light_lux,
            frequency_hz,
            duty,
            verdict,
            bytes,
            metrics,
        })
    }

    /// The row with its record deflated, as the store holds it.
    fn deflated(self) -> Row {
        Row {
            bytes: record::deflate(&self.bytes),
            ..self
        }
    }
}

/// Inserts the case `row` at position `idx`: its row and its metrics.
fn insert(conn: &Connection, idx: usize, row: &Row) -> rusqlite::Result<()> {
    conn.prepare_cached(
        "INSERT INTO cases (idx, id, light_lux, frequency_hz, duty, verdict, result) \
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
    )?
    .execute(params![
        idx as i64,
        row.id,
        row.light_lux,
        row.frequency_hz,
        row.duty,
        row.verdict,
        row.bytes
    ])?;
    let mut m = conn.prepare_cached(
        "INSERT INTO roi_metrics (idx, roi, metric, value) VALUES (?1, ?2, ?3, ?4)",
    )?;
    for (roi, metric, value) in &row.metrics {
        m.execute(params![idx as i64, roi, metric, value])?;
    }
    Ok(())
}

/// The `roi_metrics` rows of a case: each ROI's metrics by their
/// results.json names; an undefined metric is NULL.
fn roi_metrics(result: &CaseResult) -> Vec<(String, &'static str, Option<f64>)> {
    let mut rows = Vec::new();
    for (i, (trace, m)) in result
        .acquisition
        .rois
        .iter()
        .zip(&result.metrics)
        .enumerate()
    {
        let mut named = vec![
            ("fdi_2018", Some(&m.fdi_2018)),
            ("percent_flicker", Some(&m.percent_flicker)),
            ("fdi_2018_worst_phase", m.fdi_2018_worst_phase.as_ref()),
            (
                "percent_flicker_worst_phase",
                m.percent_flicker_worst_phase.as_ref(),
            ),
        ];
        if let Some(p) = result.p2020.get(i) {
            named.extend([
                ("fmi", Some(&p.fmi)),
                ("fdi_p2020", Some(&p.fdi)),
                ("mmp", Some(&p.mmp)),
            ]);
        }
        for (name, metric) in named {
            if let Some(metric) = metric {
                rows.push((trace.name.clone(), name, metric.value));
            }
        }
    }
    rows
}

/// Every case of the finished store at `path`, in case order.
pub fn read_cases(path: &Path) -> Result<Vec<CaseResult>, StoreError> {
    let stored = StoredCases::open(path)?;
    stored.read_range(0..stored.len)
}

/// The cases of a finished store, read back a chunk at a time
/// ([`CaseSource`]): the stages after the run hold a chunk of them, never
/// the whole run.
pub struct StoredCases {
    /// One connection, read by one worker at a time (a connection is not
    /// shared between threads).
    conn: std::sync::Mutex<Connection>,
    path: PathBuf,
    len: usize,
}

impl StoredCases {
    /// Opens the finished store at `path`, read only; a store whose run
    /// did not finish, or whose cases are not numbered 0 to n - 1, is
    /// refused.
    pub fn open(path: &Path) -> Result<StoredCases, StoreError> {
        let conn = Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .map_err(sqlite(path))?;
        let sql = sqlite(path);
        let status: Option<String> = conn
            .query_row("SELECT value FROM run WHERE key = 'status'", [], |r| {
                r.get("value")
            })
            .optional()
            .map_err(&sql)?;
        if status.as_deref() != Some("complete") {
            return Err(StoreError::Mismatch {
                path: path.to_path_buf(),
                message: "its run did not finish".to_string(),
            });
        }
        let (count, last): (i64, Option<i64>) = conn
            .query_row(
                "SELECT COUNT(*) AS count, MAX(idx) AS last FROM cases",
                [],
                |r| Ok((r.get("count")?, r.get("last")?)),
            )
            .map_err(&sql)?;
        if last.map_or(count != 0, |last| last + 1 != count) {
            return Err(StoreError::Mismatch {
                path: path.to_path_buf(),
                message: format!("it holds {count} cases, numbered up to {last:?}"),
            });
        }
        Ok(StoredCases {
            conn: std::sync::Mutex::new(conn),
            path: path.to_path_buf(),
            len: usize::try_from(count).unwrap_or(0),
        })
    }

    /// Every case id, in case order (`ledflicker export` finds a case by
    /// it).
    pub fn ids(&self) -> Result<Vec<String>, StoreError> {
        let sql = sqlite(&self.path);
        let conn = self.conn.lock().unwrap_or_else(|p| p.into_inner());
        let mut q = conn
            .prepare("SELECT id FROM cases ORDER BY idx")
            .map_err(&sql)?;
        let ids = q
            .query_map([], |r| r.get::<_, String>("id"))
            .map_err(&sql)?;
        ids.collect::<Result<_, _>>().map_err(&sql)
    }

    fn read_range(&self, range: std::ops::Range<usize>) -> Result<Vec<CaseResult>, StoreError> {
        let path = &self.path;
        let sql = sqlite(path);
        let conn = match self.conn.lock() {
            Ok(conn) => conn,
            // A reader that panicked left no state behind in a read-only
            // connection.
            Err(poisoned) => poisoned.into_inner(),
        };
        let mut q = conn
            .prepare_cached(
                "SELECT idx, result FROM cases WHERE idx >= ?1 AND idx < ?2 ORDER BY idx",
            )
            .map_err(&sql)?;
        let rows = q
            .query_map(params![range.start as i64, range.end as i64], |r| {
                Ok((r.get::<_, i64>("idx")?, r.get::<_, Vec<u8>>("result")?))
            })
            .map_err(&sql)?;
        let mut cases = Vec::with_capacity(range.len());
        for (want, row) in range.clone().zip(rows) {
            let (idx, bytes) = row.map_err(&sql)?;
            if idx != want as i64 {
                return Err(StoreError::Record {
                    path: path.to_path_buf(),
                    idx: want,
                    id: String::new(),
                    message: "missing".to_string(),
                });
            }
            let case = record::decode(&bytes).map_err(|message| StoreError::Record {
                path: path.to_path_buf(),
                idx: want,
                id: String::new(),
                message,
            })?;
            cases.push(case);
        }
        if cases.len() != range.len() {
            return Err(StoreError::Record {
                path: path.to_path_buf(),
                idx: range.start + cases.len(),
                id: String::new(),
                message: "missing".to_string(),
            });
        }
        Ok(cases)
    }
}

impl CaseSource for StoredCases {
    fn len(&self) -> usize {
        self.len
    }

    fn read(&self, range: std::ops::Range<usize>) -> Result<Vec<CaseResult>, CaseReadError> {
        Ok(self.read_range(range)?)
    }
}

fn sqlite(path: &Path) -> impl Fn(rusqlite::Error) -> StoreError + '_ {
    move |source| StoreError::Sqlite {
        path: path.to_path_buf(),
        source,
    }
}

fn remove_file(path: &Path) -> Result<(), StoreError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(StoreError::Io {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Removes the partial store at `path` (named [`PARTIAL`]) with its WAL files.
fn remove_partial(path: &Path) -> Result<(), StoreError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    for name in [PARTIAL, PARTIAL_WAL, PARTIAL_SHM] {
        remove_file(&dir.join(name))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
