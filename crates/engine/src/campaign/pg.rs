//! The results database on a PostgreSQL server (`--db postgres://...`):
//! the connection, the schema's migrations under an advisory lock, and
//! the statements of [`super::sql`] run on it.
//!
//! The client is the pure-Rust `postgres` crate without TLS: a lab server
//! is reached on a trusted network or a Unix socket; credentials come
//! from the URL or the libpq password file ([`super::server`]).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::rc::Rc;

use bytes::BytesMut;
use postgres::types::{IsNull, ToSql, Type, to_sql_checked};
use postgres::{Client, Config, GenericClient, NoTls};

use super::server::{self, Target};
use super::sql::{Row, ServerTx, Tx, Value};
use super::{CampaignError, SCHEMA};

/// The schema's steps for PostgreSQL, the same tables and columns as
/// [`super::MIGRATIONS`] for SQLite, step for step.
pub const MIGRATIONS: &[&str] = &[
    include_str!("schema_1.pg.sql"),
    include_str!("schema_2.pg.sql"),
];

/// Key of the advisory lock a client holds while it reads and raises the
/// schema version, so that two clients starting together migrate once
/// ("ledflick" in ASCII).
const LOCK_KEY: i64 = 0x6c65_6466_6c69_636b;

/// The table holding the schema's version, one row per step applied.
const VERSION_TABLE: &str = "CREATE TABLE schema_version (\
    version BIGINT PRIMARY KEY, applied_unix_s BIGINT NOT NULL, tool TEXT NOT NULL)";

/// An open connection to a results database on a server, migrated.
pub struct PgDb {
    client: RefCell<Client>,
    /// Statements prepared on this connection, by their SQL.
    statements: RefCell<HashMap<String, postgres::Statement>>,
    /// The URL, password hidden: how messages name the database.
    pub(crate) path: PathBuf,
    /// The password as the URL holds it, kept out of every message.
    secrets: Vec<String>,
}

impl PgDb {
    /// Connects to `url` and brings its schema up to `migrations`.
    pub fn open(url: &str, migrations: &[&str]) -> Result<PgDb, CampaignError> {
        let client = connect(url)?;
        let mut db = PgDb {
            client: RefCell::new(client),
            statements: RefCell::new(HashMap::new()),
            path: PathBuf::from(server::redact(url)),
            secrets: server::secrets_in(url),
        };
        db.migrate(migrations)?;
        Ok(db)
    }

    fn error(&self, e: &postgres::Error) -> CampaignError {
        CampaignError::Postgres {
            url: self.path.display().to_string(),
            message: chain(e, &self.secrets),
        }
    }

    /// The schema version of the database.
    pub fn version(&self) -> Result<usize, CampaignError> {
        let mut c = self.client.borrow_mut();
        version_of(&mut *c).map_err(|e| self.error(&e))
    }

    /// Applies each step past the database's version, each in one
    /// transaction with its row in `schema_version`, under the advisory
    /// lock: a second client waits, then finds the steps applied.
    fn migrate(&mut self, migrations: &[&str]) -> Result<(), CampaignError> {
        loop {
            let mut c = self.client.borrow_mut();
            let mut tx = c.transaction().map_err(|e| self.error(&e))?;
            tx.execute("SELECT pg_advisory_xact_lock($1)", &[&LOCK_KEY])
                .map_err(|e| self.error(&e))?;
            let version = version_of(&mut tx).map_err(|e| self.error(&e))?;
            if version > migrations.len() {
                return Err(CampaignError::Unusable {
                    path: self.path.clone(),
                    message: format!(
                        "its schema is {SCHEMA}/{version}, newer than this ledflicker's {SCHEMA}/{}\n    hint: use a newer ledflicker, or another --db",
                        migrations.len()
                    ),
                });
            }
            if version == 0 {
                let others: i64 = tx
                    .query_one(
                        "SELECT count(*) AS tables FROM information_schema.tables \
                         WHERE table_schema = current_schema() AND table_name <> 'schema_version'",
                        &[],
                    )
                    .and_then(|r| r.try_get("tables"))
                    .map_err(|e| self.error(&e))?;
                if others > 0 {
                    return Err(CampaignError::Unusable {
                        path: self.path.clone(),
                        message: "its schema holds tables, but it is not a ledflicker results database\n    hint: pass another database with --db".to_string(),
                    });
                }
            }
            let Some(step) = migrations.get(version) else {
                return Ok(());
            };
            if !has_version_table(&mut tx).map_err(|e| self.error(&e))? {
                tx.batch_execute(VERSION_TABLE)
                    .map_err(|e| self.error(&e))?;
            }
            tx.batch_execute(step).map_err(|e| self.error(&e))?;
            let now = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs() as i64);
            tx.execute(
                "INSERT INTO schema_version (version, applied_unix_s, tool) VALUES ($1, $2, $3)",
                &[
                    &((version + 1) as i64),
                    &now,
                    &concat!("ledflicker ", env!("CARGO_PKG_VERSION")),
                ],
            )
            .map_err(|e| self.error(&e))?;
            tx.commit().map_err(|e| self.error(&e))?;
        }
    }

    /// The prepared statement of `sql` on this connection, prepared on
    /// `c` (the client, or a transaction on it) the first time.
    fn statement(
        &self,
        c: &mut impl GenericClient,
        sql: &str,
    ) -> Result<postgres::Statement, CampaignError> {
        if let Some(s) = self.statements.borrow().get(sql) {
            return Ok(s.clone());
        }
        let st = c
            .prepare(&super::sql::dollar_placeholders(sql))
            .map_err(|e| self.error(&e))?;
        self.statements
            .borrow_mut()
            .insert(sql.to_string(), st.clone());
        Ok(st)
    }

    pub(crate) fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError> {
        self.rows_in(&mut *self.client.borrow_mut(), sql, params)
    }

    /// The rows `sql` gives on `c`: the client, or a transaction on it.
    fn rows_in(
        &self,
        c: &mut impl GenericClient,
        sql: &str,
        params: &[Value],
    ) -> Result<Vec<Row>, CampaignError> {
        let st = self.statement(c, sql)?;
        let refs: Vec<&(dyn ToSql + Sync)> = params.iter().map(|v| v as _).collect();
        let rows = c.query(&st, &refs).map_err(|e| self.error(&e))?;
        let names: Rc<[String]> = st.columns().iter().map(|c| c.name().to_string()).collect();
        rows.iter()
            .map(|r| {
                (0..r.len())
                    .map(|i| column(r, i))
                    .collect::<Result<Vec<_>, _>>()
                    .map(|values| Row {
                        names: Rc::clone(&names),
                        values,
                    })
            })
            .collect::<Result<_, _>>()
            .map_err(|e| self.error(&e))
    }

    /// Runs a statement that returns no rows on `c`: the client, or a
    /// transaction on it.
    fn run_in(
        &self,
        c: &mut impl GenericClient,
        sql: &str,
        params: &[Value],
    ) -> Result<(), CampaignError> {
        let st = self.statement(c, sql)?;
        let refs: Vec<&(dyn ToSql + Sync)> = params.iter().map(|v| v as _).collect();
        c.execute(&st, &refs).map(drop).map_err(|e| self.error(&e))
    }

    /// [`super::Database::write`] on the server: the client's transaction,
    /// rolled back by its guard when `f` or the commit fails.
    pub(crate) fn write<T>(
        &self,
        f: impl FnOnce(&Tx<'_>) -> Result<T, CampaignError>,
    ) -> Result<T, CampaignError> {
        let mut client = self.client.borrow_mut();
        let tx = client.transaction().map_err(|e| self.error(&e))?;
        let tx = PgTx {
            db: self,
            tx: RefCell::new(tx),
        };
        super::sql::in_transaction(Tx::server(&self.path, Box::new(tx)), f)
    }
}

/// A transaction on the server, as [`Tx`] runs statements in it.
struct PgTx<'a> {
    db: &'a PgDb,
    /// In a cell: the client runs a statement through `&mut`.
    tx: RefCell<postgres::Transaction<'a>>,
}

impl ServerTx for PgTx<'_> {
    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError> {
        self.db.rows_in(&mut *self.tx.borrow_mut(), sql, params)
    }

    fn run(&self, sql: &str, params: &[Value]) -> Result<(), CampaignError> {
        self.db.run_in(&mut *self.tx.borrow_mut(), sql, params)
    }

    fn commit(self: Box<Self>) -> Result<(), CampaignError> {
        let PgTx { db, tx } = *self;
        tx.into_inner().commit().map_err(|e| db.error(&e))
    }
}

/// A connection to the server at `url`, the password from the URL or
/// else from the password file; errors name the URL without password.
pub fn connect(url: &str) -> Result<Client, CampaignError> {
    let path = PathBuf::from(server::redact(url));
    let mut secrets = server::secrets_in(url);
    let unusable = |message: String| CampaignError::Unusable {
        path: path.clone(),
        message,
    };
    let mut config: Config = url.parse().map_err(|e: postgres::Error| {
        unusable(format!(
            "not a PostgreSQL URL: {}\n    hint: postgres://USER@HOST:PORT/DATABASE, the password in a password file (PGPASSFILE or ~/.pgpass)",
            server::scrub(&e.to_string(), &secrets)
        ))
    })?;
    if config.get_password().is_none()
        && let Some(pw) = password_from_file(&config).map_err(&unusable)?
    {
        config.password(pw);
    }
    if let Some(pw) = config.get_password() {
        // The password as the client understood it, however it was written.
        let pw = String::from_utf8_lossy(pw).into_owned();
        secrets.push(pw);
    }
    bound(&mut config);
    let failed = |message: String| CampaignError::Postgres {
        url: path.display().to_string(),
        message,
    };
    // The connection is made on a thread of its own, so that a server
    // that takes the connection and never answers, or a stop asked for
    // meanwhile (Ctrl-C, `timeout`'s SIGTERM), cannot hold the command.
    let (tx, rx) = std::sync::mpsc::channel();
    let attempt = config.clone();
    std::thread::spawn(move || {
        let _ = tx.send(attempt.connect(NoTls));
    });
    let started = std::time::Instant::now();
    let client = loop {
        match rx.recv_timeout(std::time::Duration::from_millis(50)) {
            Ok(result) => break result,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(failed(
                    "the connection attempt ended without an answer".to_string(),
                ));
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Err(stop) = ledflicker_core::interrupt::check() {
                    return Err(failed(format!("not connected: {stop}")));
                }
                if started.elapsed() >= CONNECT_TIMEOUT {
                    return Err(failed(format!(
                        "the server did not complete the connection within {} s\n    hint: check the host and port, and that a PostgreSQL server answers there",
                        CONNECT_TIMEOUT.as_secs()
                    )));
                }
            }
        }
    };
    client.map_err(|e| {
        let mut message = chain(&e, &secrets);
        if config.get_password().is_none() && message.contains("password") {
            message.push_str("\n    hint: put the password in a password file (PGPASSFILE, else ~/.pgpass, mode 0600), not on the command line");
        }
        failed(message)
    })
}

/// The longest a connection may take, start-up and authentication
/// included.
pub const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(15);

/// The longest one statement may run on the server (`statement_timeout`;
/// recording a run of 100,000 cases takes seconds), and may wait for a
/// lock (`lock_timeout`).
pub const STATEMENT_TIMEOUT_MS: u64 = 120_000;

/// Bounds on the connection's every wait: the TCP connect, a peer that
/// vanishes (keepalives after 15 s idle; unacknowledged data for 30 s),
/// and each statement and lock on the server. The user's own `options`
/// come first; these are added to them.
fn bound(config: &mut Config) {
    use std::time::Duration;
    config.connect_timeout(Duration::from_secs(10));
    config.keepalives(true);
    config.keepalives_idle(Duration::from_secs(15));
    config.tcp_user_timeout(Duration::from_secs(30));
    let ours = format!(
        "-c statement_timeout={STATEMENT_TIMEOUT_MS} -c lock_timeout={STATEMENT_TIMEOUT_MS}"
    );
    let options = match config.get_options() {
        Some(theirs) if !theirs.is_empty() => format!("{theirs} {ours}"),
        _ => ours,
    };
    config.options(&options);
}

fn has_version_table(c: &mut impl postgres::GenericClient) -> Result<bool, postgres::Error> {
    c.query_one(
        "SELECT to_regclass('schema_version') IS NOT NULL AS present",
        &[],
    )?
    .try_get("present")
}

/// The highest step recorded in `schema_version`; 0 without the table.
fn version_of(c: &mut impl postgres::GenericClient) -> Result<usize, postgres::Error> {
    if !has_version_table(c)? {
        return Ok(0);
    }
    let v: Option<i64> = c
        .query_one("SELECT max(version) AS version FROM schema_version", &[])?
        .try_get("version")?;
    Ok(v.unwrap_or(0).max(0) as usize)
}

/// Column `i` of `r` as a [`Value`].
fn column(r: &postgres::Row, i: usize) -> Result<Value, postgres::Error> {
    let ty = r.columns()[i].type_();
    let int = |v: Option<i64>| v.map_or(Value::Null, Value::Int);
    Ok(match *ty {
        Type::INT8 => int(r.try_get(i)?),
        Type::INT4 => int(r.try_get::<_, Option<i32>>(i)?.map(i64::from)),
        Type::INT2 => int(r.try_get::<_, Option<i16>>(i)?.map(i64::from)),
        Type::BOOL => int(r.try_get::<_, Option<bool>>(i)?.map(i64::from)),
        Type::FLOAT4 => r
            .try_get::<_, Option<f32>>(i)?
            .map_or(Value::Null, |x| Value::Real(f64::from(x))),
        Type::FLOAT8 => r
            .try_get::<_, Option<f64>>(i)?
            .map_or(Value::Null, Value::Real),
        // Any other type reads as text (TEXT, VARCHAR, NAME) or fails
        // naming the column's type.
        _ => r
            .try_get::<_, Option<String>>(i)?
            .map_or(Value::Null, Value::Text),
    })
}

impl ToSql for Value {
    fn to_sql(
        &self,
        ty: &Type,
        out: &mut BytesMut,
    ) -> Result<IsNull, Box<dyn std::error::Error + Sync + Send>> {
        match (self, ty) {
            (Value::Null, _) => Ok(IsNull::Yes),
            (Value::Int(i), &Type::BOOL) => (*i != 0).to_sql(ty, out),
            (Value::Int(i), &Type::INT8) => i.to_sql(ty, out),
            (Value::Int(i), &Type::INT4) => i32::try_from(*i)?.to_sql(ty, out),
            (Value::Int(i), &Type::INT2) => i16::try_from(*i)?.to_sql(ty, out),
            (Value::Int(i), &Type::FLOAT8) => (*i as f64).to_sql(ty, out),
            (Value::Real(x), &Type::FLOAT8) => x.to_sql(ty, out),
            (Value::Text(s), _) if <&str as ToSql>::accepts(ty) => s.as_str().to_sql(ty, out),
            (v, ty) => Err(format!("cannot store {v:?} in a column of type {ty}").into()),
        }
    }

    fn accepts(_: &Type) -> bool {
        // The match above checks each value against the type.
        true
    }

    to_sql_checked!();
}

/// The password for `config` in the password file, if the file exists
/// and has a matching line. As libpq does, a file others may read is not
/// used (with a warning).
fn password_from_file(config: &Config) -> Result<Option<String>, String> {
    let env = |k: &str| std::env::var(k).ok();
    let Some(file) = server::passfile(&env) else {
        return Ok(None);
    };
    let text = match ledflicker_core::util::read_input_to_string(&file) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(format!(
                "cannot read the password file `{}`: {e}",
                file.display()
            ));
        }
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&file).map_or(0, |m| m.permissions().mode());
        if mode & 0o077 != 0 {
            eprintln!(
                "warning: the password file `{}` has group or world access; not used\n    hint: chmod 0600 {}",
                file.display(),
                file.display()
            );
            return Ok(None);
        }
    }
    let user = config
        .get_user()
        .map(str::to_string)
        .or_else(|| env("USER"))
        .unwrap_or_default();
    let database = config.get_dbname().unwrap_or(&user).to_string();
    let port = config.get_ports().first().copied().unwrap_or(5432);
    let (host, socket) = match config.get_hosts().first() {
        Some(postgres::config::Host::Tcp(h)) => (h.clone(), false),
        #[cfg(unix)]
        Some(postgres::config::Host::Unix(p)) => (p.display().to_string(), true),
        None => ("localhost".to_string(), false),
    };
    Ok(server::lookup(
        &text,
        &Target {
            host: &host,
            socket,
            port,
            database: &database,
            user: &user,
        },
    ))
}

/// `e` and its causes, one line, passwords hidden.
fn chain(e: &postgres::Error, secrets: &[String]) -> String {
    let mut parts = vec![e.to_string()];
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        let s_text = s.to_string();
        if !parts.iter().any(|p| p.contains(&s_text)) {
            parts.push(s_text);
        }
        source = s.source();
    }
    server::scrub(&parts.join(": "), secrets)
}
