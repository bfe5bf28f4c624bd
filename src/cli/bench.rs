//! `ledflicker bench`: speed against error of the integration methods,
//! whole-plan times, and the time of the analytic fine map for a plan's
//! camera (the measuring is in `crate::bench`; this prints it).

use super::output::outln;
use clap::Args;

use super::{ExitCode, Failure};
use crate::error::UsageError;
use crate::plan;

#[derive(Args, Debug)]
pub(super) struct BenchArgs {
    /// A CI-sized run (a few seconds).
    #[arg(long)]
    quick: bool,
    /// Plan file or name whose camera and first LED ROI the fine map uses.
    #[arg(default_value = "daylight")]
    plan: String,
    /// Timed repetitions of the fine map (>= 1); the median is reported.
    #[arg(long, default_value_t = 11)]
    repeat: usize,
    /// Also time `calibrate` on a synthetic 8K frame (7680 x 4320, 16-bit
    /// PNG; read, band estimate, fit, profile, closed loop), 5 runs.
    #[arg(long = "calibrate-8k")]
    calibrate_8k: bool,
    /// Also run the daylight plan and the P2020 sample plan end to end as
    /// separate processes (wall time and peak memory, medians), beside the
    /// OpenCV reference (scripts/opencv_bench.py) when Python has cv2.
    #[arg(long = "end-to-end")]
    end_to_end: bool,
    /// Also run sweeps of 100, 1,000, 10,000 and 100,000 cases (`--quick`:
    /// the first two) of a 16 x 12 sensor end to end as separate processes
    /// (wall time, peak memory, the run stage's rate) beside the
    /// simulator's own rate; the largest writes about 3.5 GB.
    #[arg(long)]
    sweeps: bool,
}

/// The numpy peer's figure on the exact-core grid, measured now, and the
/// batched core's ratio to it; a missing Python or numpy is said, not fatal.
fn print_peer_ratio(rows: &[crate::bench::BenchRow]) -> std::io::Result<()> {
    // The peer is a script of the source tree, not of an installed binary.
    let script = std::path::Path::new("scripts/peer_closedform.py");
    let Some(ours) = rows.iter().find(|r| r.method == "exact core, batched") else {
        return Ok(());
    };
    let ours = 1.0 / ours.time_s;
    match crate::bench::numpy_peer(script, std::time::Duration::from_secs(120)) {
        Ok(peer) => outln!(
            "numpy peer (scripts/peer_closedform.py, same grid): {peer:.2e} integrals/s; \
             exact core, batched: {ours:.2e} integrals/s = {:.1}x numpy",
            ours / peer
        ),
        Err(_) if !script.is_file() => outln!(
            "numpy peer not measured: no `{}` here (run `bench` from the ledflicker source tree to compare)",
            script.display()
        ),
        Err(e) => outln!("numpy peer not measured: {e} (pip install numpy to compare)"),
    }
}

pub(super) fn bench(a: BenchArgs) -> Result<ExitCode, Failure> {
    use crate::analysis::{FINE_DUTY, FINE_FREQUENCY, finemap};
    if a.repeat == 0 {
        return Err(UsageError("--repeat must be at least 1".into()).into());
    }
    outln!("{:<44} {:>14} {:>12}  note", "method", "time", "max error")?;
    let mut print_row = |r: &crate::bench::BenchRow| {
        let time = if r.time_s < 1e-6 {
            format!("{:.2} ns/{}", r.time_s * 1e9, r.per)
        } else if r.time_s < 1e-3 {
            format!("{:.3} us/{}", r.time_s * 1e6, r.per)
        } else {
            format!("{:.3} s/{}", r.time_s, r.per)
        };
        let err = r.max_error.map_or("-".to_string(), |e| format!("{e:.2e}"));
        // A write error other than a closed pipe (a full disk under a
        // redirect) shows again, and is returned, at the next line.
        let _ = outln!("{:<44} {:>14} {:>12}  {}", r.method, time, err, r.note);
    };
    let rows = crate::bench::run(a.quick, &mut print_row)
        .map_err(|e| Failure::Internal(format!("bench failed: {e}")))?;
    print_peer_ratio(&rows)?;
    let repeat = if a.quick { a.repeat.min(3) } else { a.repeat };
    let plan = plan::find_and_load(&a.plan)?;
    let roi = plan
        .rois
        .iter()
        .find(|r| r.kind == plan::RoiKind::Led)
        .ok_or_else(|| UsageError(format!("plan `{}` has no LED ROI", plan.id)))?;
    let shutter = plan.dut.camera.exposure_timing();
    let lux = plan.light_levels_lux.first().copied().unwrap_or(0.0);
    let luma = crate::analysis::ideal_luma_model(&plan, lux);
    let mut times: Vec<f64> = (0..repeat)
        .map(|_| {
            let t = std::time::Instant::now();
            let map = finemap::compute(&shutter, roi.rows(), luma, FINE_FREQUENCY, FINE_DUTY);
            std::hint::black_box(&map);
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let cells = FINE_FREQUENCY.count * FINE_DUTY.count;
    outln!(
        "fine map `{}` ({} rows of ROI `{}`): {} x {} = {cells} cells, {} threads; median {:.1} ms (min {:.1}, max {:.1}) over {} runs",
        plan.id,
        roi.rows().len(),
        roi.name,
        FINE_FREQUENCY.count,
        FINE_DUTY.count,
        rayon::current_num_threads(),
        1e3 * times[times.len() / 2],
        1e3 * times[0],
        1e3 * times[times.len() - 1],
        repeat
    )?;
    if a.calibrate_8k {
        let (t, rms) = crate::bench::calibrate_8k(5).map_err(|e| {
            Failure::Internal(format!("bench of calibrate on an 8K frame failed: {e}"))
        })?;
        outln!(
            "calibrate, one 8K frame (7680 x 4320, 16-bit PNG), {} threads: median {:.2} s (min {:.2}, max {:.2}) over {} runs; closed-loop profile_rms {rms:.4}",
            rayon::current_num_threads(),
            t[t.len() / 2],
            t[0],
            t[t.len() - 1],
            t.len()
        )?;
    }
    if a.end_to_end {
        super::endtoend::bench_end_to_end(a.quick)?;
    }
    if a.sweeps {
        super::sweeps::bench_sweeps(a.quick)?;
    }
    Ok(ExitCode::Pass)
}
