//! The case store: a run killed with SIGKILL half way resumes with
//! `plan --resume`, runs only the cases it had not stored, and writes the
//! very bytes of an uninterrupted run.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use super::{root, scratch, stderr};

/// A lab rig (the example rig's rendering) that counts its calls and, from
/// the fifth on, waits for a `go` file: the run stalls half way, with four
/// of its eight cases finished.
fn rig(dir: &Path) -> PathBuf {
    let d = dir.display();
    let script = format!(
        r#"#!/bin/sh
set -eu
n=$(cat "{d}/calls" 2>/dev/null || echo 0)
n=$((n + 1))
echo "$n" > "{d}/calls"
if [ "$n" -gt 4 ] && [ ! -e "{d}/go" ]; then
  touch "{d}/blocked"
  i=0
  while [ ! -e "{d}/go" ] && [ "$i" -lt 600 ]; do
    [ -e "{d}/stop" ] && exit 1
    sleep 0.1; i=$((i + 1))
  done
fi
cat > "$LEDFLICKER_OUT_DIR.json"
exec "$LEDFLICKER_EXE" render \
    --frequency-hz "$LEDFLICKER_FREQUENCY_HZ" --duty "$LEDFLICKER_DUTY" \
    --fps "$LEDFLICKER_FRAME_RATE_FPS" --exposure-ms 11.111 \
    --shutter rolling --line-time-us 14.565 \
    --on-s "$LEDFLICKER_ON_S" --off-s "$LEDFLICKER_OFF_S" --pwm-s "$LEDFLICKER_PWM_S" \
    --width 64 --height 48 --out "$LEDFLICKER_OUT_DIR"
"#
    );
    let path = dir.join("rig.sh");
    std::fs::write(&path, script).unwrap();
    path
}

/// Stops a run and its stalled rig when a test ends, passed or failed: no
/// process of the test is left to print into the terminal later.
struct Stop<'a> {
    dir: &'a Path,
    child: Option<std::process::Child>,
}

impl Drop for Stop<'_> {
    fn drop(&mut self) {
        let _ = std::fs::write(self.dir.join("stop"), "");
        if let Some(child) = &mut self.child {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The shipped rig plan with eight cases, on [`rig`].
fn plan(dir: &Path) -> PathBuf {
    let base = std::fs::read_to_string(root().join("test-plans/command-sim-rig.toml")).unwrap();
    let text = base
        .replace(
            "frequencies-hz = [90.0, 137.0]",
            "frequencies-hz = [90.0, 137.0, 200.0, 300.0]",
        )
        .replace(
            "command = [\"sh\", \"../examples/sim-rig.sh\"]",
            &format!("command = [\"sh\", \"{}\"]", rig(dir).display()),
        );
    assert!(text.contains("300.0]") && text.contains("rig.sh"));
    let path = dir.join("p.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn plan_command(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ledflicker"));
    c.env("LEDFLICKER_DB", crate::test_db())
        .arg("plan")
        .arg(dir.join("p.toml"))
        .args(["--date", "2026-01-01", "-q", "--threads", "1"])
        .args(args)
        .current_dir(dir)
        .env_remove("SOURCE_DATE_EPOCH");
    c
}

/// Cases stored in the partial store beside `out`, once there is one.
fn stored_cases(dir: &Path, out: &str) -> Option<i64> {
    let prefix = format!(".{out}.ledflicker-new-");
    let staging = std::fs::read_dir(dir)
        .ok()?
        .flatten()
        .find(|e| e.file_name().to_string_lossy().starts_with(&prefix))?;
    let db = staging.path().join(ledflicker::store::PARTIAL);
    let conn =
        rusqlite::Connection::open_with_flags(db, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .ok()?;
    conn.query_row("SELECT count(*) FROM cases", [], |r| r.get(0))
        .ok()
}

/// Every file under `dir`, by relative path, with its bytes.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                todo.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                files.push((p.strip_prefix(dir).unwrap().to_path_buf(), bytes));
            }
        }
    }
    files.sort();
    files
}

#[test]
fn a_run_killed_half_way_resumes_to_the_bytes_of_an_uninterrupted_run() {
    let dir = scratch("store-resume");
    plan(&dir);
    std::fs::write(dir.join("go"), "").unwrap();
    let whole = plan_command(&dir, &["--out", "whole"]).output().unwrap();
    assert!(
        matches!(whole.status.code(), Some(0 | 1)),
        "{}",
        stderr(&whole)
    );
    assert!(dir.join("whole").join(ledflicker::store::FILE).is_file());

    std::fs::remove_file(dir.join("go")).unwrap();
    std::fs::remove_file(dir.join("calls")).unwrap();
    let mut stop = Stop {
        dir: &dir,
        child: Some(plan_command(&dir, &["--out", "killed"]).spawn().unwrap()),
    };
    let start = Instant::now();
    // Four cases stored and the fifth stalled in the rig, whichever of the
    // two happens first, then SIGKILL.
    while stored_cases(&dir, "killed") != Some(4) || !dir.join("blocked").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the run did not store four cases and stall on the fifth: {:?} stored",
            stored_cases(&dir, "killed")
        );
        let child = stop.child.as_mut().unwrap();
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut child = stop.child.take().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    std::fs::write(dir.join("go"), "").unwrap();
    assert!(!dir.join("killed").exists(), "nothing in --out yet");

    let resumed = plan_command(&dir, &["--resume", "killed"])
        .output()
        .unwrap();
    assert_eq!(
        resumed.status.code(),
        whole.status.code(),
        "{}",
        stderr(&resumed)
    );
    let calls = std::fs::read_to_string(dir.join("calls")).unwrap();
    assert_eq!(
        calls.trim(),
        "9",
        "five rig calls before the kill, then only the four cases not stored"
    );
    let (a, b) = (tree(&dir.join("whole")), tree(&dir.join("killed")));
    assert_eq!(
        a.iter().map(|(p, _)| p).collect::<Vec<_>>(),
        b.iter().map(|(p, _)| p).collect::<Vec<_>>()
    );
    for ((path, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs after the resume", path.display());
    }
}

#[test]
fn resume_refuses_another_plan_and_a_directory_with_nothing_to_resume() {
    let dir = scratch("store-refuse");
    plan(&dir);
    let o = plan_command(&dir, &["--resume", "nothing"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no interrupted run"), "{}", stderr(&o));

    // A store left by a run of another plan (another seed).
    std::fs::remove_file(dir.join("calls")).ok();
    let mut child = plan_command(&dir, &["--out", "other"]).spawn().unwrap();
    let start = Instant::now();
    while stored_cases(&dir, "other") != Some(4) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no four cases stored"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    std::fs::write(dir.join("go"), "").unwrap();
    let p = dir.join("p.toml");
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(&p, text.replace("[plan]\n", "[plan]\nseed = 7\n")).unwrap();
    let o = plan_command(&dir, &["--resume", "other"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot be resumed") && stderr(&o).contains("plan_hash"),
        "{}",
        stderr(&o)
    );
    // Resuming again with this plan would fail the same way: the advice
    // is to use the plan that made the store, or start afresh.
    assert!(
        stderr(&o).contains("another run's") && !stderr(&o).contains("continue the run with"),
        "{}",
        stderr(&o)
    );
}

/// A simulated sweep of 40 small cases whose report stage (the PDF) is
/// most of its wall time.
fn sweep(dir: &Path) -> PathBuf {
    let grid = "frequencies-hz = [90.0, 110.0, 130.0, 150.0, 170.0, 190.0, 210.0, 230.0]\nduty-cycles = [0.1, 0.2, 0.3, 0.5, 0.7]";
    let small = crate::robust::small_plan(dir, grid);
    let text = std::fs::read_to_string(small)
        .unwrap()
        .replace("fdi-2018-min = 0.1", "fdi-2018-min = 0.6");
    assert!(text.contains("230.0]") && text.contains("fdi-2018-min = 0.6"));
    let path = dir.join("p.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_sweep_stopped_at_any_instant_of_either_stage_resumes_to_the_bytes_of_an_uninterrupted_run() {
    let dir = scratch("store-any-instant");
    sweep(&dir);
    let started = Instant::now();
    let whole = plan_command(&dir, &["--out", "whole"]).output().unwrap();
    let wall = started.elapsed();
    assert!(
        matches!(whole.status.code(), Some(0 | 1)),
        "{}",
        stderr(&whole)
    );
    let expected = tree(&dir.join("whole"));
    // Instants spread over the whole run, run stage and report stage (a
    // fixed pseudo-random sequence, so that a failure repeats), each with
    // SIGKILL or SIGINT.
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    for round in 0..6 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let at = wall.mul_f64(0.05 + 0.9 * (state % 1000) as f64 / 1000.0);
        let signal = if round % 2 == 0 {
            libc::SIGKILL
        } else {
            libc::SIGINT
        };
        let out = format!("k{round}");
        let mut child = plan_command(&dir, &["--out", &out])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(at);
        unsafe { libc::kill(child.id() as i32, signal) };
        child.wait().unwrap();
        // Resume until the report is there (a stop before any case was
        // stored leaves nothing to resume: the plan is run afresh).
        let mut tries = 0;
        while !dir.join(&out).join("results.json").is_file() {
            tries += 1;
            assert!(tries <= 2, "round {round}: no report after resuming");
            let o = plan_command(&dir, &["--resume", &out]).output().unwrap();
            if o.status.code() == Some(2) && stderr(&o).contains("no interrupted run") {
                let o = plan_command(&dir, &["--out", &out]).output().unwrap();
                assert_eq!(o.status.code(), whole.status.code(), "{}", stderr(&o));
            } else {
                assert_eq!(
                    o.status.code(),
                    whole.status.code(),
                    "round {round} (stopped at {at:?} of {wall:?}): {}",
                    stderr(&o)
                );
            }
        }
        let got = tree(&dir.join(&out));
        assert_eq!(
            got.iter().map(|(p, _)| p).collect::<Vec<_>>(),
            expected.iter().map(|(p, _)| p).collect::<Vec<_>>(),
            "round {round}"
        );
        for ((path, x), (_, y)) in expected.iter().zip(&got) {
            assert!(
                x == y,
                "round {round}: {} differs after the resume",
                path.display()
            );
        }
    }
}
