//! A PostgreSQL server named by `--db` or `$LEDFLICKER_DB`: its URL told
//! from a file path, the URL with its password hidden for every message,
//! and the password looked up in a libpq password file, as `psql` does
//! (docs/campaigns.md, "A lab server").

use std::path::{Path, PathBuf};

use percent_encoding::{AsciiSet, CONTROLS, percent_decode_str, utf8_percent_encode};
use url::Url;

/// Whether `--db` names a server, not a file: a `postgres://` or
/// `postgresql://` URL, as libpq takes them.
pub fn is_url(db: &str) -> bool {
    db.starts_with("postgres://") || db.starts_with("postgresql://")
}

/// What is escaped in a user part before the `url` crate parses it: the
/// characters that end a URL's authority (RFC 3986) before its `@`.
const IN_USER_PART: &AsciiSet = &CONTROLS.add(b'?').add(b'#');
/// What is escaped in the rest of the URL: a `#` starts no fragment in a
/// libpq URL, so a parameter's value may hold one.
const IN_REST: &AsciiSet = &CONTROLS.add(b'#');

/// The user part of a server URL (`user:password`, as written), read as
/// libpq and the postgres client read it: up to the first `@` met before
/// any `/`, so that a password may hold a `?` or a `#`.
fn user_part(url: &str) -> Option<&str> {
    let (_, rest) = url.split_once("://")?;
    rest.find(['@', '/'])
        .filter(|&i| rest.as_bytes()[i] == b'@')
        .map(|at| &rest[..at])
}

/// A server URL as the `url` crate parses it, read as libpq reads it: its
/// user part as [`user_part`] reads it (the crate would end it at a `?`
/// or a `#`), and a `#` a character like any other; these are escaped
/// first. `None`: not a URL the crate parses (a libpq list of several
/// hosts with ports).
fn parse(url: &str) -> Option<Url> {
    let (scheme, rest) = url.split_once("://")?;
    let user = user_part(url).unwrap_or("");
    let escaped = format!(
        "{scheme}://{}{}",
        utf8_percent_encode(user, IN_USER_PART),
        utf8_percent_encode(&rest[user.len()..], IN_REST)
    );
    Url::parse(&escaped).ok()
}

/// Whether a URL parameter's key, percent-decoded, is `password`.
fn is_password_key(key: &str) -> bool {
    percent_decode_str(key).decode_utf8_lossy() == "password"
}

/// The URL's parameters as written, each `(key, value)` (`value` `None`
/// without `=`).
fn params(url: &Url) -> impl Iterator<Item = (&str, Option<&str>)> {
    url.query()
        .into_iter()
        .flat_map(|q| q.split('&'))
        .map(|p| match p.split_once('=') {
            Some((k, v)) => (k, Some(v)),
            None => (p, None),
        })
}

/// `url` with the password, of the user part or of a `password=`
/// parameter (its key percent-encoded or not), replaced by `***`: the only
/// form of the URL a message or a page shows. A URL that cannot be parsed
/// shows its scheme alone.
pub fn redact(url: &str) -> String {
    let Some(mut parsed) = parse(url) else {
        let scheme = url.split_once("://").map_or("", |(s, _)| s);
        return format!("{scheme}://***");
    };
    if parsed.password().is_some() {
        // Cannot fail: the URL has a host, or it would have no password.
        let _ = parsed.set_password(Some("***"));
    }
    if parsed.query().is_some() {
        let query: Vec<String> = params(&parsed)
            .map(|(k, v)| match v {
                Some(_) if is_password_key(k) => format!("{k}=***"),
                Some(v) => format!("{k}={v}"),
                None => k.to_string(),
            })
            .collect();
        parsed.set_query(Some(&query.join("&")));
    }
    parsed.into()
}

/// The password written in `url`, if any, as written and percent-decoded:
/// the strings a message must never show.
pub fn secrets_in(url: &str) -> Vec<String> {
    let mut found = Vec::new();
    if let Some((_, pw)) = user_part(url).and_then(|u| u.split_once(':')) {
        found.push(pw.to_string());
    }
    if let Some(parsed) = parse(url) {
        found.extend(
            params(&parsed)
                .filter(|(k, _)| is_password_key(k))
                .filter_map(|(_, v)| v.map(str::to_string)),
        );
    }
    let decoded: Vec<String> = found
        .iter()
        .map(|s| percent_decode_str(s).decode_utf8_lossy().into_owned())
        .collect();
    found.extend(decoded);
    found.retain(|s| !s.is_empty());
    found.sort();
    found.dedup();
    found
}

/// `text` with every secret replaced by `***`.
pub fn scrub(text: &str, secrets: &[String]) -> String {
    secrets
        .iter()
        .fold(text.to_string(), |t, s| t.replace(s.as_str(), "***"))
}

/// The password file libpq reads: `$PGPASSFILE`, else `~/.pgpass`.
pub fn passfile(env: &dyn Fn(&str) -> Option<String>) -> Option<PathBuf> {
    env("PGPASSFILE")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
        .or_else(|| env("HOME").map(|h| Path::new(&h).join(".pgpass")))
}

/// The connection a password is looked up for.
#[derive(Debug, Clone)]
pub struct Target<'a> {
    /// Host name or address; a Unix socket's directory.
    pub host: &'a str,
    /// Whether `host` is a Unix socket's directory.
    pub socket: bool,
    /// Port.
    pub port: u16,
    /// Database name.
    pub database: &'a str,
    /// User name.
    pub user: &'a str,
}

/// The password of the first line of a password file (`text`) that
/// matches `t`: `hostname:port:database:username:password`, `*` matching
/// anything, `\:` and `\\` escaping, `#` starting a comment line. As in
/// libpq, a Unix socket connection matches the host name `localhost`
/// (and here its directory too).
pub fn lookup(text: &str, t: &Target<'_>) -> Option<String> {
    let port = t.port.to_string();
    text.lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .find_map(|line| {
            let f = fields(line);
            if f.len() != 5 {
                return None;
            }
            let is = |field: &str, value: &str| field == "*" || field == value;
            let host = is(&f[0], t.host) || (t.socket && f[0] == "localhost");
            (host && is(&f[1], &port) && is(&f[2], t.database) && is(&f[3], t.user))
                .then(|| f[4].clone())
        })
}

/// A password file line's fields, split at unescaped colons.
fn fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => {
                if let (Some(n), Some(f)) = (chars.next(), out.last_mut()) {
                    f.push(n);
                }
            }
            // The password, the last field, may hold colons unescaped.
            ':' if out.len() < 5 => out.push(String::new()),
            c => {
                if let Some(f) = out.last_mut() {
                    f.push(c)
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_name_servers_and_anything_else_a_file() {
        assert!(is_url("postgres://lab@db/ledflicker"));
        assert!(is_url("postgresql://lab@db/ledflicker"));
        assert!(!is_url("results.sqlite"));
        assert!(!is_url("/data/postgres/results.sqlite"));
    }

    #[test]
    fn the_password_of_the_user_part_and_of_the_parameters_is_hidden() {
        assert_eq!(
            redact("postgres://lab:s3cr%40t@db.example:5433/ledflicker"),
            "postgres://lab:***@db.example:5433/ledflicker"
        );
        assert_eq!(
            redact("postgresql://lab@db/x?password=hunter2&sslmode=disable"),
            "postgresql://lab@db/x?password=***&sslmode=disable"
        );
        assert_eq!(redact("postgres://db/x"), "postgres://db/x");
        // A `?` in the password, and the key percent-encoded: both are
        // passwords to the client, and hidden.
        let url = "postgres://lab:pa?ss@db:5432/x";
        assert_eq!(redact(url), "postgres://lab:***@db:5432/x");
        assert_eq!(secrets_in(url), ["pa?ss"]);
        let url = "postgres://lab@db/x?pass%77ord=hun%3Fter&sslmode=disable";
        assert_eq!(
            redact(url),
            "postgres://lab@db/x?pass%77ord=***&sslmode=disable"
        );
        assert_eq!(secrets_in(url), ["hun%3Fter", "hun?ter"]);
        let url = "postgres://lab:a#b@db/x";
        assert_eq!(redact(url), "postgres://lab:***@db/x");
        assert_eq!(secrets_in(url), ["a#b"]);
        // Nor does a `#` end a parameter's value.
        let url = "postgres://db/x?password=a#b&sslmode=disable";
        assert_eq!(redact(url), "postgres://db/x?password=***&sslmode=disable");
        assert_eq!(secrets_in(url), ["a#b", "a%23b"]);
        // A libpq list of hosts with ports is no URL the url crate parses:
        // it shows its scheme alone, and its password is still known.
        let url = "postgres://lab:pw@h1:5432,h2:5433/x?password=p2";
        assert_eq!(redact(url), "postgres://***");
        assert_eq!(secrets_in(url), ["pw"]);
        // An `@` in a parameter is not a user part.
        assert_eq!(
            redact("postgres://db/x?application_name=a@b&password=p"),
            "postgres://db/x?application_name=a@b&password=***"
        );
        assert_eq!(
            secrets_in("postgres://lab:s3cr%40t@db/x?password=p2"),
            ["p2", "s3cr%40t", "s3cr@t"]
        );
        assert_eq!(
            scrub(
                "auth failed for s3cr@t",
                &secrets_in("postgres://u:s3cr%40t@h/d")
            ),
            "auth failed for ***"
        );
    }

    #[test]
    fn the_password_file_gives_the_first_matching_line() {
        let file = "# lab server\n\
                    db.example:5432:other:lab:wrong\n\
                    db.example:5432:ledflicker:lab:right\n\
                    *:*:*:lab:any\n\
                    localhost:*:*:ci:with\\:colon:and:more\n";
        let t = Target {
            host: "db.example",
            socket: false,
            port: 5432,
            database: "ledflicker",
            user: "lab",
        };
        assert_eq!(lookup(file, &t).as_deref(), Some("right"));
        let t2 = Target {
            port: 6000,
            ..t.clone()
        };
        assert_eq!(lookup(file, &t2).as_deref(), Some("any"));
        let sock = Target {
            host: "/tmp/pg",
            socket: true,
            user: "ci",
            ..t.clone()
        };
        assert_eq!(lookup(file, &sock).as_deref(), Some("with:colon:and:more"));
        let none = Target {
            user: "nobody",
            ..t
        };
        assert_eq!(lookup(file, &none), None);
    }

    #[test]
    fn the_password_file_is_pgpassfile_else_pgpass_at_home() {
        let env = |k: &str| match k {
            "PGPASSFILE" => Some("/etc/lab.pgpass".to_string()),
            "HOME" => Some("/home/u".to_string()),
            _ => None,
        };
        assert_eq!(passfile(&env), Some(PathBuf::from("/etc/lab.pgpass")));
        let home = |k: &str| (k == "HOME").then(|| "/home/u".to_string());
        assert_eq!(passfile(&home), Some(PathBuf::from("/home/u/.pgpass")));
    }
}
