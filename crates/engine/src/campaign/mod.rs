//! The results database: every finished run of `plan` and `merge`, and
//! every report directory `import` reads, with its device, cases, ROIs,
//! metrics and verdicts, in one SQLite file across runs, or on a lab's
//! PostgreSQL server with the same schema (docs/campaigns.md).
//! `history` lists the runs, `compare` gates one against another.
//!
//! ```text
//! Results (results.json) + report dir ──record──▶ results.sqlite
//!                                                   │ query::history
//!                                                   │ query::load_run ──▶ compare
//! ```
//!
//! It sits after the pipeline: a run is recorded once its report is
//! written, so recording never slows or endangers the report. A run is
//! written in one transaction, so a run killed while it is recorded
//! leaves nothing of itself; WAL and a busy timeout let several runs
//! record into one file at once. On PostgreSQL ([`pg`], feature
//! `postgres`) the same statements run ([`sql`]), and the server's MVCC
//! lets many clients record at once.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rusqlite::{Connection, OpenFlags, OptionalExtension, TransactionBehavior};

pub mod compare;
pub mod flips;
pub mod noise;
pub mod pages;
pub mod query;
pub mod record;
pub mod rejudge;
pub mod repeats;
pub mod server;
pub mod setup;
pub mod sql;
pub mod stats;
pub mod view;

#[cfg(feature = "postgres")]
pub mod pg;

/// Name of the schema; its version is SQLite's `user_version`, or on
/// PostgreSQL the highest row of the table `schema_version`.
pub const SCHEMA: &str = "ledflicker.db";
/// The database's file name in its directory.
pub const FILE: &str = "results.sqlite";
/// Environment variable naming the database (as `--db`).
pub const ENV: &str = "LEDFLICKER_DB";

/// How long a writer waits for another process's transaction to end.
/// Recording a large run takes well under a second; a lab's CI may start
/// a few runs at once.
const BUSY_TIMEOUT: Duration = Duration::from_secs(30);

/// The schema's migrations, in order: migration `i` takes the database
/// from version `i` to `i + 1`. Version 0 is an empty file (or none).
/// A step is never edited once shipped; a change is a new step.
pub const MIGRATIONS: &[&str] = &[include_str!("schema_1.sql"), include_str!("schema_2.sql")];

/// Why the database could not be used.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    /// SQLite failed on the file.
    #[error("results database `{}`", path.display())]
    Sqlite {
        /// The database file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: rusqlite::Error,
    },
    /// The file is not a results database, or of a newer schema.
    #[error("results database `{}`: {message}", path.display())]
    Unusable {
        /// The database file.
        path: PathBuf,
        /// What is wrong, with a hint.
        message: String,
    },
    /// The PostgreSQL server refused or failed; `url` and `message` never
    /// hold the password.
    #[error("results database `{url}`: {message}")]
    Postgres {
        /// The server's URL, password hidden.
        url: String,
        /// What went wrong.
        message: String,
    },
    /// A report directory cannot be recorded, or a run asked for is not
    /// there.
    #[error("{0}")]
    Input(String),
}

impl CampaignError {
    /// The user's file or request is at fault (exit 2), not the tool.
    pub fn is_usage_error(&self) -> bool {
        // Every variant named, so that a new one must be placed.
        match self {
            CampaignError::Unusable { .. } | CampaignError::Input(_) => true,
            CampaignError::Sqlite { .. } | CampaignError::Postgres { .. } => false,
        }
    }
}

pub(crate) fn sqlite(path: &Path) -> impl Fn(rusqlite::Error) -> CampaignError + '_ {
    move |source| CampaignError::Sqlite {
        path: path.to_path_buf(),
        source,
    }
}

/// Where runs are recorded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// `--no-db`: nowhere.
    Off,
    /// This file, named by `--db` or `$LEDFLICKER_DB`: its directory
    /// must exist.
    File(PathBuf),
    /// This file, ledflicker's own default place (XDG or HOME): its
    /// directory is created when missing.
    Default(PathBuf),
    /// The PostgreSQL server at this `postgres://` URL.
    Server(String),
}

/// The database `--db`, `--no-db` and the environment ask for: `--no-db`,
/// else `--db`, else `$LEDFLICKER_DB`, else `$XDG_DATA_HOME/ledflicker/
/// results.sqlite` (an absolute `XDG_DATA_HOME` only, as the XDG base
/// directory specification says), else `$HOME/.local/share/ledflicker/
/// results.sqlite`. `None` when no rule gives a place (no `HOME`). A
/// `postgres://` or `postgresql://` URL names a server.
pub fn locate(
    db: Option<&Path>,
    no_db: bool,
    env: &dyn Fn(&str) -> Option<String>,
) -> Option<Location> {
    if no_db {
        return Some(Location::Off);
    }
    let set = |k: &str| env(k).filter(|v| !v.is_empty());
    let Some(file) = db
        .map(Path::to_path_buf)
        .or_else(|| set(ENV).map(PathBuf::from))
    else {
        return set("XDG_DATA_HOME")
            .map(PathBuf::from)
            .filter(|p| p.is_absolute())
            .map(|p| p.join("ledflicker").join(FILE))
            .or_else(|| {
                set("HOME").map(|h| Path::new(&h).join(".local/share/ledflicker").join(FILE))
            })
            .map(Location::Default);
    };
    match file.to_str() {
        Some(url) if server::is_url(url) => Some(Location::Server(url.to_string())),
        _ => Some(Location::File(file)),
    }
}

/// A database file the user named is made in a directory that exists: a
/// mistyped directory is refused, not created with a new, empty history
/// in it.
pub fn check_directory(path: &Path) -> Result<(), CampaignError> {
    match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) if !dir.is_dir() => Err(CampaignError::Input(format!(
            "results database `{}`: the directory `{}` does not exist\n    hint: create it first (mkdir -p {}), or give a file in an existing directory with --db or $LEDFLICKER_DB",
            path.display(),
            dir.display(),
            dir.display()
        ))),
        _ => Ok(()),
    }
}

/// An open results database: an SQLite file or a PostgreSQL server.
pub enum Database {
    /// A file.
    Sqlite(Db),
    /// A server.
    #[cfg(feature = "postgres")]
    Postgres(Box<pg::PgDb>),
}

impl Database {
    /// Opens (creating it if need be) the database at `at` and brings its
    /// schema up to date.
    pub fn open(at: &Location) -> Result<Database, CampaignError> {
        match at {
            Location::File(path) => {
                check_directory(path)?;
                Db::open(path).map(Database::Sqlite)
            }
            Location::Default(path) => {
                if let Some(dir) = path.parent() {
                    std::fs::create_dir_all(dir).map_err(|e| CampaignError::Unusable {
                        path: path.to_path_buf(),
                        message: format!("cannot create its directory: {e}"),
                    })?;
                }
                Db::open(path).map(Database::Sqlite)
            }
            Location::Server(url) => open_server(url),
            Location::Off => Err(CampaignError::Input(
                "no results database (--no-db)".to_string(),
            )),
        }
    }

    /// Opens a database for reading: a file that is not there is an
    /// error naming it, not an empty history.
    pub fn open_existing(at: &Location) -> Result<Database, CampaignError> {
        match at {
            Location::File(path) | Location::Default(path) => {
                Db::open_existing(path).map(Database::Sqlite)
            }
            Location::Server(_) | Location::Off => Database::open(at),
        }
    }

    /// The file, or the server's URL with its password hidden.
    pub fn path(&self) -> &Path {
        match self {
            Database::Sqlite(db) => &db.path,
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => &db.path,
        }
    }
}

#[cfg(feature = "postgres")]
fn open_server(url: &str) -> Result<Database, CampaignError> {
    pg::PgDb::open(url, pg::MIGRATIONS).map(|db| Database::Postgres(Box::new(db)))
}

#[cfg(not(feature = "postgres"))]
fn open_server(url: &str) -> Result<Database, CampaignError> {
    Err(CampaignError::Unusable {
        path: PathBuf::from(server::redact(url)),
        message: "a PostgreSQL server needs the `postgres` feature, which this ledflicker was built without\n    hint: build it with default features (or --features postgres), or pass an SQLite file to --db".to_string(),
    })
}

/// An open results database, migrated to the current schema.
pub struct Db {
    pub(crate) conn: Connection,
    pub(crate) path: PathBuf,
}

impl Db {
    /// Opens (creating it and its directory if need be) the database at
    /// `path` and brings its schema up to date.
    pub fn open(path: &Path) -> Result<Db, CampaignError> {
        Db::open_with(path, MIGRATIONS)
    }

    /// Opens an existing database for reading; a missing file is an error
    /// naming it, not an empty history. A current database is opened read
    /// only, so that `history`, `compare` and `trend` work on a file they
    /// may not write (a read-only mount, another user's file) and never
    /// change one: not its journal mode, not its schema. Only a database
    /// of an older schema is opened for writing, to be migrated.
    pub fn open_existing(path: &Path) -> Result<Db, CampaignError> {
        if !path.is_file() {
            return Err(CampaignError::Unusable {
                path: path.to_path_buf(),
                message: "no such file\n    hint: runs are recorded by `ledflicker plan` and `ledflicker import`; pass the database with --db or $LEDFLICKER_DB".to_string(),
            });
        }
        let sql = sqlite(path);
        let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let conn = match Connection::open_with_flags(path, flags) {
            Ok(c) => c,
            Err(e) => return Err(not_a_database(path, e)),
        };
        conn.busy_timeout(BUSY_TIMEOUT).map_err(&sql)?;
        // A database in WAL mode whose directory may not be written cannot
        // make its shared-memory file: read it as immutable then (nobody
        // writes a file on a read-only mount).
        let conn = match schema_state(&conn, path, MIGRATIONS.len()) {
            Err(CampaignError::Sqlite { .. }) => {
                let uri = format!("file:{}?immutable=1", uri_path(path));
                let flags = flags | OpenFlags::SQLITE_OPEN_URI;
                let c = Connection::open_with_flags(uri, flags).map_err(&sql)?;
                schema_state(&c, path, MIGRATIONS.len())?;
                c
            }
            other => {
                other?;
                conn
            }
        };
        if schema_state(&conn, path, MIGRATIONS.len())? < MIGRATIONS.len() {
            drop(conn);
            return Db::open(path).map_err(|e| match e {
                CampaignError::Sqlite { source, .. }
                    if source.sqlite_error_code() == Some(rusqlite::ErrorCode::ReadOnly) =>
                {
                    CampaignError::Unusable {
                        path: path.to_path_buf(),
                        message: format!(
                            "its schema is older than this ledflicker's {SCHEMA}/{} and must be migrated, which needs write permission\n    hint: run `ledflicker history --db FILE` once as a user who may write it",
                            MIGRATIONS.len()
                        ),
                    }
                }
                e => e,
            });
        }
        Ok(Db {
            conn,
            path: path.to_path_buf(),
        })
    }

    /// [`Db::open`] with the given migrations (tests give fewer, to make a
    /// database of an older version).
    pub fn open_with(path: &Path, migrations: &[&str]) -> Result<Db, CampaignError> {
        let sql = sqlite(path);
        let conn = Connection::open(path).map_err(&sql)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(&sql)?;
        // Refuse a file that is not a results database before anything is
        // written to it: switching to WAL rewrites the file's header.
        schema_state(&conn, path, migrations.len())?;
        // WAL: readers never block the writer, and a commit is one append.
        conn.pragma_update(None, "journal_mode", "WAL")
            .map_err(|e| not_a_database(path, e))?;
        conn.execute_batch("PRAGMA foreign_keys = ON; PRAGMA synchronous = NORMAL;")
            .map_err(&sql)?;
        let mut db = Db {
            conn,
            path: path.to_path_buf(),
        };
        db.migrate(migrations)?;
        Ok(db)
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The schema version the file is at.
    pub fn version(&self) -> Result<usize, CampaignError> {
        let v: i64 = self
            .conn
            .query_row("PRAGMA user_version", [], |r| r.get("user_version"))
            .map_err(|e| not_a_database(&self.path, e))?;
        Ok(v.max(0) as usize)
    }

    /// Applies every step past the file's version, each with its new
    /// version in one transaction: a migration stopped halfway leaves the
    /// old version whole. Two processes migrating at once are serialised
    /// by the write lock taken before the version is read.
    fn migrate(&mut self, migrations: &[&str]) -> Result<(), CampaignError> {
        let path = self.path.clone();
        let sql = sqlite(&path);
        loop {
            let tx = self
                .conn
                .transaction_with_behavior(TransactionBehavior::Immediate)
                .map_err(|e| not_a_database(&path, e))?;
            let version: i64 = tx
                .query_row("PRAGMA user_version", [], |r| r.get("user_version"))
                .map_err(&sql)?;
            let version = version.max(0) as usize;
            if version > migrations.len() {
                return Err(CampaignError::Unusable {
                    path: path.clone(),
                    message: format!(
                        "its schema is {SCHEMA}/{version}, newer than this ledflicker's {SCHEMA}/{}\n    hint: use a newer ledflicker, or another --db",
                        migrations.len()
                    ),
                });
            }
            if version == 0 && !is_empty(&tx).map_err(&sql)? {
                return Err(CampaignError::Unusable {
                    path: path.clone(),
                    message: "it is an SQLite database, but not a ledflicker results database\n    hint: pass another file with --db".to_string(),
                });
            }
            let Some(step) = migrations.get(version) else {
                return Ok(());
            };
            tx.execute_batch(step).map_err(&sql)?;
            tx.pragma_update(None, "user_version", (version + 1) as i64)
                .map_err(&sql)?;
            tx.commit().map_err(&sql)?;
        }
    }
}

/// The schema version of an open file, read without writing: an SQLite
/// file that is not a results database, or of a newer schema, is refused.
fn schema_state(conn: &Connection, path: &Path, known: usize) -> Result<usize, CampaignError> {
    let version: i64 = conn
        .query_row("PRAGMA user_version", [], |r| r.get("user_version"))
        .map_err(|e| not_a_database(path, e))?;
    let version = version.max(0) as usize;
    if version > known {
        return Err(CampaignError::Unusable {
            path: path.to_path_buf(),
            message: format!(
                "its schema is {SCHEMA}/{version}, newer than this ledflicker's {SCHEMA}/{known}\n    hint: use a newer ledflicker, or another --db"
            ),
        });
    }
    if version == 0 && !is_empty(conn).map_err(|e| not_a_database(path, e))? {
        return Err(CampaignError::Unusable {
            path: path.to_path_buf(),
            message: "it is an SQLite database, but not a ledflicker results database\n    hint: pass another file with --db".to_string(),
        });
    }
    Ok(version)
}

/// `path` for an SQLite `file:` URI: absolute, with `%`, `?` and `#`
/// escaped.
fn uri_path(path: &Path) -> String {
    let abs = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = String::new();
    for c in abs.to_string_lossy().chars() {
        match c {
            '%' => out.push_str("%25"),
            '?' => out.push_str("%3f"),
            '#' => out.push_str("%23"),
            c => out.push(c),
        }
    }
    out
}

/// The database holds no table.
fn is_empty(conn: &Connection) -> rusqlite::Result<bool> {
    conn.query_row("SELECT name FROM sqlite_master LIMIT 1", [], |r| {
        r.get::<_, String>("name")
    })
    .optional()
    .map(|t| t.is_none())
}

fn not_a_database(path: &Path, e: rusqlite::Error) -> CampaignError {
    match e.sqlite_error_code() {
        Some(rusqlite::ErrorCode::NotADatabase) => CampaignError::Unusable {
            path: path.to_path_buf(),
            message: "it is not an SQLite database\n    hint: pass another file with --db"
                .to_string(),
        },
        _ => sqlite(path)(e),
    }
}

#[cfg(test)]
mod tests;
