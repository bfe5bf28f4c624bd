//! The SQL the results database runs, written once for both backends:
//! statements use SQLite's numbered placeholders `?1`, `?2`, ..., which
//! [`Database`] rewrites to PostgreSQL's `$1`, `$2`, ...; values go in and
//! come out as [`Value`]s, the four storage classes both servers share.
//!
//! Booleans travel as integers 0 and 1, as SQLite stores them; a
//! PostgreSQL `BOOLEAN` column takes and gives them as `false` and `true`.

use std::path::Path;
use std::rc::Rc;

use rusqlite::TransactionBehavior;

use super::{CampaignError, Database};

/// One SQL value: what a placeholder takes and a column gives.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// SQL NULL.
    Null,
    /// A 64-bit integer (SQLite `INTEGER`, PostgreSQL `BIGINT`, or a
    /// boolean as 0 or 1).
    Int(i64),
    /// A double (SQLite `REAL`, PostgreSQL `DOUBLE PRECISION`).
    Real(f64),
    /// UTF-8 text.
    Text(String),
}

/// What a Rust value is as a [`Value`].
pub trait IntoValue {
    /// The value.
    fn value(&self) -> Value;
}

impl IntoValue for i64 {
    fn value(&self) -> Value {
        Value::Int(*self)
    }
}
impl IntoValue for f64 {
    fn value(&self) -> Value {
        Value::Real(*self)
    }
}
impl IntoValue for bool {
    fn value(&self) -> Value {
        Value::Int(i64::from(*self))
    }
}
impl IntoValue for str {
    fn value(&self) -> Value {
        Value::Text(self.to_string())
    }
}
impl IntoValue for String {
    fn value(&self) -> Value {
        Value::Text(self.clone())
    }
}
impl<T: IntoValue> IntoValue for Option<T> {
    fn value(&self) -> Value {
        self.as_ref().map_or(Value::Null, IntoValue::value)
    }
}
impl<T: IntoValue + ?Sized> IntoValue for &T {
    fn value(&self) -> Value {
        (**self).value()
    }
}

/// The statement's parameters as [`Value`]s, in placeholder order.
macro_rules! values {
    ($($v:expr),* $(,)?) => {
        [$($crate::campaign::sql::IntoValue::value(&$v)),*]
    };
}
pub(crate) use values;

/// A column held something its reader did not expect (a file edited by
/// hand, or a server table of another shape).
#[derive(Debug)]
pub struct Mismatch(String);

/// A Rust value read from a [`Value`].
pub trait FromValue: Sized {
    /// `None`: `v` is not of this type.
    fn from_value(v: &Value) -> Option<Self>;
}

impl FromValue for i64 {
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Int(i) => Some(*i),
            _ => None,
        }
    }
}
impl FromValue for f64 {
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Real(x) => Some(*x),
            // SQLite may hand back a whole REAL as an integer.
            Value::Int(i) => Some(*i as f64),
            _ => None,
        }
    }
}
impl FromValue for bool {
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Int(i) => Some(*i != 0),
            _ => None,
        }
    }
}
impl FromValue for String {
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Text(s) => Some(s.clone()),
            _ => None,
        }
    }
}
impl<T: FromValue> FromValue for Option<T> {
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Null => Some(None),
            v => T::from_value(v).map(Some),
        }
    }
}

/// One result row: its values by column name.
#[derive(Debug)]
pub struct Row {
    /// The statement's column names, shared by its rows.
    pub(crate) names: Rc<[String]>,
    /// The values, in the order of `names`.
    pub(crate) values: Vec<Value>,
}

impl Row {
    /// Column `name` as a `T`. A name the statement does not give, or
    /// gives twice (an unaliased join), is an error: a reordered or
    /// widened SELECT cannot hand a field another column's value.
    pub fn get<T: FromValue>(&self, name: &str) -> Result<T, Mismatch> {
        let mut at = (self.names.iter().enumerate())
            .filter(|(_, n)| n.as_str() == name)
            .map(|(i, _)| i);
        let v = match (at.next(), at.next()) {
            (Some(i), None) => self.values.get(i).unwrap_or(&Value::Null),
            (None, _) => return Err(Mismatch(format!("no column `{name}`"))),
            (Some(_), Some(_)) => {
                return Err(Mismatch(format!("two columns are named `{name}`")));
            }
        };
        T::from_value(v).ok_or_else(|| {
            Mismatch(format!(
                "column `{name}` holds {v:?}, not a {}",
                std::any::type_name::<T>()
            ))
        })
    }
}

/// `sql` with SQLite's `?N` placeholders as PostgreSQL's `$N`. The
/// statements hold no `?` in a string literal.
#[cfg_attr(not(feature = "postgres"), allow(dead_code))]
pub(crate) fn dollar_placeholders(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len());
    let mut chars = sql.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '?' && chars.peek().is_some_and(char::is_ascii_digit) {
            out.push('$');
        } else {
            out.push(c);
        }
    }
    out
}

/// Where statements that return rows run: the database, or a write
/// transaction on it. Each says how it gets the rows; reading them into
/// values, and the one-row case, are written once here.
pub(crate) trait Query {
    /// The file, or the server's URL with its password hidden, as
    /// messages name it.
    fn location(&self) -> &Path;

    /// The rows `sql` gives.
    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError>;

    /// Runs `sql` and reads each row with `read`.
    fn query_map<T>(
        &self,
        sql: &str,
        params: &[Value],
        read: impl FnMut(&Row) -> Result<T, Mismatch>,
    ) -> Result<Vec<T>, CampaignError> {
        let rows = self.rows(sql, params)?;
        read_rows(self.location(), sql, &rows, read)
    }

    /// The one row `sql` gives, read with `read`; `None` when it gives none.
    fn query_row<T>(
        &self,
        sql: &str,
        params: &[Value],
        read: impl FnMut(&Row) -> Result<T, Mismatch>,
    ) -> Result<Option<T>, CampaignError> {
        Ok(self.query_map(sql, params, read)?.into_iter().next())
    }
}

impl Query for Database {
    fn location(&self) -> &Path {
        self.path()
    }

    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError> {
        match self {
            Database::Sqlite(db) => sqlite_rows(&db.conn, &db.path, sql, params),
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => db.rows(sql, params),
        }
    }
}

impl Query for Tx<'_> {
    fn location(&self) -> &Path {
        self.path
    }

    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError> {
        match &self.guard {
            Guard::Sqlite(tx) => sqlite_rows(tx, self.path, sql, params),
            #[cfg(feature = "postgres")]
            Guard::Server(tx) => tx.rows(sql, params),
        }
    }
}

impl Database {
    /// Runs `f` in one write transaction: all its statements are
    /// committed, or (on an error, a panic, or a process killed
    /// meanwhile) none.
    pub(crate) fn write<T>(
        &mut self,
        f: impl FnOnce(&Tx<'_>) -> Result<T, CampaignError>,
    ) -> Result<T, CampaignError> {
        match self {
            Database::Sqlite(db) => db.write(f),
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => db.write(f),
        }
    }
}

/// An open write transaction ([`Database::write`]): the crate's own guard,
/// which rolls back what was written when it is dropped uncommitted.
pub(crate) struct Tx<'a> {
    /// How messages name the database.
    path: &'a Path,
    guard: Guard<'a>,
}

enum Guard<'a> {
    Sqlite(rusqlite::Transaction<'a>),
    #[cfg(feature = "postgres")]
    Server(Box<dyn ServerTx + 'a>),
}

/// A transaction on a server (pg.rs), as [`Tx`] runs statements
/// in it; dropped uncommitted, it rolls back.
#[cfg(feature = "postgres")]
pub(crate) trait ServerTx {
    /// The rows `sql` gives.
    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError>;
    /// Runs a statement that returns no rows.
    fn run(&self, sql: &str, params: &[Value]) -> Result<(), CampaignError>;
    /// Commits.
    fn commit(self: Box<Self>) -> Result<(), CampaignError>;
}

impl<'a> Tx<'a> {
    /// The transaction `tx` on the server named `path` (password hidden).
    #[cfg(feature = "postgres")]
    pub(crate) fn server(path: &'a Path, tx: Box<dyn ServerTx + 'a>) -> Tx<'a> {
        Tx {
            path,
            guard: Guard::Server(tx),
        }
    }

    /// The file, or the server's URL with its password hidden.
    pub(crate) fn path(&self) -> &Path {
        self.path
    }

    /// Runs a statement that returns no rows, in the transaction.
    pub(crate) fn execute(&self, sql: &str, params: &[Value]) -> Result<(), CampaignError> {
        match &self.guard {
            Guard::Sqlite(tx) => sqlite_run(tx, self.path, sql, params),
            #[cfg(feature = "postgres")]
            Guard::Server(tx) => tx.run(sql, params),
        }
    }

    /// Commits; on an error here the guard is dropped and rolls back.
    fn commit(self) -> Result<(), CampaignError> {
        match self.guard {
            Guard::Sqlite(tx) => tx.commit().map_err(super::sqlite(self.path)),
            #[cfg(feature = "postgres")]
            Guard::Server(tx) => tx.commit(),
        }
    }
}

/// Runs `f` in the transaction `tx`, committed when `f` succeeds and
/// rolled back (by the guard's drop) when `f` or the commit fails.
pub(crate) fn in_transaction<T>(
    tx: Tx<'_>,
    f: impl FnOnce(&Tx<'_>) -> Result<T, CampaignError>,
) -> Result<T, CampaignError> {
    let v = f(&tx)?;
    tx.commit()?;
    Ok(v)
}

/// `rows`, each read with `read`; a value its reader did not expect is an
/// error naming the statement.
fn read_rows<T>(
    path: &Path,
    sql: &str,
    rows: &[Row],
    read: impl FnMut(&Row) -> Result<T, Mismatch>,
) -> Result<Vec<T>, CampaignError> {
    rows.iter()
        .map(read)
        .collect::<Result<_, _>>()
        .map_err(|Mismatch(m)| CampaignError::Unusable {
            path: path.to_path_buf(),
            message: format!("{m}, in `{sql}`"),
        })
}

impl super::Db {
    /// [`Database::write`] on the file: `BEGIN IMMEDIATE` takes the write
    /// lock at once, so that two writers wait for each other (busy
    /// timeout) instead of one failing at commit.
    fn write<T>(
        &mut self,
        f: impl FnOnce(&Tx<'_>) -> Result<T, CampaignError>,
    ) -> Result<T, CampaignError> {
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(super::sqlite(&self.path))?;
        let tx = Tx {
            path: &self.path,
            guard: Guard::Sqlite(tx),
        };
        in_transaction(tx, f)
    }
}

/// The rows `sql` gives on an SQLite connection (or a transaction on it).
fn sqlite_rows(
    conn: &rusqlite::Connection,
    path: &Path,
    sql: &str,
    params: &[Value],
) -> Result<Vec<Row>, CampaignError> {
    let err = super::sqlite(path);
    let mut st = conn.prepare_cached(sql).map_err(&err)?;
    let names: Rc<[String]> = st.column_names().map(String::from).collect();
    let mut rows = st
        .query(rusqlite::params_from_iter(params.iter()))
        .map_err(&err)?;
    let mut out = Vec::new();
    while let Some(r) = rows.next().map_err(&err)? {
        let values = (0..names.len())
            .map(|i| r.get_ref(i).map(Value::from))
            .collect::<Result<_, _>>()
            .map_err(&err)?;
        out.push(Row {
            names: Rc::clone(&names),
            values,
        });
    }
    Ok(out)
}

/// Runs a statement that returns no rows on an SQLite connection.
fn sqlite_run(
    conn: &rusqlite::Connection,
    path: &Path,
    sql: &str,
    params: &[Value],
) -> Result<(), CampaignError> {
    conn.prepare_cached(sql)
        .and_then(|mut st| st.execute(rusqlite::params_from_iter(params.iter())))
        .map(drop)
        .map_err(super::sqlite(path))
}

impl rusqlite::ToSql for Value {
    fn to_sql(&self) -> rusqlite::Result<rusqlite::types::ToSqlOutput<'_>> {
        use rusqlite::types::{ToSqlOutput, ValueRef};
        Ok(ToSqlOutput::Borrowed(match self {
            Value::Null => ValueRef::Null,
            Value::Int(i) => ValueRef::Integer(*i),
            Value::Real(x) => ValueRef::Real(*x),
            Value::Text(s) => ValueRef::Text(s.as_bytes()),
        }))
    }
}

impl From<rusqlite::types::ValueRef<'_>> for Value {
    fn from(v: rusqlite::types::ValueRef<'_>) -> Value {
        use rusqlite::types::ValueRef;
        match v {
            ValueRef::Null => Value::Null,
            ValueRef::Integer(i) => Value::Int(i),
            ValueRef::Real(x) => Value::Real(x),
            // The schema has no BLOB column; a blob where text belongs is
            // read as text, so a reader names the column.
            ValueRef::Text(t) | ValueRef::Blob(t) => {
                Value::Text(String::from_utf8_lossy(t).into_owned())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_placeholders_become_dollar_placeholders() {
        assert_eq!(
            dollar_placeholders("SELECT a FROM t WHERE b = ?1 AND c != ?12 ORDER BY a"),
            "SELECT a FROM t WHERE b = $1 AND c != $12 ORDER BY a"
        );
        // A `?` not followed by a digit is not a placeholder.
        assert_eq!(dollar_placeholders("a ? b"), "a ? b");
    }

    #[test]
    fn values_read_back_as_their_rust_types_and_nulls_as_none() {
        let row = Row {
            names: ["n", "x", "ok", "s", "none"].map(String::from).into(),
            values: values![3_i64, 0.5_f64, true, "x", None::<f64>].to_vec(),
        };
        assert_eq!(row.get::<i64>("n").unwrap(), 3);
        assert_eq!(row.get::<f64>("x").unwrap(), 0.5);
        assert!(row.get::<bool>("ok").unwrap());
        assert_eq!(row.get::<String>("s").unwrap(), "x");
        assert_eq!(row.get::<Option<f64>>("none").unwrap(), None);
        assert_eq!(row.get::<Option<i64>>("n").unwrap(), Some(3));
        let e = row.get::<i64>("s").unwrap_err().0;
        assert!(e.contains("column `s`"), "{e}");
    }

    #[test]
    fn a_column_not_given_or_given_twice_is_refused_not_guessed() {
        let row = Row {
            names: ["id", "id"].map(String::from).into(),
            values: values![1_i64, 2_i64].to_vec(),
        };
        let e = row.get::<i64>("id").unwrap_err().0;
        assert!(e.contains("two columns"), "{e}");
        let e = row.get::<i64>("run").unwrap_err().0;
        assert!(e.contains("no column `run`"), "{e}");
    }
}
