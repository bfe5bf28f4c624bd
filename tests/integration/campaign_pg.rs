//! The results database on a real PostgreSQL server: the campaign of
//! tests/integration/campaign.rs recorded into the server, read back
//! the same as from SQLite, migrations under the lock, concurrent
//! writers, and the password kept out of messages (docs/campaigns.md,
//! "A lab server").
//!
//! The server comes from `scripts/pg-test-server.sh`, which sets
//! `LEDFLICKER_TEST_PG` (an administrator's URL, password in
//! `PGPASSFILE`); scripts/test.sh runs the suite under it. Each test
//! makes a database of its own there. Under `CI=true` a missing server is
//! a failure, never a skip.
#![cfg(feature = "postgres")]

use std::path::Path;
use std::process::Output;

use super::campaign::{plan, small_plan};
use crate::{ledflicker_in, scratch, stderr, text};

/// The server's URL, or `None` (with a note) outside CI when there is
/// none.
fn server() -> Option<String> {
    match std::env::var("LEDFLICKER_TEST_PG") {
        Ok(url) if !url.is_empty() => Some(url),
        _ if std::env::var("CI").is_ok_and(|v| v == "true") => panic!(
            "LEDFLICKER_TEST_PG is not set, and CI=true: the PostgreSQL tests must run\n    hint: run the tests under scripts/pg-test-server.sh (scripts/test.sh does)"
        ),
        _ => {
            eprintln!(
                "note: PostgreSQL test NOT RUN: LEDFLICKER_TEST_PG is unset; run `scripts/pg-test-server.sh cargo test --test integration campaign_pg`"
            );
            None
        }
    }
}

/// A new, empty database `name` on the server; its URL.
fn fresh_database(admin: &str, name: &str) -> String {
    let name = format!("lf_{name}_{}", std::process::id());
    let mut c = ledflicker::campaign::pg::connect(admin).unwrap();
    c.batch_execute(&format!("DROP DATABASE IF EXISTS {name}"))
        .unwrap();
    c.batch_execute(&format!("CREATE DATABASE {name}")).unwrap();
    let (base, _) = admin.rsplit_once('/').unwrap();
    format!("{base}/{name}")
}

fn run(dir: &Path, args: &[&str]) -> Output {
    ledflicker_in(args, dir)
}

fn ok(o: Output, code: i32) -> String {
    assert_eq!(o.status.code(), Some(code), "{}", text(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn history(dir: &Path, db: &str) -> Vec<serde_json::Value> {
    let out = ok(run(dir, &["history", "--db", db, "--json"]), 0);
    let mut runs: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    // When and by which command each was recorded differ between the two
    // databases; everything else is the same.
    for r in &mut runs {
        r.as_object_mut().unwrap().remove("recorded_unix_s");
        r.as_object_mut().unwrap().remove("source");
    }
    runs
}

#[test]
fn a_campaign_on_postgres_reads_back_as_on_sqlite_and_the_regression_exits_1() {
    let Some(admin) = server() else { return };
    let url = fresh_database(&admin, "campaign");
    let dir = scratch("campaign-pg");
    let v10 = small_plan(&dir, "v10", "1.0", "11.111");
    let v11 = small_plan(&dir, "v11", "1.1", "1.0");
    // Recorded into the server by `plan`, and into a file by `import`.
    assert_eq!(
        plan(&dir, &v10, "a", &["--db", &url]).status.code(),
        Some(0)
    );
    assert_eq!(
        plan(&dir, &v11, "b", &["--db", &url]).status.code(),
        Some(1)
    );
    ok(run(&dir, &["import", "a", "b", "--db", "c.sqlite"]), 0);

    let runs = history(&dir, &url);
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["firmware"], "1.0");
    assert_eq!(runs[1]["firmware"], "1.1");
    assert_eq!(runs[1]["verdict"], "fail");
    assert_eq!(runs, history(&dir, "c.sqlite"));
    let filtered = ok(
        run(
            &dir,
            &["history", "--db", &url, "--firmware", "1.1", "--json"],
        ),
        0,
    );
    let filtered: Vec<serde_json::Value> = serde_json::from_str(&filtered).unwrap();
    assert_eq!(filtered.len(), 1);
    assert_eq!(filtered[0]["id"], 2);

    let on_pg = ok(
        run(
            &dir,
            &["compare", "a", "b", "--db", &url, "--junit", "pg.xml"],
        ),
        1,
    );
    assert!(
        on_pg.contains("REGRESSION in 2 case(s): 2000lux-150hz-20pct, 2000lux-150hz-50pct"),
        "{on_pg}"
    );
    let on_file = ok(
        run(
            &dir,
            &[
                "compare", "a", "b", "--db", "c.sqlite", "--junit", "file.xml",
            ],
        ),
        1,
    );
    assert_eq!(on_pg, on_file);
    assert_eq!(
        std::fs::read(dir.join("pg.xml")).unwrap(),
        std::fs::read(dir.join("file.xml")).unwrap()
    );
    ok(run(&dir, &["compare", "b", "a", "--db", &url]), 0);
    let o = run(&dir, &["compare", "1", "9", "--db", &url]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no run 9"), "{}", stderr(&o));

    let trend = |db: &str| {
        ok(
            run(
                &dir,
                &[
                    "trend",
                    "--kpi",
                    "fdi_2018_worst_phase",
                    "--json",
                    "--db",
                    db,
                ],
            ),
            0,
        )
    };
    let points: Vec<serde_json::Value> = serde_json::from_str(&trend(&url)).unwrap();
    assert_eq!(points.len(), 2 * 4, "two runs of 4 cases, one ROI");
    assert_eq!(trend(&url), trend("c.sqlite"));
}

#[test]
fn processes_recording_into_postgres_at_once_lose_nothing() {
    let Some(admin) = server() else { return };
    let url = fresh_database(&admin, "concurrent");
    let dir = scratch("campaign-pg-concurrent");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    // Six clients start together on an empty database: one migrates, the
    // others wait for its lock, then all record.
    let children: Vec<_> = (0..6)
        .map(|_| {
            std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
                .env("LEDFLICKER_DB", &url)
                .args(["import", "r", "r", "r"])
                .current_dir(&dir)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let mut c = ledflicker::campaign::pg::connect(&url).unwrap();
    let count =
        |c: &mut postgres::Client, sql: &str| -> i64 { c.query_one(sql, &[]).unwrap().get(0) };
    assert_eq!(count(&mut c, "SELECT count(*) FROM runs"), 18);
    assert_eq!(count(&mut c, "SELECT count(*) FROM cases"), 18 * 4);
    assert_eq!(
        count(&mut c, "SELECT count(*) FROM schema_version"),
        ledflicker::campaign::pg::MIGRATIONS.len() as i64
    );
    let ids: Vec<i64> = history(&dir, &url)
        .iter()
        .map(|r| r["id"].as_i64().unwrap())
        .collect();
    assert_eq!(ids, (1..=18).collect::<Vec<_>>());
}

/// The next schema step, in PostgreSQL's dialect, for the framework's
/// test (as the SQLite test's `NEXT`).
const NEXT: &str = "ALTER TABLE runs ADD COLUMN camera_label TEXT; \
                    UPDATE runs SET camera_label = model || ' ' || firmware;";

#[test]
fn a_postgres_database_of_the_previous_version_is_migrated_once_under_the_lock() {
    use ledflicker::campaign::pg::{MIGRATIONS, PgDb};
    let Some(admin) = server() else { return };
    let url = fresh_database(&admin, "migrate");
    let dir = scratch("campaign-pg-migrate");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--db", &url]).status.code(), Some(0));
    assert_eq!(
        PgDb::open(&url, MIGRATIONS).unwrap().version().unwrap(),
        MIGRATIONS.len()
    );
    // Four clients of the next version open it at once.
    let steps: Vec<&str> = MIGRATIONS.iter().copied().chain([NEXT]).collect();
    std::thread::scope(|s| {
        let opened: Vec<_> = (0..4)
            .map(|_| s.spawn(|| PgDb::open(&url, &steps).map(|db| db.version().unwrap())))
            .collect();
        for o in opened {
            assert_eq!(o.join().unwrap().unwrap(), MIGRATIONS.len() + 1);
        }
    });
    let mut c = ledflicker::campaign::pg::connect(&url).unwrap();
    let versions: Vec<i64> = c
        .query("SELECT version FROM schema_version ORDER BY version", &[])
        .unwrap()
        .iter()
        .map(|r| r.get(0))
        .collect();
    let want: Vec<i64> = (1..=MIGRATIONS.len() as i64 + 1).collect();
    assert_eq!(versions, want, "each step applied once");
    let label: String = c
        .query_one("SELECT camera_label FROM runs", &[])
        .unwrap()
        .get(0);
    assert_eq!(label, "EX-1 1.0");
    // This build's schema is older than the database's now: refused.
    let o = run(&dir, &["history", "--db", &url]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("newer than this ledflicker's"),
        "{}",
        stderr(&o)
    );
    // A step that fails leaves the version as it was.
    let broken: Vec<&str> = steps
        .iter()
        .copied()
        .chain(["ALTER TABLE runs ADD COLUMN half TEXT; SELECT * FROM no_such_table;"])
        .collect();
    assert!(PgDb::open(&url, &broken).is_err());
    assert_eq!(
        PgDb::open(&url, &steps).unwrap().version().unwrap(),
        MIGRATIONS.len() + 1
    );
    assert!(c.query("SELECT half FROM runs", &[]).is_err());
}

#[test]
fn the_postgres_schema_has_the_tables_and_columns_of_the_sqlite_schema() {
    let Some(admin) = server() else { return };
    let url = fresh_database(&admin, "schema");
    drop(ledflicker::campaign::pg::PgDb::open(&url, ledflicker::campaign::pg::MIGRATIONS).unwrap());
    let dir = scratch("campaign-pg-schema");
    let file = dir.join("s.sqlite");
    drop(ledflicker::campaign::Db::open(&file).unwrap());
    let sqlite = rusqlite::Connection::open(&file).unwrap();
    let mut c = ledflicker::campaign::pg::connect(&url).unwrap();
    for table in ["runs", "cases", "rois", "metrics", "checks"] {
        let mut q = sqlite
            .prepare(&format!(
                "SELECT name, \"notnull\", pk FROM pragma_table_info('{table}') ORDER BY cid"
            ))
            .unwrap();
        let on_file: Vec<(String, bool)> = q
            .query_map([], |r| {
                Ok((
                    r.get(0)?,
                    r.get::<_, i64>(1)? == 1 || r.get::<_, i64>(2)? > 0,
                ))
            })
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        let on_server: Vec<(String, bool)> = c
            .query(
                "SELECT column_name::text, is_nullable = 'NO' FROM information_schema.columns \
                 WHERE table_schema = current_schema() AND table_name = $1 ORDER BY ordinal_position",
                &[&table],
            )
            .unwrap()
            .iter()
            .map(|r| (r.get(0), r.get(1)))
            .collect();
        assert_eq!(on_server, on_file, "table {table}");
    }
}

#[test]
fn a_wrong_password_is_refused_without_showing_it() {
    let Some(admin) = server() else { return };
    let dir = scratch("campaign-pg-password");
    let wrong = admin.replacen("://ledflicker@", "://ledflicker:pw-71d3e@", 1);
    let o = run(&dir, &["history", "--db", &wrong]);
    assert_ne!(o.status.code(), Some(0), "{}", text(&o));
    let err = stderr(&o);
    assert!(err.contains("password authentication failed"), "{err}");
    assert!(err.contains("ledflicker:***@"), "{err}");
    assert!(!err.contains("pw-71d3e"), "{err}");
    // Without a password in the URL or the password file, a hint names
    // the password file.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["history", "--db", &admin])
        .env("PGPASSFILE", dir.join("none"))
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0), "{}", text(&o));
    assert!(stderr(&o).contains("password file"), "{}", stderr(&o));
}

#[test]
fn a_run_that_cannot_be_recorded_whole_leaves_nothing_on_postgres() {
    let Some(admin) = server() else { return };
    let url = fresh_database(&admin, "atomic");
    let dir = scratch("campaign-pg-atomic");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    // The last case names its ROI twice: the insert of its second copy
    // fails after the run and three cases went in.
    let path = dir.join("r/results.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let rois = v["cases"][3]["rois"].as_array_mut().unwrap();
    rois.push(rois[0].clone());
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let o = run(&dir, &["import", "r", "--db", &url]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(stderr(&o).contains("duplicate key"), "{}", stderr(&o));
    let mut c = ledflicker::campaign::pg::connect(&url).unwrap();
    for table in ["runs", "cases", "rois", "metrics", "checks"] {
        let n: i64 = c
            .query_one(&format!("SELECT count(*) FROM {table}"), &[])
            .unwrap()
            .get(0);
        assert_eq!(n, 0, "{table}");
    }
    // The database takes the next run whole.
    assert_eq!(plan(&dir, &p, "r2", &["--db", &url]).status.code(), Some(0));
    let n: i64 = c
        .query_one("SELECT count(*) FROM cases", &[])
        .unwrap()
        .get(0);
    assert_eq!(n, 4);
}
