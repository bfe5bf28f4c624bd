//! The SQL the results database runs, written once for both backends:
//! statements use SQLite's numbered placeholders `?1`, `?2`, ..., which
//! [`Database`] rewrites to PostgreSQL's `$1`, `$2`, ...; values go in and
//! come out as [`Value`]s, the four storage classes both servers share.
//!
//! Booleans travel as integers 0 and 1, as SQLite stores them; a
//! PostgreSQL `BOOLEAN` column takes and gives them as `false` and `true`.

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

/// One result row.
#[derive(Debug)]
pub struct Row(pub(crate) Vec<Value>);

impl Row {
    /// Column `i` as a `T`.
    pub fn get<T: FromValue>(&self, i: usize) -> Result<T, Mismatch> {
        let v = self.0.get(i).unwrap_or(&Value::Null);
        T::from_value(v).ok_or_else(|| {
            Mismatch(format!(
                "column {i} holds {v:?}, not a {}",
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

impl Database {
    /// Runs `sql` and reads each row with `read`.
    pub(crate) fn query_map<T>(
        &self,
        sql: &str,
        params: &[Value],
        read: impl FnMut(&Row) -> Result<T, Mismatch>,
    ) -> Result<Vec<T>, CampaignError> {
        let rows = match self {
            Database::Sqlite(db) => db.rows(sql, params)?,
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => db.rows(sql, params)?,
        };
        rows.iter()
            .map(read)
            .collect::<Result<_, _>>()
            .map_err(|Mismatch(m)| CampaignError::Unusable {
                path: self.path().to_path_buf(),
                message: format!("{m}, in `{sql}`"),
            })
    }

    /// The one row `sql` gives, read with `read`; `None` when it gives none.
    pub(crate) fn query_row<T>(
        &self,
        sql: &str,
        params: &[Value],
        read: impl FnMut(&Row) -> Result<T, Mismatch>,
    ) -> Result<Option<T>, CampaignError> {
        Ok(self.query_map(sql, params, read)?.into_iter().next())
    }

    /// Runs a statement that returns no rows.
    pub(crate) fn execute(&self, sql: &str, params: &[Value]) -> Result<(), CampaignError> {
        match self {
            Database::Sqlite(db) => db.run(sql, params),
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => db.run(sql, params),
        }
    }

    /// Runs `f` in one write transaction: all its statements are
    /// committed, or (on an error, or a process killed meanwhile) none.
    pub(crate) fn write<T>(
        &mut self,
        f: impl FnOnce(&Database) -> Result<T, CampaignError>,
    ) -> Result<T, CampaignError> {
        // SQLite: IMMEDIATE takes the write lock now, so two writers wait
        // for each other (busy timeout) instead of failing at commit.
        let (begin, commit, rollback) = match self {
            Database::Sqlite(_) => ("BEGIN IMMEDIATE", "COMMIT", "ROLLBACK"),
            #[cfg(feature = "postgres")]
            Database::Postgres(_) => ("BEGIN", "COMMIT", "ROLLBACK"),
        };
        self.batch(begin)?;
        match f(self) {
            Ok(v) => match self.batch(commit) {
                Ok(()) => Ok(v),
                Err(e) => {
                    let _ = self.batch(rollback);
                    Err(e)
                }
            },
            Err(e) => {
                let _ = self.batch(rollback);
                Err(e)
            }
        }
    }

    fn batch(&self, sql: &str) -> Result<(), CampaignError> {
        match self {
            Database::Sqlite(db) => db.conn.execute_batch(sql).map_err(super::sqlite(&db.path)),
            #[cfg(feature = "postgres")]
            Database::Postgres(db) => db.batch(sql),
        }
    }
}

impl super::Db {
    fn rows(&self, sql: &str, params: &[Value]) -> Result<Vec<Row>, CampaignError> {
        let err = super::sqlite(&self.path);
        let mut st = self.conn.prepare_cached(sql).map_err(&err)?;
        let n = st.column_count();
        let mut rows = st
            .query(rusqlite::params_from_iter(params.iter()))
            .map_err(&err)?;
        let mut out = Vec::new();
        while let Some(r) = rows.next().map_err(&err)? {
            let row = (0..n)
                .map(|i| r.get_ref(i).map(Value::from))
                .collect::<Result<_, _>>()
                .map_err(&err)?;
            out.push(Row(row));
        }
        Ok(out)
    }

    fn run(&self, sql: &str, params: &[Value]) -> Result<(), CampaignError> {
        let err = super::sqlite(&self.path);
        self.conn
            .prepare_cached(sql)
            .and_then(|mut st| st.execute(rusqlite::params_from_iter(params.iter())))
            .map(drop)
            .map_err(err)
    }
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
        let row = Row(values![3_i64, 0.5_f64, true, "x", None::<f64>].to_vec());
        assert_eq!(row.get::<i64>(0).unwrap(), 3);
        assert_eq!(row.get::<f64>(1).unwrap(), 0.5);
        assert!(row.get::<bool>(2).unwrap());
        assert_eq!(row.get::<String>(3).unwrap(), "x");
        assert_eq!(row.get::<Option<f64>>(4).unwrap(), None);
        assert_eq!(row.get::<Option<i64>>(0).unwrap(), Some(3));
        let e = row.get::<i64>(3).unwrap_err().0;
        assert!(e.contains("column 3"), "{e}");
    }
}
