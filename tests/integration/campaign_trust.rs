//! The results database against a careless user and a forger
//! (docs/campaigns.md, "What import, history and compare promise"):
//! readers never change a file, a database never lands inside a report,
//! `import` judges verdicts again and trusts a signature only through a
//! certificate the user trusts, and no path in an imported report makes
//! it read outside the report or wait on a FIFO.

use std::path::Path;
use std::process::Output;
use std::time::{Duration, Instant};

use crate::campaign::{plan, small_plan};
use crate::{ledflicker_in, mkfifo, scratch, stderr, text};

fn run(dir: &Path, args: &[&str]) -> Output {
    ledflicker_in(args, dir)
}

fn sha(path: &Path) -> String {
    ledflicker::util::sha256_hex(&std::fs::read(path).unwrap())
}

#[test]
fn readers_leave_an_sqlite_file_that_is_not_a_results_database_untouched() {
    let dir = scratch("trust-foreign");
    let other = dir.join("other.sqlite");
    let c = rusqlite::Connection::open(&other).unwrap();
    c.execute_batch("CREATE TABLE notes (x TEXT); INSERT INTO notes VALUES ('mine');")
        .unwrap();
    drop(c);
    let before = sha(&other);
    for args in [
        &["history", "--db", "other.sqlite"][..],
        &["compare", "1", "2", "--db", "other.sqlite"][..],
        &["trend", "--kpi", "fdi_2018", "--db", "other.sqlite"][..],
        &["import", "nowhere", "--db", "other.sqlite"][..],
    ] {
        let o = run(&dir, args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(
            stderr(&o).contains("not a ledflicker results database"),
            "{}",
            text(&o)
        );
        assert_eq!(sha(&other), before, "{args:?} changed the file");
        assert!(!dir.join("other.sqlite-wal").exists());
    }
}

#[test]
fn a_results_database_that_may_not_be_written_is_read() {
    let dir = scratch("trust-readonly");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    for out in ["a", "b"] {
        assert_eq!(
            plan(&dir, &p, out, &["--db", "db.sqlite"]).status.code(),
            Some(0)
        );
    }
    // A copy in a directory of its own, closed (no WAL files), that the
    // reader may not write: as root, read as `nobody`; otherwise through
    // the permissions.
    let ro = tempfile::Builder::new()
        .prefix("ledflicker-ro")
        .tempdir_in("/tmp")
        .unwrap();
    let db = ro.path().join("db.sqlite");
    std::fs::copy(dir.join("db.sqlite"), &db).unwrap();
    let bin = ro.path().join("ledflicker");
    std::fs::copy(env!("CARGO_BIN_EXE_ledflicker"), &bin).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&db, std::fs::Permissions::from_mode(0o444)).unwrap();
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::set_permissions(ro.path(), std::fs::Permissions::from_mode(0o555)).unwrap();
    let before = sha(&db);
    let root = unsafe { libc::geteuid() } == 0;
    for args in [
        &["history", "--json"][..],
        &["compare", "1", "2"][..],
        &["trend", "--kpi", "fdi_2018_worst_phase"][..],
    ] {
        let mut cmd = if root {
            let mut c = std::process::Command::new("runuser");
            c.args(["-u", "nobody", "--"]).arg(&bin);
            c
        } else {
            std::process::Command::new(&bin)
        };
        let o = cmd
            .args(args)
            .args(["--db", db.to_str().unwrap()])
            .current_dir("/")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", text(&o));
    }
    assert_eq!(sha(&db), before);
    std::fs::set_permissions(ro.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn a_database_inside_the_report_directory_is_refused_before_the_run() {
    let dir = scratch("trust-db-in-out");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    for db in ["r/db.sqlite", "./r/sub/../db.sqlite"] {
        let o = plan(&dir, &p, "r", &["--db", db]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(
            stderr(&o).contains("is inside the report directory"),
            "{}",
            text(&o)
        );
        assert!(!dir.join("r").exists());
    }
    // Beside it is fine.
    assert_eq!(
        plan(&dir, &p, "r", &["--db", "r.sqlite"]).status.code(),
        Some(0)
    );
}

/// A report of `small_plan` whose results.json is edited by `edit`.
fn forged(dir: &Path, name: &str, edit: impl Fn(&mut serde_json::Value)) {
    let path = dir.join(name).join("results.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, serde_json::to_string(&v).unwrap()).unwrap();
}

#[test]
fn import_judges_the_verdicts_again_and_refuses_a_report_edited_to_pass() {
    let dir = scratch("trust-rejudge");
    // 1.0 ms exposure: the 150 Hz cases fail.
    let p = small_plan(&dir, "p", "1.1", "1.0");
    for out in ["genuine", "verdicts", "checks", "limits"] {
        assert_eq!(plan(&dir, &p, out, &["--no-db"]).status.code(), Some(1));
    }
    let o = run(&dir, &["import", "genuine", "--db", "i.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The verdicts alone turned to pass.
    forged(&dir, "verdicts", |v| {
        v["verdict"] = "pass".into();
        for c in v["cases"].as_array_mut().unwrap() {
            if c["verdict"] == "fail" {
                c["verdict"] = "pass".into();
            }
        }
    });
    // The checks too.
    forged(&dir, "checks", |v| {
        v["verdict"] = "pass".into();
        for c in v["cases"].as_array_mut().unwrap() {
            if c["verdict"] == "fail" {
                c["verdict"] = "pass".into();
                for k in c["checks"].as_array_mut().unwrap() {
                    k["pass"] = true.into();
                }
            }
        }
    });
    // The limit lowered in the failing checks only.
    forged(&dir, "limits", |v| {
        v["verdict"] = "pass".into();
        for c in v["cases"].as_array_mut().unwrap() {
            if c["verdict"] == "fail" {
                c["verdict"] = "pass".into();
                for k in c["checks"].as_array_mut().unwrap() {
                    k["pass"] = true.into();
                    k["threshold"] = (-1.0).into();
                }
            }
        }
    });
    for forged in ["verdicts", "checks", "limits"] {
        let o = run(&dir, &["import", forged, "--db", "i.sqlite"]);
        assert_eq!(o.status.code(), Some(2), "{forged}: {}", text(&o));
        assert!(
            stderr(&o).contains("do not follow from its own values"),
            "{}",
            text(&o)
        );
        assert!(stderr(&o).contains("2000lux-150hz-"), "{}", text(&o));
    }
    let o = run(&dir, &["history", "--db", "i.sqlite", "--json"]);
    let runs: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["verdict"], "fail");
}

#[test]
fn import_reads_no_path_outside_the_report_and_waits_on_no_fifo() {
    let dir = scratch("trust-paths");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    for out in ["escape", "fifo"] {
        assert_eq!(plan(&dir, &p, out, &["--no-db"]).status.code(), Some(0));
    }
    // Traces named outside the report: a device that never ends, a parent
    // directory, an absolute file.
    forged(&dir, "escape", |v| {
        let cases = v["cases"].as_array_mut().unwrap();
        cases[0]["trace"] = "/dev/zero".into();
        cases[1]["trace"] = "../p.toml".into();
        cases[2]["trace"] = "/etc/hostname".into();
    });
    let start = Instant::now();
    let o = run(&dir, &["import", "escape", "--db", "i.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(start.elapsed() < Duration::from_secs(20));
    // Their noise is unknown: none was read.
    let db = rusqlite::Connection::open(dir.join("i.sqlite")).unwrap();
    let unknown: i64 = db
        .query_row(
            "SELECT count(*) FROM rois WHERE noise_on_dn IS NULL AND idx < 3",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(unknown, 3);
    // A FIFO as manifest.txt: refused at once, named.
    mkfifo(&dir.join("fifo/manifest.txt"));
    let start = Instant::now();
    let o = run(&dir, &["import", "fifo", "--db", "i.sqlite"]);
    assert!(start.elapsed() < Duration::from_secs(20));
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("FIFO"), "{}", text(&o));
}
