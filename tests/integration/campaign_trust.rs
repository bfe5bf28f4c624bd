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

/// `v` (a results.json) turned to pass: the overall verdict and each
/// failing case's, with `edit` applied to each of that case's checks.
fn to_pass(v: &mut serde_json::Value, edit: impl Fn(&mut serde_json::Value)) {
    v["verdict"] = "pass".into();
    for c in v["cases"].as_array_mut().unwrap() {
        if c["verdict"] == "fail" {
            c["verdict"] = "pass".into();
            for k in c["checks"].as_array_mut().unwrap() {
                edit(k);
            }
        }
    }
}

#[test]
fn import_judges_the_verdicts_again_and_refuses_a_report_edited_to_pass() {
    let dir = scratch("trust-rejudge");
    // 1.0 ms exposure: the 150 Hz cases fail.
    let p = small_plan(&dir, "p", "1.1", "1.0");
    let forgeries = [
        "verdicts",
        "checks",
        "limits",
        "basis",
        "unbounded",
        "dropped",
        "duplicate",
    ];
    for out in std::iter::once("genuine").chain(forgeries) {
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
    forged(&dir, "checks", |v| to_pass(v, |k| k["pass"] = true.into()));
    // The limit lowered in the failing checks only.
    forged(&dir, "limits", |v| {
        to_pass(v, |k| {
            k["pass"] = true.into();
            k["threshold"] = (-1.0).into();
        })
    });
    // The failing worst-phase check renamed to the as-captured figure,
    // which passes: the basis says worst phase.
    forged(&dir, "basis", |v| {
        v["verdict"] = "pass".into();
        for c in v["cases"].as_array_mut().unwrap() {
            if c["verdict"] == "fail" {
                c["verdict"] = "pass".into();
                let fdi = c["rois"][0]["metrics"]["fdi_2018"].clone();
                for k in c["checks"].as_array_mut().unwrap() {
                    k["metric"] = "fdi_2018".into();
                    k["value"] = fdi.clone();
                    k["pass"] = true.into();
                }
            }
        }
    });
    // The failing check marked unbounded (+inf meets a minimum).
    forged(&dir, "unbounded", |v| {
        to_pass(v, |k| {
            k["unbounded"] = true.into();
            k["pass"] = true.into();
        })
    });
    // The failing check removed, excused in `not_checked`.
    forged(&dir, "dropped", |v| {
        v["verdict"] = "pass".into();
        for c in v["cases"].as_array_mut().unwrap() {
            if c["verdict"] == "fail" {
                c["verdict"] = "info".into();
                c["checks"] = serde_json::json!([]);
                c["not_checked"] = serde_json::json!(["led: skipped"]);
                c["not_judged"] = "no threshold applies (led: skipped)".into();
            }
        }
    });
    // A check twice: refused as an edit (exit 2), not a database error.
    forged(&dir, "duplicate", |v| {
        let c = &mut v["cases"][2];
        let k = c["checks"][0].clone();
        c["checks"].as_array_mut().unwrap().push(k);
    });
    for forged in forgeries {
        let o = run(&dir, &["import", forged, "--db", "i.sqlite"]);
        assert_eq!(o.status.code(), Some(2), "{forged}: {}", text(&o));
        assert!(
            stderr(&o).contains("do not follow from its own values"),
            "{}",
            text(&o)
        );
        assert!(stderr(&o).contains("2000lux-"), "{}", text(&o));
    }
    let o = run(&dir, &["history", "--db", "i.sqlite", "--json"]);
    let runs: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["verdict"], "fail");
}

#[test]
fn a_signature_by_a_key_the_user_does_not_trust_is_untrusted_not_broken() {
    let dir = scratch("trust-signers");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    for who in ["alice", "mallory"] {
        let o = run(
            &dir,
            &[
                "keygen",
                "--signer",
                "Alice Tester, Tested by",
                "--out",
                &format!("{who}.key"),
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    // Mallory signs under Alice's name.
    let signing = [
        "--no-db",
        "--sign-key",
        "mallory.key",
        "--signer",
        "Alice Tester, Tested by",
    ];
    assert_eq!(plan(&dir, &p, "r", &signing).status.code(), Some(0));
    let states = |trust: &[&str]| {
        let db = format!("s{}.sqlite", trust.len());
        let mut args = vec!["import", "r", "--db", &db];
        args.extend(trust);
        let o = run(&dir, &args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let o = run(&dir, &["history", "--db", &db, "--json"]);
        let runs: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).unwrap();
        runs[0]["signature"].as_str().unwrap().to_string()
    };
    assert_eq!(states(&[]), "untrusted");
    assert_eq!(states(&["--trust", "alice.crt"]), "untrusted");
    assert_eq!(
        states(&["--trust", "alice.crt", "--trust", "mallory.crt"]),
        "intact"
    );
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

#[test]
fn recorded_strings_reach_the_terminal_with_their_control_characters_written_out() {
    let dir = scratch("trust-escapes");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    // A hostile plan: OSC set-title, BEL, CR, and a C1 CSI in the [dut].
    let plan_text = std::fs::read_to_string(&p).unwrap().replace(
        "model = \"EX-1\"",
        "model = \"EX\\u001b]0;owned\\u0007\\r\\u009b2J\"",
    );
    std::fs::write(&p, plan_text).unwrap();
    for out in ["a", "b"] {
        assert_eq!(
            plan(&dir, &p, out, &["--db", "e.sqlite"]).status.code(),
            Some(0)
        );
    }
    for args in [
        &["history", "--db", "e.sqlite"][..],
        &["compare", "1", "2", "--db", "e.sqlite"][..],
        &["trend", "--kpi", "fdi_2018", "--db", "e.sqlite"][..],
        &["import", "a", "--db", "e.sqlite"][..],
    ] {
        let o = run(&dir, args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", text(&o));
        let raw = &o.stdout;
        assert!(
            !raw.iter().any(|b| matches!(b, 0x1b | 0x07 | b'\r'))
                && !raw.windows(2).any(|w| w == [0xc2, 0x9b]),
            "{args:?} printed a control character"
        );
        assert!(
            String::from_utf8_lossy(raw).contains("EX\\x1b]0;owned\\x07\\x0d\\u{9b}2J"),
            "{args:?}: {}",
            text(&o)
        );
    }
}

#[test]
fn a_nul_in_a_plan_string_is_refused_at_its_line() {
    let dir = scratch("trust-nul");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    let plan_text = std::fs::read_to_string(&p)
        .unwrap()
        .replace("model = \"EX-1\"", "model = \"EX\\u0000\"");
    std::fs::write(&p, plan_text).unwrap();
    let o = run(&dir, &["validate", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("`dut.model`: the string holds a NUL character"),
        "{}",
        text(&o)
    );
    assert!(stderr(&o).contains("line "), "{}", text(&o));
}

#[test]
fn the_history_page_replaces_only_its_own_page_and_refuses_a_fifo() {
    let dir = scratch("trust-page");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(
        plan(&dir, &p, "a", &["--db", "h.sqlite"]).status.code(),
        Some(0)
    );
    // A user's page that merely mentions the title in its body.
    let mine = "<!DOCTYPE html><html><head><title>Notes</title></head><body>&lt;title&gt;ledflicker history: is what the tool writes</body></html>";
    std::fs::write(dir.join("notes.html"), mine).unwrap();
    let o = run(
        &dir,
        &["history", "--db", "h.sqlite", "--html", "notes.html"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.html")).unwrap(),
        mine
    );
    // Its own page is replaced.
    let o = run(&dir, &["history", "--db", "h.sqlite", "--html", "h.html"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&dir, &["history", "--db", "h.sqlite", "--html", "h.html"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A FIFO is refused at once.
    mkfifo(&dir.join("pipe.html"));
    let start = Instant::now();
    let o = run(
        &dir,
        &["history", "--db", "h.sqlite", "--html", "pipe.html"],
    );
    assert!(start.elapsed() < Duration::from_secs(20));
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("not a regular file"), "{}", text(&o));
}

#[test]
fn a_server_that_never_answers_holds_no_command_past_its_timeout_or_a_stop() {
    let dir = scratch("trust-pg-hang");
    // Accepts connections and never says a word.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let mut held = Vec::new();
        for c in listener.incoming().flatten() {
            held.push(c);
        }
    });
    let url = format!("postgres://lab@127.0.0.1:{port}/ledflicker");
    // A FIFO as the password file is refused, not waited on.
    mkfifo(&dir.join("pgpass"));
    let start = Instant::now();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["history", "--db", &url])
        .env("PGPASSFILE", dir.join("pgpass"))
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(
        start.elapsed() < Duration::from_secs(5),
        "{:?}",
        start.elapsed()
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("FIFO"), "{}", text(&o));
    // The connection times out.
    let start = Instant::now();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["history", "--db", &url])
        .env("PGPASSFILE", dir.join("none"))
        .current_dir(&dir)
        .output()
        .unwrap();
    let took = start.elapsed();
    assert!(took < Duration::from_secs(25), "{took:?}");
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(
        stderr(&o).contains("did not complete the connection within 15 s"),
        "{}",
        text(&o)
    );
    // A run whose recording hangs is stopped by the first SIGTERM.
    let p = small_plan(&dir, "p", "1.0", "11.111");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args([
            "plan",
            p.to_str().unwrap(),
            "--out",
            "r",
            "-q",
            "--db",
            &url,
        ])
        .env("PGPASSFILE", dir.join("none"))
        .current_dir(&dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The report is written quickly; then the recording waits.
    let deadline = Instant::now() + Duration::from_secs(20);
    while !dir.join("r/results.json").exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(300));
    let stopped_at = Instant::now();
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            stopped_at.elapsed() < Duration::from_secs(5),
            "SIGTERM did not stop it"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.code().is_some(), "{status:?}");
    assert!(dir.join("r/results.json").is_file());
}

#[test]
fn a_rerun_refuses_to_lose_a_users_file_saved_inside_a_report_folder() {
    let dir = scratch("trust-subfolder");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    // What the run wrote is listed in the marker, folders' files included.
    let marker = std::fs::read_to_string(dir.join("r/.ledflicker")).unwrap();
    assert!(
        marker
            .lines()
            .any(|l| l.starts_with("traces/") && l.ends_with(".csv")),
        "{marker}"
    );
    // A re-run replaces its own files.
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    for folder in ["traces", "charts", "frames"] {
        if !dir.join("r").join(folder).is_dir() {
            continue;
        }
        let mine = dir.join("r").join(folder).join("my-notes.txt");
        std::fs::write(&mine, "mine").unwrap();
        let o = plan(&dir, &p, "r", &["--no-db"]);
        assert_eq!(o.status.code(), Some(2), "{folder}: {}", text(&o));
        assert!(
            stderr(&o).contains(&format!("{folder}/my-notes.txt")),
            "{}",
            text(&o)
        );
        assert_eq!(std::fs::read_to_string(&mine).unwrap(), "mine");
        std::fs::remove_file(&mine).unwrap();
    }
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
}

#[test]
fn sign_refuses_a_report_whose_verdicts_were_edited() {
    let dir = scratch("trust-sign-edited");
    let p = small_plan(&dir, "p", "1.1", "1.0");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(1));
    let o = run(
        &dir,
        &[
            "keygen",
            "--signer",
            "Ada Tester, Tested by",
            "--out",
            "ada.key",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    forged(&dir, "r", |v| to_pass(v, |k| k["pass"] = true.into()));
    let pdf = std::fs::read(dir.join("r/report.pdf")).unwrap();
    let o = run(
        &dir,
        &[
            "sign",
            "r",
            "--key",
            "ada.key",
            "--signer",
            "Ada Tester, Tested by",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(stderr(&o).contains("so it is not signed"), "{}", text(&o));
    assert!(!dir.join("r/signoff.p7s").exists());
    assert_eq!(std::fs::read(dir.join("r/report.pdf")).unwrap(), pdf);
}
