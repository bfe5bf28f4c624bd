//! `ledflicker bench --end-to-end`: whole runs as a user starts them. This
//! binary runs the shipped daylight plan and the P2020 sample plan (every
//! output, default detail) as separate processes, and the OpenCV reference
//! pipeline (`scripts/opencv_bench.py`) on the same three videos in the
//! same minute; it prints medians of wall time and peak memory and the
//! ratio to OpenCV.

use super::output::outln;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::Failure;
use crate::bench::median;
use crate::error::UsageError;

/// Longest any one timed run may take before its process group is killed.
const RUN_TIMEOUT: Duration = Duration::from_secs(300);

/// One finished child process.
#[derive(Debug, Clone, Copy)]
pub(super) struct Finished {
    /// Wall time, seconds.
    pub(super) wall_s: f64,
    /// Peak resident set size, bytes (`ru_maxrss`).
    pub(super) peak_rss_bytes: f64,
    /// Exit code; `None` when killed by a signal.
    pub(super) code: Option<i32>,
}

/// Runs `program args` in its own process group with no input and its
/// output discarded, or its standard error into the file `stderr`; kills
/// the group after `timeout` ([`RUN_TIMEOUT`] for the benchmarks). Wall
/// time and peak RSS come from `wait4`.
pub(super) fn run_timed(
    program: &Path,
    args: &[&str],
    dir: &Path,
    timeout: Duration,
    stderr: Option<&Path>,
) -> Result<Finished, String> {
    let name = program.display();
    let stderr = match stderr {
        Some(path) => std::fs::File::create(path)
            .map(Stdio::from)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?,
        None => Stdio::null(),
    };
    let child = Command::new(program)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        .process_group(0)
        .spawn()
        .map_err(|e| format!("cannot start {name}: {e}"))?;
    let pid = child.id() as libc::pid_t;
    let started = Instant::now();
    loop {
        let mut status = 0;
        // SAFETY: a zeroed rusage is a valid value for wait4 to fill.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `pid` is our child, not yet reaped; both pointers are to
        // live locals.
        let got = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if got == pid {
            return Ok(Finished {
                wall_s: started.elapsed().as_secs_f64(),
                peak_rss_bytes: usage.ru_maxrss as f64 * 1024.0,
                code: libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status)),
            });
        }
        if got < 0 {
            return Err(format!(
                "waiting for {name}: {}",
                std::io::Error::last_os_error()
            ));
        }
        if started.elapsed() > timeout {
            // SAFETY: signals the process group the child leads (started
            // with process_group(0)), then reaps the child.
            unsafe {
                libc::kill(-pid, libc::SIGKILL);
                libc::waitpid(pid, &mut status, 0);
            }
            return Err(format!(
                "{name} timed out after {:.1} s",
                timeout.as_secs_f64()
            ));
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// `reps` runs of `ledflicker plan PLAN` into a scratch report directory,
/// recorded in a scratch results database or (`record` false) in none; an
/// exit code other than 0 or 1 (pass or fail) is an error.
fn time_plan(
    exe: &Path,
    root: &Path,
    plan: &str,
    reps: usize,
    record: bool,
) -> Result<Vec<Finished>, String> {
    let scratch = tempfile::tempdir().map_err(|e| format!("no scratch directory: {e}"))?;
    let out = scratch.path().join("report");
    // Every run is recorded, as a user's is, but in a scratch database:
    // a benchmark is no run of the user's.
    let db = scratch.path().join("results.sqlite");
    let plan_path = root.join("test-plans").join(plan);
    let mut args = vec![
        "plan",
        plan_path.to_str().unwrap_or_default(),
        "--out",
        out.to_str().unwrap_or_default(),
        "-q",
        "--force",
    ];
    if record {
        args.extend(["--db", db.to_str().unwrap_or_default()]);
    } else {
        args.push("--no-db");
    }
    (0..reps)
        .map(|_| {
            let run = run_timed(exe, &args, root, RUN_TIMEOUT, None)?;
            match run.code {
                Some(0 | 1) => Ok(run),
                code => Err(format!("`ledflicker plan {plan}` exited with {code:?}")),
            }
        })
        .collect()
}

/// The OpenCV reference, `reps` times; `None` with the reason when Python
/// or OpenCV is missing.
fn time_opencv(root: &Path, reps: usize) -> Result<Vec<Finished>, String> {
    let python = PathBuf::from("python3");
    let probe = Command::new(&python)
        .args(["-c", "import cv2, numpy"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    if !probe.is_ok_and(|s| s.success()) {
        return Err(
            "python3 with cv2 and numpy not found (pip install opencv-python-headless numpy)"
                .into(),
        );
    }
    let script = root.join("scripts/opencv_bench.py");
    let script = script.to_str().unwrap_or_default();
    (0..reps)
        .map(|_| {
            let run = run_timed(&python, &[script], root, RUN_TIMEOUT, None)?;
            match run.code {
                Some(0) => Ok(run),
                code => Err(format!("scripts/opencv_bench.py exited with {code:?}")),
            }
        })
        .collect()
}

/// One line: median wall and peak RSS of `runs`, with the range.
fn describe(what: &str, runs: &[Finished]) -> String {
    let walls: Vec<f64> = runs.iter().map(|r| r.wall_s).collect();
    let rss: Vec<f64> = runs.iter().map(|r| r.peak_rss_bytes / 1e6).collect();
    let (lo, hi) = walls
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &w| {
            (a.min(w), b.max(w))
        });
    format!(
        "{what}: wall median {:.3} s (min {lo:.3}, max {hi:.3}), peak RSS median {:.0} MB, {} runs",
        median(walls.clone()),
        median(rss),
        runs.len()
    )
}

/// Times the daylight plan and the P2020 sample plan end to end, and the
/// OpenCV reference beside the P2020 plan; prints one line each and the
/// ratio.
pub(super) fn bench_end_to_end(quick: bool) -> Result<(), Failure> {
    let exe = std::env::current_exe()?;
    // The P2020 sample plan's videos and the OpenCV script are files of the
    // source tree: the bench runs from there, not from where it was built.
    let root = Path::new(".");
    if !root.join("scripts/opencv_bench.py").is_file()
        || !root.join("test-plans/p2020-samples.toml").is_file()
    {
        return Err(UsageError(
            "`bench --end-to-end` runs the sample plans and scripts of the ledflicker source tree\n    hint: run it from the root of a ledflicker checkout".to_string(),
        )
        .into());
    }
    let reps = if quick { 3 } else { 7 };
    outln!(
        "end to end (this binary as a separate process, all outputs, default detail, {} threads):",
        rayon::current_num_threads()
    )?;
    // Interleaved with runs that record nothing, so that both see the
    // same load: the cost of recording (docs/campaigns.md).
    let (mut daylight, mut unrecorded) = (Vec::new(), Vec::new());
    for _ in 0..reps {
        daylight
            .extend(time_plan(&exe, root, "daylight.toml", 1, true).map_err(Failure::Internal)?);
        unrecorded
            .extend(time_plan(&exe, root, "daylight.toml", 1, false).map_err(Failure::Internal)?);
    }
    outln!("  {}", describe("daylight plan (35 cases)", &daylight))?;
    outln!(
        "  {}",
        describe("daylight plan, --no-db (not recorded)", &unrecorded)
    )?;
    let cost = median(daylight.iter().map(|r| r.wall_s).collect())
        / median(unrecorded.iter().map(|r| r.wall_s).collect())
        - 1.0;
    outln!(
        "  recording in the results database: {:+.1} % of the daylight plan's median wall",
        100.0 * cost
    )?;
    let reps = if quick { 1 } else { 3 };
    // Interleaved, so that both see the same load.
    let mut ours = Vec::new();
    let mut peer = Vec::new();
    let mut peer_missing = None;
    for _ in 0..reps {
        ours.extend(
            time_plan(&exe, root, "p2020-samples.toml", 1, true).map_err(Failure::Internal)?,
        );
        if peer_missing.is_none() {
            match time_opencv(root, 1) {
                Ok(r) => peer.extend(r),
                Err(e) => peer_missing = Some(e),
            }
        }
    }
    outln!(
        "  {}",
        describe("P2020 sample plan (3 videos, 1,697 frames)", &ours)
    )?;
    match peer_missing {
        Some(e) => outln!("  OpenCV reference not measured: {e}")?,
        None => {
            outln!(
                "  {}",
                describe("OpenCV reference (scripts/opencv_bench.py)", &peer)
            )?;
            let ratio = median(peer.iter().map(|r| r.wall_s).collect())
                / median(ours.iter().map(|r| r.wall_s).collect());
            outln!(
                "  P2020 sample plan against the OpenCV reference: {ratio:.2}x (ratio of median walls)"
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str, timeout: Duration) -> Result<Finished, String> {
        run_timed(
            Path::new("sh"),
            &["-c", script],
            Path::new("."),
            timeout,
            None,
        )
    }

    #[test]
    fn a_run_reports_its_exit_code_wall_time_and_peak_memory() {
        let run = sh("exit 3", RUN_TIMEOUT).unwrap();
        assert_eq!(run.code, Some(3));
        assert!(run.wall_s > 0.0 && run.wall_s < RUN_TIMEOUT.as_secs_f64());
        // A shell holds at least a few hundred kB resident.
        assert!(run.peak_rss_bytes > 100e3, "{}", run.peak_rss_bytes);
        // Killed by a signal: no exit code.
        assert_eq!(sh("kill -9 $$", RUN_TIMEOUT).unwrap().code, None);
    }

    #[test]
    fn a_run_past_its_time_limit_is_killed_with_its_group() {
        let err = sh("sleep 30 & sleep 30", Duration::from_millis(300)).unwrap_err();
        assert!(err.contains("timed out after 0.3 s"), "{err}");
        let err = run_timed(
            Path::new("/nonexistent/ledflicker-peer"),
            &[],
            Path::new("."),
            RUN_TIMEOUT,
            None,
        )
        .unwrap_err();
        assert!(
            err.starts_with("cannot start /nonexistent/ledflicker-peer"),
            "{err}"
        );
    }

    #[test]
    fn the_line_gives_median_and_range() {
        let run = |wall_s: f64, mb: f64| Finished {
            wall_s,
            peak_rss_bytes: mb * 1e6,
            code: Some(0),
        };
        let line = describe("x", &[run(3.0, 90.0), run(1.0, 100.0), run(2.0, 95.0)]);
        assert_eq!(
            line,
            "x: wall median 2.000 s (min 1.000, max 3.000), peak RSS median 95 MB, 3 runs"
        );
    }
}
