//! `ledflicker bench --sweeps`: dense sweeps of 100 to 100,000 cases of a
//! small sensor, each run end to end by this binary as a separate process
//! (every output, default detail): wall time, peak memory and the run
//! stage's rate, beside the simulator's own rate with no store and no
//! report, so that a reader sees whether the store or the report limits a
//! sweep (docs/speed.md, "Where the time goes").

use std::path::Path;
use std::time::{Duration, Instant};

use super::Failure;
use super::endtoend::run_timed;
use super::output::outln;
use crate::bench::{SWEEP_DUTIES, sweep_plan};
use crate::runner::{CaseSink, RunError, RunOptions};

/// Case counts of the sweeps (`--quick`: the first two).
const SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];
/// Longest one sweep may take before its process group is killed.
const SWEEP_TIMEOUT: Duration = Duration::from_secs(1800);

/// A sink that keeps no case: the simulator's rate alone.
struct Discard;

impl CaseSink for Discard {
    type Error = RunError;
    type Item = ();

    fn prepare(_result: crate::model::CaseResult) {}

    fn put(&mut self, _position: usize, _item: ()) -> Result<(), RunError> {
        Ok(())
    }
}

/// The simulator's rate on the sweep in `plan_path`, cases a second: every
/// case simulated with its sample frame, as `plan` runs it, into no store.
fn simulator_rate(plan_path: &Path) -> Result<f64, String> {
    let plan = crate::plan::load(plan_path).map_err(|e| format!("{e:#}"))?;
    let cases = crate::plan::expand_cases(&plan);
    let simulator = crate::backend::sim::Simulator::new(&plan);
    let options = RunOptions {
        threads: None,
        sample_frames: true,
    };
    let started = Instant::now();
    crate::runner::run_streaming(&plan, &cases, &simulator, options, &|_| {}, &mut Discard)
        .map_err(|e| e.to_string())?;
    Ok(cases.len() as f64 / started.elapsed().as_secs_f64())
}

/// The "run cases" seconds of a `--timings` table: the first figure after
/// the name (the peak memory may follow it).
fn run_stage_s(timings: &str) -> Option<f64> {
    timings
        .lines()
        .find_map(|l| l.trim_start().strip_prefix("run cases"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Runs each sweep once and prints a row each, then the simulator's own
/// rate on the 10,000-case sweep (1,000 with `--quick`).
pub(super) fn bench_sweeps(quick: bool) -> Result<(), Failure> {
    let exe = std::env::current_exe()?;
    let scratch = tempfile::tempdir()?;
    let dir = scratch.path();
    let sizes = if quick { &SIZES[..2] } else { &SIZES[..] };
    outln!(
        "sweeps (16 x 12 sensor, 120 frames and 2 ROIs a case; this binary as a separate process, every output, default detail, {} threads):",
        rayon::current_num_threads()
    )?;
    outln!(
        "  {:>8}  {:>8}  {:>9}  {:>9}  {:>13}",
        "cases",
        "wall s",
        "peak MB",
        "run s",
        "run cases/s"
    )?;
    let mut rates = Vec::new();
    for &cases in sizes {
        let plan = dir.join(format!("sweep-{cases}.toml"));
        std::fs::write(&plan, sweep_plan(cases / SWEEP_DUTIES))?;
        let out = dir.join("report");
        let timings = dir.join("timings.txt");
        let args = [
            "plan",
            plan.to_str().unwrap_or_default(),
            "--out",
            out.to_str().unwrap_or_default(),
            "--no-db",
            "-q",
            "--force",
            "--timings",
            "--max-memory",
            "1TB",
            "--max-report",
            "1TB",
        ];
        let run = run_timed(&exe, &args, dir, SWEEP_TIMEOUT, Some(&timings))
            .map_err(Failure::Internal)?;
        if !matches!(run.code, Some(0 | 1)) {
            return Err(Failure::Internal(format!(
                "the sweep of {cases} cases exited with {:?}",
                run.code
            )));
        }
        let run_s = run_stage_s(&std::fs::read_to_string(&timings)?);
        let rate = run_s.map(|s| cases as f64 / s);
        rates.push((cases, rate));
        outln!(
            "  {cases:>8}  {:>8.1}  {:>9.0}  {:>9}  {:>13}",
            run.wall_s,
            run.peak_rss_bytes / 1e6,
            run_s.map_or("-".to_string(), |s| format!("{s:.2}")),
            rate.map_or("-".to_string(), |r| format!("{r:.0}")),
        )?;
        std::fs::remove_dir_all(&out)?;
    }
    let at = if quick { 1_000 } else { 10_000 };
    let plan = dir.join(format!("sweep-{at}.toml"));
    let alone = simulator_rate(&plan).map_err(Failure::Internal)?;
    outln!(
        "  the simulator alone on the {at}-case sweep (sample frames, no store, no report): {alone:.0} cases/s"
    )?;
    if let Some((_, Some(stored))) = rates.iter().find(|(n, _)| *n == at) {
        outln!(
            "  the run stage with the case store: {:.0} % of that rate",
            100.0 * stored / alone
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timings::{Span, table};

    #[test]
    fn the_run_stage_is_read_from_the_timings_table_with_or_without_the_memory_column() {
        let span = |name, seconds, peak_rss_bytes| Span {
            name,
            depth: 0,
            seconds,
            peak_rss_bytes,
        };
        for peak in [Some(486_100_000), None] {
            let text = table(&[
                span("load and validate plan", 0.002, peak),
                span("run cases", 0.074, peak),
                span("total", 1.604, peak),
            ]);
            assert_eq!(run_stage_s(&text), Some(0.074), "{text}");
        }
        assert_eq!(run_stage_s("timings (wall, seconds):\n"), None);
    }
}
