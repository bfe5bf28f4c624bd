//! A PostgreSQL server named by `--db` or `$LEDFLICKER_DB`: its URL told
//! from a file path, the URL with its password hidden for every message,
//! and the password looked up in a libpq password file, as `psql` does
//! (docs/campaigns.md, "A lab server").

use std::path::{Path, PathBuf};

/// Whether `--db` names a server, not a file: a `postgres://` or
/// `postgresql://` URL, as libpq takes them.
pub fn is_url(db: &str) -> bool {
    db.starts_with("postgres://") || db.starts_with("postgresql://")
}

/// The parts of a server URL as libpq reads them: the scheme with its
/// `://`, the user part (before an `@` met before any `/`; it may hold a
/// `?`), the host and path, and the parameters after the first `?` of
/// the host and path.
fn split(url: &str) -> Option<(&str, Option<&str>, &str, Option<&str>)> {
    let scheme_end = url.find("://")? + 3;
    let rest = &url[scheme_end..];
    let user_end = rest
        .find(['@', '/'])
        .filter(|&i| rest.as_bytes()[i] == b'@');
    let (user, after) = match user_end {
        Some(at) => (Some(&rest[..at]), &rest[at + 1..]),
        None => (None, rest),
    };
    let (host, query) = match after.find('?') {
        Some(q) => (&after[..q], Some(&after[q + 1..])),
        None => (after, None),
    };
    Some((&url[..scheme_end], user, host, query))
}

/// Whether a URL parameter's key, percent-decoded, is `password`.
fn is_password_key(key: &str) -> bool {
    percent_decode(key) == "password"
}

/// `url` with the password, of the user part or of a `password=`
/// parameter (its key percent-encoded or not), replaced by `***`: the only
/// form of the URL a message or a page shows.
pub fn redact(url: &str) -> String {
    let Some((scheme, user, host, query)) = split(url) else {
        return url.to_string();
    };
    let mut out = scheme.to_string();
    if let Some(user) = user {
        match user.split_once(':') {
            Some((name, _)) => {
                out.push_str(name);
                out.push_str(":***");
            }
            None => out.push_str(user),
        }
        out.push('@');
    }
    out.push_str(host);
    if let Some(params) = query {
        let params: Vec<String> = params
            .split('&')
            .map(|p| match p.split_once('=') {
                Some((k, _)) if is_password_key(k) => format!("{k}=***"),
                _ => p.to_string(),
            })
            .collect();
        out.push('?');
        out.push_str(&params.join("&"));
    }
    out
}

/// The password written in `url`, if any, as written and percent-decoded:
/// the strings a message must never show.
pub fn secrets_in(url: &str) -> Vec<String> {
    let mut found = Vec::new();
    let Some((_, user, _, query)) = split(url) else {
        return found;
    };
    if let Some((_, pw)) = user.and_then(|u| u.split_once(':')) {
        found.push(pw.to_string());
    }
    for p in query.unwrap_or("").split('&') {
        if let Some((k, pw)) = p.split_once('=')
            && is_password_key(k)
        {
            found.push(pw.to_string());
        }
    }
    let decoded: Vec<String> = found.iter().map(|s| percent_decode(s)).collect();
    found.extend(decoded);
    found.retain(|s| !s.is_empty());
    found.sort();
    found.dedup();
    found
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
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
