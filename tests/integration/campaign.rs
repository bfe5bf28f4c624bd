//! The results database: `plan` and `merge` record, `import`, `history`
//! and `compare` (docs/campaigns.md).

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::{ledflicker_in, root, scratch, stderr, text};

/// A small, fast simulator plan (4 cases: 60 and 150 Hz x 20 and 50 %
/// duty, 16 x 12 sensor) of firmware `firmware` with exposure
/// `exposure_ms`, written to `dir/name.toml`.
pub(super) fn small_plan(dir: &Path, name: &str, firmware: &str, exposure_ms: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace("sensor-rows = 800", "sensor-rows = 12")
        .replace("sensor-columns = 1280", "sensor-columns = 16")
        .replace(
            "model = \"Ideal rolling\"",
            &format!("model = \"EX-1\"\nserial = \"S-7\"\nfirmware = \"{firmware}\""),
        )
        .replace(
            "exposure-ms = 11.111",
            &format!("exposure-ms = {exposure_ms}"),
        )
        + "\n[[roi]]\nname = \"led\"\nx-px = 2\ny-px = 4\nwidth-px = 8\nheight-px = 2\n";
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn run(dir: &Path, args: &[&str]) -> Output {
    ledflicker_in(args, dir)
}

pub(super) fn plan(dir: &Path, plan: &Path, out: &str, db: &[&str]) -> Output {
    let mut args = vec![
        "plan",
        plan.to_str().unwrap(),
        "--out",
        out,
        "-q",
        "--date",
        "2026-03-04",
    ];
    args.extend(db);
    run(dir, &args)
}

fn history(dir: &Path, db: &str, filters: &[&str]) -> Vec<serde_json::Value> {
    let mut args = vec!["history", "--db", db, "--json"];
    args.extend(filters);
    let o = run(dir, &args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    serde_json::from_slice::<Vec<serde_json::Value>>(&o.stdout).unwrap()
}

fn count(db: &Path, sql: &str) -> i64 {
    rusqlite::Connection::open(db)
        .unwrap()
        .query_row(sql, [], |r| r.get(0))
        .unwrap()
}

#[test]
fn plan_records_the_run_its_device_cases_rois_and_checks() {
    let dir = scratch("campaign-record");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    let o = plan(&dir, &p, "r", &["--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let runs = history(&dir, "db.sqlite", &[]);
    assert_eq!(runs.len(), 1);
    let r = &runs[0];
    assert_eq!(r["plan_id"], "small");
    assert_eq!(r["model"], "EX-1");
    assert_eq!(r["serial"], "S-7");
    assert_eq!(r["firmware"], "1.0");
    assert_eq!(r["source"], "plan");
    assert_eq!(r["signature"], "unsigned");
    assert_eq!(r["date"], "2026-03-04");
    assert_eq!(r["verdict"], "pass");
    assert_eq!(r["cases"], serde_json::json!([4, 2, 0, 2]));
    let report = std::fs::canonicalize(dir.join("r")).unwrap();
    assert_eq!(r["report_dir"], report.to_str().unwrap());
    let results = std::fs::read(dir.join("r/results.json")).unwrap();
    assert_eq!(
        r["results_sha256"],
        ledflicker::util::sha256_hex(&results).as_str()
    );
    assert_eq!(r["plan_hash"].as_str().unwrap().len(), 64);
    let db = dir.join("db.sqlite");
    assert_eq!(count(&db, "SELECT count(*) FROM cases"), 4);
    assert_eq!(count(&db, "SELECT count(*) FROM rois"), 4);
    // Judged cases (150 Hz, in the mitigation range) have their FDI check.
    assert_eq!(
        count(
            &db,
            "SELECT count(*) FROM checks c JOIN cases k USING (run_id, idx) WHERE c.metric = 'fdi_2018_worst_phase' AND c.pass = 1 AND k.verdict = 'pass'"
        ),
        2
    );
    // A noiseless simulator: the steady frames do not move at all.
    assert_eq!(
        count(
            &db,
            "SELECT count(*) FROM rois WHERE noise_on_dn = 0 AND noise_off_dn = 0 AND off_frames = 15"
        ),
        4
    );
    assert!(
        count(
            &db,
            "SELECT count(*) FROM metrics WHERE metric = 'percent_flicker'"
        ) == 4
    );
}

#[test]
fn no_db_records_nothing_and_a_database_that_fails_is_a_warning() {
    let dir = scratch("campaign-nodb");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    let o = plan(&dir, &p, "r", &["--no-db"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!dir.join("db.sqlite").exists());
    // A file that is no database: the report is written, the exit code is
    // the run's, and the warning says how to record it later.
    std::fs::write(dir.join("junk.sqlite"), "x".repeat(4096)).unwrap();
    let o = plan(&dir, &p, "r2", &["--db", "junk.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: the run was not recorded in the results database")
            && err.contains("not an SQLite database")
            && err.contains("ledflicker import r2"),
        "{err}"
    );
    assert!(dir.join("r2/results.json").is_file());
    // --db and --no-db together are a usage error.
    let o = plan(&dir, &p, "r3", &["--db", "x.sqlite", "--no-db"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // A database in a directory that does not exist (a typo) is refused
    // before the run, naming it, and nothing is created; import likewise.
    let o = plan(&dir, &p, "r4", &["--db", "no/such/dir/db.sqlite"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = stderr(&o);
    assert!(
        err.contains("the directory `no/such/dir` does not exist")
            && err.contains("hint: create it first"),
        "{err}"
    );
    assert!(!dir.join("no").exists() && !dir.join("r4").exists());
    let o = run(&dir, &["import", "r", "--db", "no/such/dir/db.sqlite"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(!dir.join("no").exists());
}

#[test]
fn import_records_past_reports_and_history_filters_them() {
    let dir = scratch("campaign-import");
    let v10 = small_plan(&dir, "v10", "1.0", "11.111");
    let v11 = small_plan(&dir, "v11", "1.1", "1.0");
    assert_eq!(plan(&dir, &v10, "a", &["--no-db"]).status.code(), Some(0));
    assert_eq!(plan(&dir, &v11, "b", &["--no-db"]).status.code(), Some(1));
    let o = run(&dir, &["import", "a", "b", "--db", "h.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("run 1: `a`") && out.contains("run 2: `b`"),
        "{out}"
    );
    assert!(out.contains("(unsigned)"), "{out}");
    assert_eq!(history(&dir, "h.sqlite", &[]).len(), 2);
    let by_fw = history(&dir, "h.sqlite", &["--firmware", "1.1"]);
    assert_eq!(by_fw.len(), 1);
    assert_eq!(by_fw[0]["source"], "import");
    assert_eq!(by_fw[0]["verdict"], "fail");
    assert_eq!(history(&dir, "h.sqlite", &["--verdict", "pass"]).len(), 1);
    assert_eq!(
        history(&dir, "h.sqlite", &["--camera", "EX-1", "--serial", "S-7"]).len(),
        2
    );
    assert_eq!(history(&dir, "h.sqlite", &["--camera", "EX-2"]).len(), 0);
    assert_eq!(
        history(
            &dir,
            "h.sqlite",
            &["--since", "2026-03-04", "--until", "2026-03-04"]
        )
        .len(),
        2
    );
    assert_eq!(
        history(&dir, "h.sqlite", &["--since", "2026-03-05"]).len(),
        0
    );
    assert_eq!(history(&dir, "h.sqlite", &["--plan", "small"]).len(), 2);
    // The table: a header and one line per run.
    let o = run(&dir, &["history", "--db", "h.sqlite"]);
    let table = String::from_utf8_lossy(&o.stdout);
    assert_eq!(table.lines().count(), 3, "{table}");
    assert!(table.starts_with("run  date"), "{table}");
    let o = run(
        &dir,
        &["history", "--db", "h.sqlite", "--since", "2026-13-01"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--since `2026-13-01` is not a date"),
        "{}",
        stderr(&o)
    );
    let o = run(&dir, &["history", "--db", "missing.sqlite"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no such file"), "{}", stderr(&o));
    let o = run(&dir, &["import", "nowhere", "--db", "h.sqlite"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("cannot read `nowhere/results.json`"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_run_that_cannot_be_recorded_whole_leaves_nothing() {
    let dir = scratch("campaign-atomic");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    // The last case names its ROI twice: the insert of its second copy
    // fails after the run and three cases went in.
    let path = dir.join("r/results.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let rois = v["cases"][3]["rois"].as_array_mut().unwrap();
    rois.push(rois[0].clone());
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let o = run(&dir, &["import", "r", "--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    let db = dir.join("db.sqlite");
    for table in ["runs", "cases", "rois", "metrics", "checks"] {
        assert_eq!(
            count(&db, &format!("SELECT count(*) FROM {table}")),
            0,
            "{table}"
        );
    }
}

#[test]
fn several_processes_recording_into_one_database_lose_nothing() {
    let dir = scratch("campaign-concurrent");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    assert_eq!(plan(&dir, &p, "r", &["--no-db"]).status.code(), Some(0));
    let children: Vec<_> = (0..6)
        .map(|_| {
            std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
                .env("LEDFLICKER_DB", dir.join("shared.sqlite"))
                .args(["import", "r", "r", "r"])
                .current_dir(&dir)
                .output()
        })
        .collect();
    for c in children {
        let o = c.unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let db = dir.join("shared.sqlite");
    assert_eq!(count(&db, "SELECT count(*) FROM runs"), 18);
    assert_eq!(count(&db, "SELECT count(*) FROM cases"), 18 * 4);
}

#[test]
fn compare_gates_a_shorter_exposure_as_a_regression_and_names_the_case() {
    let dir = scratch("campaign-compare");
    let v10 = small_plan(&dir, "v10", "1.0", "11.111");
    let v11 = small_plan(&dir, "v11", "1.1", "1.0");
    assert_eq!(
        plan(&dir, &v10, "a", &["--db", "c.sqlite"]).status.code(),
        Some(0)
    );
    assert_eq!(
        plan(&dir, &v11, "b", &["--db", "c.sqlite"]).status.code(),
        Some(1)
    );
    let o = run(
        &dir,
        &[
            "compare", "a", "b", "--db", "c.sqlite", "--junit", "cmp.xml",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    // The simulator's verdict rests on the worst PWM phase.
    assert!(
        out.contains(
            "REGRESSED:\n  2000lux-150hz-20pct led fdi_2018_worst_phase: 1.0472 -> 0.0000"
        ),
        "{out}"
    );
    // Cases judged in neither run (60 Hz, below the mitigation range) are
    // not gated.
    assert!(!out.contains("REGRESSION in 3"), "{out}");
    assert!(
        out.contains("REGRESSION in 2 case(s): 2000lux-150hz-20pct, 2000lux-150hz-50pct"),
        "{out}"
    );
    assert!(
        out.contains("verdict flip: 2000lux-150hz-20pct pass -> fail"),
        "{out}"
    );
    let xml = std::fs::read_to_string(dir.join("cmp.xml")).unwrap();
    let report = quick_junit::Report::deserialize_from_str(&xml).unwrap();
    let failed: Vec<&str> = report.test_suites[0]
        .test_cases
        .iter()
        .filter(|c| matches!(c.status, quick_junit::TestCaseStatus::NonSuccess { .. }))
        .map(|c| c.name.as_str())
        .collect();
    assert!(failed.contains(&"2000lux-150hz-20pct"), "{xml}");
    // The set-up, then the four cases.
    assert_eq!(report.test_suites[0].test_cases.len(), 5);
    assert_eq!(report.test_suites[0].test_cases[0].name.as_str(), "set-up");
    // The same run against itself, and the latest of firmware 1.1 against
    // the run before it, by id and by --latest.
    let o = run(&dir, &["compare", "1", "1", "--db", "c.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("no regression"));
    let o = run(
        &dir,
        &[
            "compare",
            "--latest",
            "--camera",
            "EX-1",
            "--firmware",
            "1.1",
            "--db",
            "c.sqlite",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("A: run 1 "));
    // The improvement (B back to A) is no regression.
    let o = run(&dir, &["compare", "b", "a", "--db", "c.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&dir, &["compare", "1", "9", "--db", "c.sqlite"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no run 9"), "{}", stderr(&o));
}

#[test]
fn compare_writes_a_comparison_report_into_a_directory_of_its_own() {
    let dir = scratch("campaign-report");
    let v10 = small_plan(&dir, "v10", "1.0", "11.111");
    let v11 = small_plan(&dir, "v11", "1.1", "1.0");
    plan(&dir, &v10, "a", &["--db", "c.sqlite"]);
    plan(&dir, &v11, "b", &["--db", "c.sqlite"]);
    let compare = |report: &str| {
        run(
            &dir,
            &[
                "compare",
                "a",
                "b",
                "--db",
                "c.sqlite",
                "--report",
                report,
                "--date",
                "2026-05-06",
            ],
        )
    };
    let o = compare("cmp");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let html = std::fs::read_to_string(dir.join("cmp/comparison.html")).unwrap();
    // The two runs, the regressed cases first (in the regressions table,
    // before the table of the other gated KPIs), the flip, and a chart.
    assert!(html.contains("firmware 1.0 → 1.1"), "{html}");
    assert!(html.contains("2026-05-06"));
    let regressions = html.find("<h2>Regressions</h2>").unwrap();
    let flips = html.find("<h2>Verdict flips</h2>").unwrap();
    for case in ["2000lux-150hz-20pct", "2000lux-150hz-50pct"] {
        let at = html[regressions..].find(case).map(|i| i + regressions);
        assert!(
            at.is_some_and(|i| i < flips),
            "{case} not among the regressions"
        );
    }
    assert!(html[flips..].contains("2000lux-150hz-20pct"));
    assert!(html.contains("<svg"), "no chart");
    assert_eq!(html.matches("<tr class=\"regressed\">").count(), 2);
    // Each regressed case's trace, A and B on one chart, before the flips.
    let traces = html.find("<h2>Traces of the regressed cases</h2>").unwrap();
    assert!(regressions < traces && traces < flips);
    for case in ["2000lux-150hz-20pct", "2000lux-150hz-50pct"] {
        assert!(
            html[traces..flips].contains(&format!("<h3>{case}, ROI led</h3>")),
            "{case}"
        );
    }
    assert!(html[traces..flips].contains("A: run 1, firmware 1.0"));
    assert!(html[traces..flips].contains("B: run 2, firmware 1.1"));
    assert_eq!(html[traces..flips].matches("<svg").count(), 2);
    // The 2 x 2 grid as a matrix: the regressed cells marked, the others not.
    let grid = html.find("<h2>Across the grid</h2>").unwrap();
    assert!(traces < grid && grid < flips);
    assert!(
        html[grid..flips].contains("<th>60 Hz</th><th>150 Hz</th>"),
        "{}",
        &html[grid..flips]
    );
    assert_eq!(
        html[grid..flips]
            .matches("<td class=\"regressed\">")
            .count(),
        2
    );
    let xml = std::fs::read_to_string(dir.join("cmp/junit.xml")).unwrap();
    assert!(xml.contains("2000lux-150hz-20pct"));
    if cfg!(feature = "pdf") {
        let pdf = std::fs::read(dir.join("cmp/comparison.pdf")).unwrap();
        assert!(pdf.starts_with(b"%PDF"));
    }
    // Written again, the directory is replaced whole and a user's file in
    // it survives.
    std::fs::write(dir.join("cmp/notes.txt"), "mine").unwrap();
    assert_eq!(compare("cmp").status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(dir.join("cmp/notes.txt")).unwrap(),
        "mine"
    );
    // A run's report directory, or a directory of the user's, is refused
    // and left as it was.
    let results = std::fs::read(dir.join("a/results.json")).unwrap();
    let o = compare("a");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("a run's report directory"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(dir.join("a/results.json")).unwrap(), results);
    assert!(!dir.join("a/comparison.html").exists());
    std::fs::create_dir(dir.join("mine")).unwrap();
    std::fs::write(dir.join("mine/x.txt"), "x").unwrap();
    let o = compare("mine");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(!dir.join("mine/comparison.html").exists());
}

/// Every place these tests start the binary points it at a scratch
/// database: none may record into the user's own.
#[test]
fn every_run_of_the_binary_in_the_tests_records_into_a_scratch_database() {
    let dir = root().join("tests/integration");
    for entry in std::fs::read_dir(&dir).unwrap().flatten() {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let src = std::fs::read_to_string(&path).unwrap();
        for (at, _) in src.match_indices("Command::new(") {
            // This test's own patterns, in string literals.
            if src[..at].ends_with('"') {
                continue;
            }
            let call = &src[at..(at + 200).min(src.len())];
            let starts_binary = call
                .starts_with("Command::new(env!(\"CARGO_BIN_EXE_ledflicker\"))")
                || call.starts_with("Command::new(exe())");
            if starts_binary {
                let next = &src[at..(at + 120).min(src.len())];
                assert!(
                    next.contains(".env(\"LEDFLICKER_DB\""),
                    "{}: a run of the binary without LEDFLICKER_DB at byte {at}",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn a_signed_run_is_recorded_with_its_signer_and_an_import_verifies_it() {
    let dir = scratch("campaign-signed");
    let p = small_plan(&dir, "p", "1.0", "11.111");
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
    let signing = [
        "--db",
        "db.sqlite",
        "--sign-key",
        "ada.key",
        "--signer",
        "Ada Tester, Tested by",
    ];
    let o = plan(&dir, &p, "r", &signing);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let manifest = std::fs::read(dir.join("r/manifest.txt")).unwrap();
    let runs = history(&dir, "db.sqlite", &[]);
    assert_eq!(runs[0]["signature"], "signed");
    assert_eq!(runs[0]["signer"], "Ada Tester, Tested by");
    assert_eq!(
        runs[0]["manifest_sha256"],
        ledflicker::util::sha256_hex(&manifest).as_str()
    );
    // Intact only with the signer's certificate as a trust anchor; without
    // one, anyone could have signed under that name.
    let o = run(
        &dir,
        &["import", "r", "--db", "db.sqlite", "--trust", "ada.crt"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&dir, &["import", "r", "--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A report changed after signing is still recorded, marked broken.
    std::fs::write(dir.join("r/summary.csv"), "changed\n").unwrap();
    let o = run(&dir, &["import", "r", "--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(stderr(&o).contains("recorded as broken"), "{}", stderr(&o));
    let runs = history(&dir, "db.sqlite", &[]);
    let states: Vec<&str> = runs
        .iter()
        .map(|r| r["signature"].as_str().unwrap())
        .collect();
    assert_eq!(states, ["signed", "intact", "untrusted", "broken"]);
    assert_eq!(runs[1]["signer"], "Ada Tester, Tested by");
}

#[test]
fn merge_records_the_whole_run_once_and_shards_record_nothing() {
    let dir = scratch("campaign-merge");
    let p = small_plan(&dir, "p", "1.0", "11.111");
    for k in ["0/2", "1/2"] {
        let out = format!("s{}", &k[..1]);
        let o = run(
            &dir,
            &[
                "plan",
                p.to_str().unwrap(),
                "--shard",
                k,
                "--out",
                &out,
                "-q",
                "--db",
                "db.sqlite",
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    assert!(!dir.join("db.sqlite").exists());
    let o = run(
        &dir,
        &[
            "merge",
            "s0",
            "s1",
            "--out",
            "m",
            "-q",
            "--date",
            "2026-03-04",
            "--db",
            "db.sqlite",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let runs = history(&dir, "db.sqlite", &[]);
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0]["source"], "merge");
    assert_eq!(runs[0]["cases"], serde_json::json!([4, 2, 0, 2]));
    // The merged run is the run `plan` would have recorded.
    let o = plan(&dir, &p, "whole", &["--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&dir, &["compare", "1", "2", "--db", "db.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("no regression") && !out.contains("verdict flip"),
        "{out}"
    );
    let runs = history(&dir, "db.sqlite", &[]);
    assert_eq!(runs[0]["plan_hash"], runs[1]["plan_hash"]);
}

/// Copies the report directory `from` to `to`, with its results.json's
/// `[dut] firmware` set to `firmware`: a past report of another build.
fn copy_as_firmware(from: &Path, to: &Path, firmware: &str) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_as_firmware(&e.path(), &target, firmware);
        } else if e.file_name() == "results.json" {
            let mut r: serde_json::Value =
                serde_json::from_slice(&std::fs::read(e.path()).unwrap()).unwrap();
            r["dut"]["firmware"] = serde_json::Value::from(firmware);
            std::fs::write(&target, serde_json::to_vec(&r).unwrap()).unwrap();
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// `%XX` of a `file://` URL back to the path.
fn url_path(url: &str) -> PathBuf {
    let bytes = url.strip_prefix("file://").unwrap().as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).unwrap();
            out.push(u8::from_str_radix(hex, 16).unwrap());
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    PathBuf::from(String::from_utf8(out).unwrap())
}

#[test]
fn history_trend_and_the_history_page_cover_a_campaign_of_52_runs() {
    let dir = scratch("campaign-trend");
    let v10 = small_plan(&dir, "v10", "1.0", "11.111");
    let v11 = small_plan(&dir, "v11", "1.1", "1.0");
    plan(&dir, &v10, "a", &["--db", "t.sqlite"]);
    plan(&dir, &v11, "b", &["--db", "t.sqlite"]);
    // Fifty past reports: builds 2.0 to 2.39 as good as run a, 2.40 to
    // 2.49 with run b's shorter exposure.
    let mut import = vec!["import".to_string(), "--db".into(), "t.sqlite".into()];
    for i in 0..50 {
        let from = if i < 40 { "a" } else { "b" };
        let to = format!("past/fw 2.{i}");
        copy_as_firmware(&dir.join(from), &dir.join(&to), &format!("2.{i}"));
        import.push(to);
    }
    let args: Vec<&str> = import.iter().map(String::as_str).collect();
    let o = run(&dir, &args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(history(&dir, "t.sqlite", &[]).len(), 52);
    let one = history(&dir, "t.sqlite", &["--firmware", "2.45"]);
    assert_eq!(one.len(), 1);
    assert_eq!(one[0]["verdict"], "fail");

    let case = "2000lux-150hz-20pct";
    let trend = |extra: &[&str]| {
        let mut args = vec![
            "trend",
            "--db",
            "t.sqlite",
            "--kpi",
            "fdi_2018_worst_phase",
            "--case",
            case,
            "--roi",
            "led",
        ];
        args.extend(extra);
        run(&dir, &args)
    };
    let o = trend(&["--json", "--svg", "trend.svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let points: Vec<serde_json::Value> = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(points.len(), 52);
    let value = |p: &serde_json::Value| p["value"].as_f64().unwrap();
    let (good, bad) = (value(&points[0]), value(&points[1]));
    assert!(good - bad > 0.5, "{good} {bad}");
    for (k, p) in points[2..].iter().enumerate() {
        assert_eq!(p["firmware"], format!("2.{k}").as_str());
        let want = if k < 40 { good } else { bad };
        assert!((value(p) - want).abs() < 1e-9, "{p}");
    }
    let svg = std::fs::read_to_string(dir.join("trend.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains(&format!("\n{case} led\n")));
    let o = trend(&["--firmware", "2.45", "--camera", "EX-1"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let table = String::from_utf8_lossy(&o.stdout);
    assert_eq!(table.lines().count(), 2, "{table}");
    assert!(table.lines().nth(1).unwrap().contains(" 2.45 "), "{table}");
    let o = trend(&["--plan", "no-such-plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no value of `fdi_2018_worst_phase`"));

    let o = run(
        &dir,
        &["history", "--db", "t.sqlite", "--html", "history.html"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let page = std::fs::read_to_string(dir.join("history.html")).unwrap();
    let hrefs: Vec<&str> = page
        .split("href=\"")
        .skip(1)
        .map(|s| s.split('"').next().unwrap())
        .filter(|h| h.starts_with("file://"))
        .collect();
    // Every run's report.html and report.pdf (when built with the PDF),
    // and every link resolves.
    let per_run = if cfg!(feature = "pdf") { 2 } else { 1 };
    assert_eq!(hrefs.len(), 52 * per_run, "{page}");
    for h in &hrefs {
        assert!(url_path(h).is_file(), "{h} does not resolve");
    }
    assert!(page.contains("2.49") && page.contains("<svg"));
    let (_, console) = crate::visual::chromium(&dir.join("history.html"), &dir);
    assert!(console.is_empty(), "console output: {console:#?}");
    // A file of the user's is never replaced.
    std::fs::write(dir.join("notes.html"), "mine").unwrap();
    let o = run(
        &dir,
        &["history", "--db", "t.sqlite", "--html", "notes.html"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.html")).unwrap(),
        "mine"
    );
}

/// `\d{4}-\d{2}-\d{2}` replaced by `DATE`: the README's dates are the
/// day it was written.
fn undated(line: &str) -> String {
    let b = line.as_bytes();
    let mut out = String::new();
    let mut i = 0;
    while i < b.len() {
        let date = b.len() >= i + 10
            && (0..10).all(|k| {
                if k == 4 || k == 7 {
                    b[i + k] == b'-'
                } else {
                    b[i + k].is_ascii_digit()
                }
            });
        if date {
            out.push_str("DATE");
            i += 10;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// The README's three-command campaign, run as written (its commands in
/// one shell, `ledflicker` this build): every line of output it shows
/// appears, in order (`...` stands for lines or text left out).
#[test]
fn readme_campaign_runs_as_written() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let section = readme
        .split("### A campaign in three commands")
        .nth(1)
        .unwrap();
    let block = section.split("```sh\n").nth(1).unwrap();
    let block = block.split("```").next().unwrap();
    let commands: Vec<&str> = block.lines().filter_map(|l| l.strip_prefix("$ ")).collect();
    let shown: Vec<&str> = block.lines().filter(|l| !l.starts_with("$ ")).collect();
    assert_eq!(commands.len(), 4, "{block}");
    // An empty directory, as after an install: no test-plans/ beside it.
    let dir = scratch("campaign-readme");
    let bin = dir.join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_ledflicker"), bin.join("ledflicker")).unwrap();
    let script = format!("exec 2>&1\n{}\n", commands.join("\n"));
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = std::process::Command::new("sh")
        .args(["-c", &script])
        .current_dir(&dir)
        .env("PATH", path)
        .env("LEDFLICKER_DB", dir.join("results.sqlite"))
        .env_remove("SOURCE_DATE_EPOCH")
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let actual: Vec<String> = out.lines().map(undated).collect();
    let mut at = 0;
    for line in shown.iter().map(|l| undated(l)) {
        if line == "..." {
            continue;
        }
        let (head, tail) = line.split_once("...").unwrap_or((&line, ""));
        let found = actual[at..].iter().position(|a| {
            if line.contains("...") {
                a.starts_with(head) && a.ends_with(tail)
            } else {
                *a == line
            }
        });
        let Some(k) = found else {
            panic!("the README shows `{line}`, not in the output after line {at}:\n{out}");
        };
        at += k + 1;
    }
    assert_eq!(out.lines().last(), Some("1"), "compare exits 1");
    assert!(dir.join("compare.xml").is_file());
    assert!(dir.join("reports/compare/comparison.html").is_file());
    if cfg!(feature = "pdf") {
        assert!(dir.join("reports/compare/comparison.pdf").is_file());
    }
}

/// The history page counts runs in words that fit one run, and says when
/// a camera's runs carry no firmware instead of printing an empty list.
#[test]
fn the_history_page_names_one_run_and_missing_firmware_in_words() {
    let dir = scratch("history-words");
    let shipped = std::fs::read_to_string(root().join("test-plans/daylight.toml")).unwrap();
    let no_firmware: String = shipped
        .lines()
        .filter(|l| !l.starts_with("firmware"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_ne!(no_firmware, shipped);
    std::fs::write(dir.join("p.toml"), no_firmware).unwrap();
    let o = plan(&dir, &dir.join("p.toml"), "r", &["--db", "h.sqlite"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = run(&dir, &["history", "--db", "h.sqlite", "--html", "h.html"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let html = std::fs::read_to_string(dir.join("h.html")).unwrap();
    assert!(html.contains("(1 run; no firmware recorded)"), "{html}");
    assert!(
        !html.contains("1 runs") && !html.contains("firmware )"),
        "{html}"
    );
}
