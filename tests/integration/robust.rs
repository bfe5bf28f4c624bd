//! Issue 10, "nothing lost, nothing hangs": each defect named in the issue,
//! reproduced through the binary. Each of these failed before the fix.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::{ledflicker_in as ledflicker, root, scratch, stderr};

/// The binary under test; `LEDFLICKER_TEST_EXE` runs these tests against
/// another build (e.g. an older one, to see them fail).
fn exe() -> String {
    std::env::var("LEDFLICKER_TEST_EXE").unwrap_or(env!("CARGO_BIN_EXE_ledflicker").to_string())
}

/// A small, fast simulator plan (4 cases, 16 x 12 sensor), written to `dir`.
pub(super) fn small_plan(dir: &Path, grid: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace("sensor-rows = 800", "sensor-rows = 12")
        .replace("sensor-columns = 1280", "sensor-columns = 16")
        .replace(
            "frequencies-hz = [60.0, 150.0]\nduty-cycles = [0.2, 0.5]",
            grid,
        )
        + "\n[[roi]]\nname = \"led\"\nx-px = 2\ny-px = 4\nwidth-px = 8\nheight-px = 2\n";
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

const GRID: &str = "frequencies-hz = [60.0, 150.0]\nduty-cycles = [0.2, 0.5]";

fn plan_into(plan: &Path, out: &Path, dir: &Path) -> Output {
    ledflicker(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
            "--date",
            "2026-01-02",
        ],
        dir,
    )
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn plan_refuses_a_foreign_directory_and_deletes_nothing_in_it() {
    // DIR/frames, DIR/charts and DIR/traces of a directory ledflicker did
    // not write are the user's: `plan --out DIR` must not remove them.
    let dir = scratch("robust-foreign");
    let plan = small_plan(&dir, GRID);
    let out = dir.join("captures");
    for sub in ["frames", "charts", "traces"] {
        std::fs::create_dir_all(out.join(sub)).unwrap();
        std::fs::write(out.join(sub).join("keep.bin"), sub).unwrap();
    }
    let o = plan_into(&plan, &out, &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("holds no ledflicker report") && err.contains("hint:"),
        "{err}"
    );
    assert_eq!(err.matches("error:").count(), 1, "{err}");
    for sub in ["frames", "charts", "traces"] {
        assert_eq!(
            std::fs::read_to_string(out.join(sub).join("keep.bin")).unwrap(),
            sub
        );
    }
    assert_eq!(listing(&dir), ["captures", "plan.toml"]);
}

#[test]
fn a_second_run_replaces_the_report_and_keeps_files_it_did_not_write() {
    let dir = scratch("robust-regen");
    let plan = small_plan(&dir, GRID);
    let out = dir.join("report");
    assert_eq!(plan_into(&plan, &out, &dir).status.code(), Some(0));
    assert!(out.join(".ledflicker").is_file());
    std::fs::write(out.join("lab-notes.txt"), "bench 3").unwrap();
    // A file of the user's inside a folder the report writes stops the
    // re-run instead of going with the old generation; moved out, the run
    // goes on, and the old run's traces are replaced.
    std::fs::write(out.join("traces/stale.csv"), "old").unwrap();
    let plan = small_plan(&dir, "frequencies-hz = [150.0]\nduty-cycles = [0.5]");
    let o = plan_into(&plan, &out, &dir);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("traces/stale.csv"), "{}", stderr(&o));
    std::fs::rename(out.join("traces/stale.csv"), dir.join("stale.csv")).unwrap();
    std::fs::remove_file(dir.join("stale.csv")).unwrap();
    let o = plan_into(&plan, &out, &dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(out.join("lab-notes.txt")).unwrap(),
        "bench 3"
    );
    assert_eq!(listing(&out.join("traces")), ["2000lux-150hz-50pct.csv"]);
    assert_eq!(
        listing(&dir),
        ["plan.toml", "report"],
        "no temporary directory left"
    );
}

#[test]
fn output_path_problems_exit_2_with_one_message() {
    let dir = scratch("robust-outpath");
    let plan = small_plan(&dir, GRID);
    std::fs::write(dir.join("afile"), "x").unwrap();
    for (out, needle) in [
        (dir.join("afile"), "not a directory"),
        (
            PathBuf::from("/proc/ledflicker-test/report"),
            "cannot create",
        ),
    ] {
        let o = plan_into(&plan, &out, &dir);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(needle), "{err}");
        assert_eq!(
            err.lines().filter(|l| l.starts_with("error:")).count(),
            1,
            "{err}"
        );
    }
}

/// Starts `plan` with a rig that sleeps, so the run is in progress for
/// `secs` seconds per case.
fn slow_rig_plan(dir: &Path, secs: u32) -> PathBuf {
    let text = std::fs::read_to_string(root().join("test-plans/command-sim-rig.toml"))
        .unwrap()
        .replace(
            "command = [\"sh\", \"../examples/sim-rig.sh\"]",
            &format!(
                "command = [\"sh\", \"-c\", \"echo started >> {}; sleep {secs}; echo finished >> {}\"]",
                dir.join("starts").display(),
                dir.join("finishes").display()
            ),
        );
    let path = dir.join("slow.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn spawn_plan(plan: &Path, out: &Path, dir: &Path) -> std::process::Child {
    Command::new(exe())
        .env("LEDFLICKER_DB", crate::test_db())
        .args([
            "plan",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_for(path: &Path) {
    let t = Instant::now();
    while !path.exists() {
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "{} never appeared",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn sigint_and_sigterm_stop_the_run_promptly_and_keep_the_old_report() {
    let dir = scratch("robust-sigint");
    let out = dir.join("report");
    assert_eq!(
        plan_into(&small_plan(&dir, GRID), &out, &dir).status.code(),
        Some(0)
    );
    let before = std::fs::read(out.join("results.json")).unwrap();
    for (signal, code) in [(libc_sigint(), 130), (libc_sigterm(), 143)] {
        let _ = std::fs::remove_file(dir.join("starts"));
        let plan = slow_rig_plan(&dir, 30);
        let mut child = spawn_plan(&plan, &out, &dir);
        wait_for(&dir.join("starts"));
        send(child.id(), signal);
        let status = child.wait().unwrap();
        let mut err = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
        assert_eq!(status.code(), Some(code), "{err}");
        assert!(err.contains("interrupted by"), "{err}");
        // The run stopped its rig; it did not wait for it to finish.
        assert!(!dir.join("finishes").exists(), "the run waited for its rig");
        assert_eq!(std::fs::read(out.join("results.json")).unwrap(), before);
        assert_eq!(
            listing(&dir).iter().filter(|n| n.starts_with('.')).count(),
            0
        );
    }
}

#[test]
fn a_run_killed_with_sigkill_leaves_the_old_report_and_the_next_run_cleans_up() {
    let dir = scratch("robust-kill9");
    let out = dir.join("report");
    assert_eq!(
        plan_into(&small_plan(&dir, GRID), &out, &dir).status.code(),
        Some(0)
    );
    let before = std::fs::read(out.join("results.json")).unwrap();
    let plan = slow_rig_plan(&dir, 30);
    let mut child = spawn_plan(&plan, &out, &dir);
    wait_for(&dir.join("starts"));
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(std::fs::read(out.join("results.json")).unwrap(), before);
    assert!(
        listing(&dir)
            .iter()
            .any(|n| n.starts_with(".report.ledflicker-new-"))
    );
    let scratch = std::env::temp_dir()
        .read_dir()
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .find(|n| n.starts_with(&format!("ledflicker-rig-{}-", child.id())))
        .expect("the killed run's rig scratch directory");
    // The next run (here a rig run, which cleans rig scratch too) removes
    // what the killed one left.
    let o = plan_into(&slow_rig_plan(&dir, 0), &out, &dir);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        !std::env::temp_dir().join(&scratch).exists(),
        "{scratch} left"
    );
    let o = plan_into(&small_plan(&dir, GRID), &out, &dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        listing(&dir).iter().filter(|n| n.starts_with('.')).count(),
        0
    );
}

fn libc_sigint() -> i32 {
    2
}

fn libc_sigterm() -> i32 {
    15
}

fn send(pid: u32, signal: i32) {
    let ok = Command::new("kill")
        .args([format!("-{signal}"), pid.to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

#[test]
fn validate_refuses_plans_beyond_the_physical_bounds_and_the_work_limit() {
    // Each of these, accepted, would abort out of memory.
    let dir = scratch("robust-bounds");
    let sub = |name: &str| {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        d
    };
    let cases = [
        (
            small_plan(
                &sub("f"),
                "frequencies-hz = [90.0, 1.0e9]\nduty-cycles = [0.5]",
            ),
            vec!["grid.frequencies-hz[1]", "above the 1000000 Hz limit"],
        ),
        (
            {
                let p = small_plan(&sub("sensor"), GRID);
                let t = std::fs::read_to_string(&p)
                    .unwrap()
                    .replace("shutter = \"rolling\"", "shutter = \"global\"")
                    .replace("line-time-us = 14.565\n", "")
                    .replace("sensor-rows = 12", "sensor-rows = 100000")
                    .replace("sensor-columns = 16", "sensor-columns = 100000");
                std::fs::write(&p, t).unwrap();
                p
            },
            vec!["100000 x 100000 sensor", "dut.camera.sensor-rows"],
        ),
        (
            small_plan(
                &sub("cases"),
                "frequency-range-hz = { start = 50.0, stop = 10049.0, step = 1.0 }\nduty-cycle-range = { start = 0.1, stop = 1.0, step = 0.1 }",
            ),
            // The spilled model keeps the memory flat: the report's disk
            // space is what refuses it.
            vec!["100000 cases", "--max-report raises it"],
        ),
        (
            {
                let p = small_plan(
                    &sub("memory"),
                    "frequency-range-hz = { start = 50.0, stop = 10049.0, step = 1.0 }\nduty-cycle-range = { start = 0.1, stop = 1.0, step = 0.1 }",
                );
                let t = std::fs::read_to_string(&p)
                    .unwrap()
                    .replace("sensor-rows = 12", "sensor-rows = 800")
                    .replace("sensor-columns = 16", "sensor-columns = 1280");
                std::fs::write(&p, t).unwrap();
                p
            },
            vec![
                "too large to run",
                "peak memory",
                "estimated work: 100000 cases x 150 frames",
            ],
        ),
    ];
    for (plan, needles) in cases {
        let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        for n in needles {
            assert!(err.contains(n), "`{n}` not in: {err}");
        }
    }
    let o = ledflicker(
        &["validate", small_plan(&dir, GRID).to_str().unwrap()],
        &dir,
    );
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("estimated work: 4 cases x 150 frames x 2 rows"),
        "{text}"
    );
}

#[test]
fn grid_points_with_the_same_case_id_are_a_validation_error_naming_both() {
    // 90.0 and 90.0000001 Hz would share one id and one trace file.
    let dir = scratch("robust-ids");
    let plan = small_plan(
        &dir,
        "frequencies-hz = [90.0, 90.0000001]\nduty-cycles = [0.5]",
    );
    let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("90 Hz")
            && err.contains("90.0000001 Hz")
            && err.contains("`2000lux-90hz-50pct`"),
        "{err}"
    );
}

fn rig_plan(dir: &Path, name: &str, script: &str, timeout_s: f64) -> PathBuf {
    let text = std::fs::read_to_string(root().join("test-plans/command-sim-rig.toml"))
        .unwrap()
        .replace(
            "command = [\"sh\", \"../examples/sim-rig.sh\"]\ntimeout-s = 60.0",
            &format!("command = [\"sh\", \"-c\", {script:?}]\ntimeout-s = {timeout_s:?}"),
        );
    let plan = dir.join(name);
    std::fs::write(&plan, text).unwrap();
    plan
}

#[test]
fn a_rig_that_leaves_a_background_child_holding_stderr_does_not_hold_the_run() {
    // The rig exits, and its background child keeps stderr open for 30 s
    // (forever, for a daemon): `plan` must not wait for it, whatever
    // timeout-s says. Had it waited, the child would have written `done`.
    let dir = scratch("robust-hung-rig");
    let done = dir.join("done");
    let script = format!("(sleep 30; touch {}) & exit 0", done.display());
    let plan = rig_plan(&dir, "hung.toml", &script, 20.0);
    let o = plan_into(&plan, &dir.join("o"), &dir);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        !done.exists(),
        "the run waited for the rig's background child"
    );
}

#[test]
fn a_timed_out_rig_is_killed_with_everything_it_started() {
    // Killing only the rig's shell would leave its children running.
    let dir = scratch("robust-rig-group");
    let flag = dir.join("survivor");
    let finished = dir.join("finished");
    let script = format!(
        "(sleep 2; touch {}) & sleep 30; touch {}",
        flag.display(),
        finished.display()
    );
    let plan = rig_plan(&dir, "group.toml", &script, 1.0);
    let o = plan_into(&plan, &dir.join("o"), &dir);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("did not finish within 1.0 s"),
        "{}",
        stderr(&o)
    );
    assert!(!finished.exists(), "the run waited for the timed-out rig");
    // Long enough for the child to have touched its file, had it lived.
    std::thread::sleep(Duration::from_millis(2500));
    assert!(!flag.exists(), "a child of the timed-out rig outlived it");
}

#[test]
fn the_rig_gets_the_exact_seed_and_a_private_scratch_directory_that_is_removed() {
    let dir = scratch("robust-rig-seed");
    let log = dir.join("log");
    let script = format!(
        "cat > {log}.$LEDFLICKER_CASE_ID.json; stat -c %a \"$(dirname \"$LEDFLICKER_OUT_DIR\")\" > {log}.$LEDFLICKER_CASE_ID.mode; dirname \"$LEDFLICKER_OUT_DIR\" > {log}.$LEDFLICKER_CASE_ID.dir; exec sh {rig}",
        log = log.display(),
        rig = root().join("examples/sim-rig.sh").display()
    );
    let text = std::fs::read_to_string(root().join("test-plans/command-sim-rig.toml"))
        .unwrap()
        .replace(
            "command = [\"sh\", \"../examples/sim-rig.sh\"]",
            &format!("command = [\"sh\", \"-c\", {script:?}]"),
        )
        .replace("[plan]\n", "[plan]\nseed = 9007199254740993\n");
    let plan = dir.join("seed.toml");
    std::fs::write(&plan, text).unwrap();
    let out = dir.join("o");
    let o = plan_into(&plan, &out, &dir);
    assert_eq!(
        o.status.code().map(|c| c <= 1),
        Some(true),
        "{}",
        stderr(&o)
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    for case in results["cases"].as_array().unwrap() {
        let id = case["id"].as_str().unwrap();
        let sent = std::fs::read_to_string(format!("{}.{id}.json", log.display())).unwrap();
        let seed = case["seed"].as_u64().unwrap();
        assert!(
            sent.contains(&format!("\"seed\":{seed}")),
            "{sent} lacks seed {seed}"
        );
        let mode = std::fs::read_to_string(format!("{}.{id}.mode", log.display())).unwrap();
        assert_eq!(mode.trim(), "700");
        let scratch = std::fs::read_to_string(format!("{}.{id}.dir", log.display())).unwrap();
        assert!(
            !Path::new(scratch.trim()).exists(),
            "{scratch} was left behind"
        );
    }
}

#[test]
fn dates_and_source_date_epoch_are_validated() {
    let dir = scratch("robust-dates");
    let plan = small_plan(&dir, GRID);
    let out = dir.join("o");
    for date in ["2026-13-45", "2026-02-30", "0000-01-01"] {
        let o = ledflicker(
            &[
                "plan",
                plan.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--date",
                date,
            ],
            &dir,
        );
        assert_eq!(o.status.code(), Some(2), "{date}: {}", stderr(&o));
        assert!(stderr(&o).contains("is not a date"), "{}", stderr(&o));
    }
    for epoch in ["-1", "99999999999999", "1.5", ""] {
        let o = Command::new(exe())
            .env("LEDFLICKER_DB", crate::test_db())
            .args([
                "plan",
                plan.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .env("SOURCE_DATE_EPOCH", epoch)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{epoch}: {}", stderr(&o));
        assert!(stderr(&o).contains("SOURCE_DATE_EPOCH"), "{}", stderr(&o));
    }
    assert!(!out.exists());
}

#[test]
fn simulate_never_prints_nan() {
    let dir = scratch("robust-simulate");
    for args in [
        vec![
            "--frequency-hz",
            "1e300",
            "--duty",
            "0.5",
            "--exposure-ms",
            "10",
            "--fps",
            "30",
        ],
        vec![
            "--frequency-hz",
            "90",
            "--duty",
            "0.5",
            "--exposure-ms",
            "1e300",
            "--fps",
            "30",
        ],
        vec![
            "--frequency-hz",
            "90",
            "--duty",
            "0.5",
            "--exposure-ms",
            "10",
            "--fps",
            "1e-300",
        ],
        vec![
            "--frequency-hz",
            "90",
            "--duty",
            "0.5",
            "--exposure-ms",
            "10",
            "--fps",
            "30",
            "--pwm-delay-ms",
            "1e308",
        ],
    ] {
        let mut all = vec!["simulate"];
        all.extend(&args);
        let o = ledflicker(&all, &dir);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            !text.contains("NaN") && !text.contains("inf"),
            "{args:?}: {text}"
        );
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        all.push("--summary");
        let o = ledflicker(&all, &dir);
        assert!(!String::from_utf8_lossy(&o.stdout).contains("NaN"));
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

fn one_case_capture_plan(dir: &Path, source: &str) -> PathBuf {
    let text = format!(
        "[plan]\nid = \"t\"\ntitle = \"t\"\n[dut]\nbackend = \"captured\"\n[capture]\nframe-rate-fps = 30.0\n[[case]]\nsource = \"{source}\"\n[[roi]]\nname = \"a\"\nx-px = 0\ny-px = 0\nwidth-px = 2\nheight-px = 2\n"
    );
    let path = dir.join(format!("{source}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn expect_capture_error(dir: &Path, source: &str, needles: &[&str], absent: &[&str]) {
    let plan = one_case_capture_plan(dir, source);
    let o = plan_into(&plan, &dir.join("o"), dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{source}: {err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    for a in absent {
        assert!(!err.contains(a), "`{a}` echoed in: {err}");
    }
}

#[test]
fn corrupt_captures_name_the_line_or_frame_and_never_allocate_from_the_header() {
    let dir = scratch("robust-captures");
    // A Y4M header claiming a 2^31 x 2 frame: before, a 4 GiB allocation.
    let mut y4m = b"YUV4MPEG2 W2147483648 H2 F30:1 Cmono\nFRAME\n".to_vec();
    y4m.extend([0u8; 64]);
    std::fs::write(dir.join("huge.y4m"), &y4m).unwrap();
    expect_capture_error(&dir, "huge.y4m", &["huge.y4m", "claims 2147483648x2"], &[]);

    // Binary junk where frame 1's FRAME line should be.
    let mut y4m = b"YUV4MPEG2 W4 H4 F30:1 Cmono\nFRAME\n".to_vec();
    y4m.extend([7u8; 16]);
    y4m.extend([0xffu8, 0xfe, 0x00, 0x9c].repeat(8));
    std::fs::write(dir.join("junk.y4m"), &y4m).unwrap();
    expect_capture_error(&dir, "junk.y4m", &["junk.y4m", "frame 1"], &[]);

    // Binary junk in a CSV trace: before, "stream did not contain valid UTF-8".
    let mut csv = b"frame,time_s,a\n0,0.0,10\n1,0.033,12\n".to_vec();
    csv.extend(b"2,0.066,\xff\xfe\x00secret\n");
    std::fs::write(dir.join("junk.csv"), &csv).unwrap();
    expect_capture_error(
        &dir,
        "junk.csv",
        &["junk.csv", "line 4", "binary"],
        &["secret"],
    );

    // Reversed and duplicate timestamps name the frame.
    let mut rows = String::from("frame,time_s,a\n");
    for (k, t) in [0.0, 0.1, 0.2, 0.15, 0.3].iter().enumerate() {
        rows += &format!("{k},{t},10\n");
    }
    std::fs::write(dir.join("rev.csv"), &rows).unwrap();
    expect_capture_error(
        &dir,
        "rev.csv",
        &["rev.csv", "frame 3", "before frame 2"],
        &[],
    );
    std::fs::write(dir.join("dup.csv"), rows.replace("0.15", "0.2")).unwrap();
    expect_capture_error(&dir, "dup.csv", &["dup.csv", "frame 3", "the same as"], &[]);
}

#[test]
fn a_file_that_is_not_a_camera_profile_is_never_echoed() {
    let dir = scratch("robust-profile");
    for (name, body) in [
        (
            "secret.txt",
            "root:x:0:0:hunter2-PASSWORD:/root:/bin/bash\n",
        ),
        (
            "secret.toml",
            "password = \"hunter2-PASSWORD\"\n[db]\nuser = \"hunter2-PASSWORD\"\n",
        ),
        ("typed.toml", "camera = \"hunter2-PASSWORD\"\n"),
    ] {
        std::fs::write(dir.join(name), body).unwrap();
        let plan = small_plan(&dir, GRID);
        let text = std::fs::read_to_string(&plan).unwrap();
        let start = text.find("[dut.camera]").unwrap();
        let end = text.find("[thresholds]").unwrap();
        let text = format!(
            "{}camera-profile = \"{name}\"\n\n{}",
            &text[..start],
            &text[end..]
        );
        std::fs::write(&plan, text).unwrap();
        let o = ledflicker(&["validate", plan.to_str().unwrap()], &dir);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(name), "{err}");
        assert!(
            !err.contains("hunter2"),
            "the file's contents were echoed: {err}"
        );
    }
}
