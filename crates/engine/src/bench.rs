//! `ledflicker bench`: speed against error for the ways of computing a
//! flicker trace, and the time of whole plans.
//!
//! Every row compares a method with the exact closed form on the same
//! randomly drawn conditions (fixed seed), and times it. Timings are medians
//! of several repetitions; the machine is noisy, so read ratios, not digits.

use std::time::Instant;

use ledflicker_core::physics::PwmDrive;
use ledflicker_core::physics::sensor::Rng;
use ledflicker_core::physics::shutter::{Shutter, ShutterModel};
use ledflicker_core::plan::{self, Plan};
use ledflicker_core::runner;

/// One row of the bench table.
#[derive(Debug, Clone)]
pub struct BenchRow {
    /// Method.
    pub method: String,
    /// Unit of `time_s`: "frame" or "case" or "plan".
    pub per: &'static str,
    /// Median time per unit, seconds.
    pub time_s: f64,
    /// Largest error against the exact result, in ON fraction (0..1);
    /// `None` for rows that are not compared.
    pub max_error: Option<f64>,
    /// What was measured.
    pub note: String,
}

/// A random condition: PWM, shutter, ROI rows.
struct Condition {
    pwm: PwmDrive,
    shutter: Shutter,
    rows: std::ops::Range<u32>,
}

fn conditions(n: usize) -> Vec<Condition> {
    let mut rng = Rng::new(2018);
    (0..n)
        .map(|_| {
            let f = 50.0 + rng.uniform() * 1950.0;
            let d = 0.05 + rng.uniform() * 0.9;
            let t = 1e-4 + rng.uniform() * 0.02;
            Condition {
                pwm: PwmDrive::new(f, d, rng.uniform() * 0.01).expect("valid drive"),
                shutter: Shutter {
                    model: ShutterModel::Rolling {
                        line_time_s: 14.565e-6,
                    },
                    exposure_s: t,
                    fps: 30.0,
                },
                rows: 399..401,
            }
        })
        .collect()
}

/// ON fraction of frame `frame` by time stepping with step `dt_s`
/// (midpoint samples), averaged over the ROI rows.
pub fn time_stepped_on_fraction(
    pwm: &PwmDrive,
    shutter: &Shutter,
    frame: u64,
    rows: std::ops::Range<u32>,
    dt_s: f64,
) -> f64 {
    let steps = (shutter.exposure_s / dt_s).ceil().max(1.0) as u64;
    let dt = shutter.exposure_s / steps as f64;
    let period = 1.0 / pwm.frequency_hz();
    let n = rows.len() as f64;
    let mut total = 0.0;
    for r in rows {
        let start = frame as f64 / shutter.fps + shutter.row_offset_s(r) - pwm.first_rise_s();
        let mut on = 0u64;
        for i in 0..steps {
            let t = start + (i as f64 + 0.5) * dt;
            let phase = (t / period).rem_euclid(1.0);
            if phase < pwm.duty() {
                on += 1;
            }
        }
        total += on as f64 / steps as f64;
    }
    total / n
}

/// Duty cycles of every benchmark sweep ([`sweep_plan`]): 10 % to 100 % in
/// steps of 10 %.
pub const SWEEP_DUTIES: usize = 10;

/// A sweep of `frequencies` x 10 duties (`frequencies` from 50 Hz in steps
/// of 5 Hz) on a 16 x 12 sensor, 120 frames a case and 2 ROIs: the shipped
/// 192-case grid's camera and scene, smaller.
pub fn sweep_plan(frequencies: usize) -> String {
    let grid = ledflicker_core::plan::shipped::PLANS
        .iter()
        .find(|p| p.path == "test-plans/grid-192.toml")
        .map_or("", |p| p.text);
    let list = |xs: Vec<String>| format!("[{}]", xs.join(", "));
    let freqs = list(
        (0..frequencies)
            .map(|i| format!("{}.0", 50 + 5 * i))
            .collect(),
    );
    let duties = list(
        (1..=SWEEP_DUTIES)
            .map(|i| format!("{:.1}", i as f64 / 10.0))
            .collect(),
    );
    let mut out = String::new();
    for line in grid.lines() {
        let line = match line.split(" = ").next().unwrap_or_default() {
            "id" => format!("id = \"sweep-{}\"", frequencies * SWEEP_DUTIES),
            "pwm-s" => "pwm-s = 3.0".to_string(),
            "frequencies-hz" => format!("frequencies-hz = {freqs}"),
            "duty-cycles" => format!("duty-cycles = {duties}"),
            "sensor-rows" => "sensor-rows = 12".to_string(),
            "sensor-columns" => "sensor-columns = 16".to_string(),
            "x-px" => "x-px = 2".to_string(),
            "y-px" => "y-px = 4".to_string(),
            "width-px" => "width-px = 10".to_string(),
            _ => line.to_string(),
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// Median of `xs` (the upper middle for an even count); NaN when empty.
pub fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs.get(xs.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Runs `f` `reps` times and returns the median wall time in seconds and
/// the last result.
fn timed<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::with_capacity(reps);
    let mut out = None;
    for _ in 0..reps {
        let t0 = Instant::now();
        out = Some(std::hint::black_box(f()));
        times.push(t0.elapsed().as_secs_f64());
    }
    (median(times), out.expect("reps >= 1"))
}

/// The plan the full-plan rows run: the daylight grid widened to at least
/// 100 cases (20 frequencies x 5 duty cycles) of 64 s at 30 fps, on the
/// given camera profile (`None`: the plan's own camera).
pub fn bench_plan(profile: Option<&str>) -> Result<Plan, plan::PlanError> {
    let daylight = plan::shipped::plan("daylight").ok_or_else(|| plan::PlanError::NotFound {
        name: "daylight".to_string(),
        tried: "the built-in plans".to_string(),
    })?;
    let mut text = daylight.text.replace(
        "frequencies-hz = [50.0, 90.0, 100.0, 150.0, 200.0, 500.0, 1000.0]",
        "frequency-range-hz = { start = 50.0, stop = 1000.0, step = 50.0 }",
    );
    if let Some(profile) = profile {
        let start = text.find("[dut.camera]").unwrap_or(text.len());
        let end = text[start..]
            .find("[scene]")
            .map_or(text.len(), |i| start + i);
        text.replace_range(start..end, "");
        text = text.replace(
            "backend = \"simulator\"",
            &format!("backend = \"simulator\"\ncamera-profile = \"{profile}\""),
        );
    }
    // Only the cases run, without a report: the report's memory limit does
    // not apply (docs/plan-format.md, "Limits").
    plan::parse_within(
        &text,
        std::path::Path::new(daylight.path),
        String::new(),
        false,
    )
}

/// Frequencies of the exact-core grid, Hz: the same grid as
/// scripts/peer_closedform.py.
pub const CORE_FREQUENCIES_HZ: [f64; 12] = [
    50.0, 60.0, 75.0, 90.0, 100.0, 120.0, 150.0, 200.0, 300.0, 400.0, 600.0, 1000.0,
];
/// Duty cycles of the exact-core grid.
pub const CORE_DUTIES: [f64; 6] = [0.05, 0.1, 0.2, 0.3, 0.5, 0.8];
/// Frames per condition of the exact-core grid (64 s at 30 fps).
pub const CORE_FRAMES: u64 = 1920;
/// ROI rows of the exact-core grid: two rows of a rolling shutter.
const CORE_ROWS: std::ops::Range<u32> = 399..401;

/// The exact-core grid: 12 frequencies x 6 duty cycles, each a 2-row
/// rolling-shutter ROI (14.565 us per line) with 5 ms exposures at 30 fps
/// and the first rising edge 0.1234 ms into frame 0.
fn core_grid() -> Vec<(PwmDrive, Shutter)> {
    let shutter = Shutter {
        model: ShutterModel::Rolling {
            line_time_s: 14.565e-6,
        },
        exposure_s: 5e-3,
        fps: 30.0,
    };
    CORE_FREQUENCIES_HZ
        .iter()
        .flat_map(|&f| {
            CORE_DUTIES
                .iter()
                .map(move |&d| (PwmDrive::new(f, d, 1.234e-4).expect("valid drive"), shutter))
        })
        .collect()
}

/// Row integrals in one pass over the exact-core grid.
pub fn core_integrals() -> usize {
    CORE_FREQUENCIES_HZ.len() * CORE_DUTIES.len() * CORE_FRAMES as usize * CORE_ROWS.len()
}

/// Times the exact closed form on the exact-core grid, single threaded:
/// the batched kernel ([`Shutter::frame_on_fractions`]) and the per-frame
/// call it replaces. Both rows give the time per row integral; the batched
/// row's error is its largest difference from the per-frame values. Each
/// is run once untimed first, as the numpy peer is, so that the median of
/// a short (`--quick`) run does not include first-touch page faults.
pub fn exact_core(reps: usize) -> [BenchRow; 2] {
    let grid = core_grid();
    let n = core_integrals() as f64;
    let batch = || {
        let mut out = Vec::with_capacity(grid.len() * CORE_FRAMES as usize);
        for (pwm, shutter) in &grid {
            shutter.frame_on_fractions(pwm, 0..CORE_FRAMES, CORE_ROWS, &mut out);
        }
        out
    };
    std::hint::black_box(batch());
    let (t_batch, batched) = timed(reps, batch);
    let frame_by_frame = || {
        grid.iter()
            .flat_map(|(pwm, shutter)| {
                (0..CORE_FRAMES).map(move |k| shutter.frame_on_fraction(pwm, k, CORE_ROWS))
            })
            .collect::<Vec<_>>()
    };
    std::hint::black_box(frame_by_frame());
    let (t_frame, per_frame) = timed(reps, frame_by_frame);
    let err = batched
        .iter()
        .zip(&per_frame)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let note = |t: f64| {
        format!(
            "{:.2e} integrals/s; 12 f x 6 D x {CORE_FRAMES} frames x 2 rows, 1 thread",
            n / t
        )
    };
    [
        BenchRow {
            method: "exact core, batched".into(),
            per: "integral",
            time_s: t_batch / n,
            max_error: Some(err),
            note: note(t_batch),
        },
        BenchRow {
            method: "exact core, frame by frame".into(),
            per: "integral",
            time_s: t_frame / n,
            max_error: Some(0.0),
            note: note(t_frame),
        },
    ]
}

/// Runs the numpy peer (scripts/peer_closedform.py) and returns its row
/// integrals per second. The script runs in its own process group, is killed
/// after `timeout`, and only its first 64 KiB of output are read.
pub fn numpy_peer(script: &std::path::Path, timeout: std::time::Duration) -> Result<f64, String> {
    use std::io::Read;
    use std::os::unix::process::CommandExt;
    use std::process::{Command, Stdio};
    if !script.is_file() {
        return Err(format!("{} not found", script.display()));
    }
    let mut child = Command::new("python3")
        .arg(script)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .process_group(0)
        .spawn()
        .map_err(|e| format!("cannot start python3: {e}"))?;
    let started = Instant::now();
    let status = loop {
        match child.try_wait().map_err(|e| e.to_string())? {
            Some(status) => break status,
            None if started.elapsed() > timeout => {
                // The group, so that anything the script started goes too.
                let _ = Command::new("kill")
                    .args(["-KILL", "--", &format!("-{}", child.id())])
                    .status();
                let _ = child.wait();
                return Err(format!("timed out after {} s", timeout.as_secs()));
            }
            None => std::thread::sleep(std::time::Duration::from_millis(20)),
        }
    };
    let mut text = String::new();
    if let Some(out) = child.stdout.take() {
        let _ = out.take(64 * 1024).read_to_string(&mut text);
    }
    if !status.success() {
        return Err(match status.code() {
            Some(3) => "numpy not found".into(),
            _ => format!("python3 exited with {status}"),
        });
    }
    text.lines()
        .find_map(|l| l.strip_prefix("integrals_per_s="))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| "no integrals_per_s line in its output".into())
}

/// The 8K calibration scene of `ledflicker bench --calibrate-8k` and
/// `cargo bench --bench calibrate`: a 7680 x 4320 16-bit PNG of a 1 kHz,
/// 50 % LED seen by a sensor reading 4320 rows in 15.7 ms, with noise and
/// vignetting. Writes it to `path`.
pub fn write_8k_frame(path: &std::path::Path) -> Result<(), String> {
    ledflicker_core::calibrate::synth::SynthFrame {
        width: 7680,
        height: 4320,
        line_time_s: 3.641e-6,
        noise_dn: 200.0,
        vignetting: 0.3,
        bits16: true,
        ..ledflicker_core::calibrate::synth::SynthFrame::base()
    }
    .save(path, 90)
}

/// One `calibrate` of the 8K frame at `frame`, as the command runs it:
/// read the frame, estimate the bands, fit the camera, write the profile to
/// `profile_out`, and close the loop through the simulator (all 4320 rows).
/// Returns the closed-loop `profile_rms`.
pub fn calibrate_8k_once(
    frame: &std::path::Path,
    profile_out: &std::path::Path,
) -> Result<f64, String> {
    use ledflicker_core::calibrate::profile::{self, ProfileOptions};
    let set = ledflicker_core::calibrate::frames::load(
        std::slice::from_ref(&frame.to_path_buf()),
        None,
        None,
    )
    .map_err(|e| e.to_string())?;
    let light = ledflicker_core::calibrate::Light {
        frequency_hz: 1000.0,
        frequency_sigma_hz: 0.0,
        duty: None,
    };
    let cal = ledflicker_core::calibrate::calibrate(&set, light).map_err(|e| e.to_string())?;
    let opts = ProfileOptions {
        name: "bench".to_string(),
        fps: None,
    };
    std::fs::write(profile_out, profile::profile_toml(&cal, &opts)).map_err(|e| e.to_string())?;
    let fps = profile::frame_rate(&cal, &opts);
    profile::closed_loop(&cal, profile_out, fps).map(|(_, rms)| rms)
}

/// Wall times, seconds, of `reps` runs of [`calibrate_8k_once`] (sorted),
/// and the closed-loop `profile_rms` of the last run.
pub fn calibrate_8k(reps: usize) -> Result<(Vec<f64>, f64), String> {
    let dir = tempfile::Builder::new()
        .prefix("ledflicker-bench-8k-")
        .tempdir()
        .map_err(|e| e.to_string())?;
    let frame = dir.path().join("frame-8k.png");
    write_8k_frame(&frame)?;
    let out = dir.path().join("profile.toml");
    let mut times = Vec::with_capacity(reps);
    let mut rms = f64::NAN;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        rms = calibrate_8k_once(&frame, &out)?;
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok((times, rms))
}

/// The rows so far, each handed to `on_row` as it is measured.
struct Table<'a> {
    rows: Vec<BenchRow>,
    on_row: &'a mut dyn FnMut(&BenchRow),
}

impl Table<'_> {
    fn push(&mut self, row: BenchRow) {
        (self.on_row)(&row);
        self.rows.push(row);
    }
}

/// How much a run measures: `quick` is CI-sized.
struct Size {
    conditions: usize,
    frames: usize,
    reps: usize,
}

/// Runs the bench. `quick` makes it CI-sized (a few seconds).
pub fn run(
    quick: bool,
    on_row: &mut dyn FnMut(&BenchRow),
) -> Result<Vec<BenchRow>, Box<dyn std::error::Error>> {
    let size = if quick {
        Size {
            conditions: 8,
            frames: 60,
            reps: 3,
        }
    } else {
        Size {
            conditions: 40,
            frames: 300,
            reps: 5,
        }
    };
    let conds = conditions(size.conditions);
    let mut table = Table {
        rows: Vec::new(),
        on_row,
    };
    // The grid takes well under a millisecond per pass: 9 repetitions cost
    // nothing even in a quick run and steady its median.
    for row in exact_core(9) {
        table.push(row);
    }
    trace_rows(&conds, &size, &mut table);
    phase_rows(&conds, &size, &mut table);
    plan_rows(quick, &mut table)?;
    Ok(table.rows)
}

/// The exact closed form per frame, then time stepping at three steps
/// against it.
fn trace_rows(conds: &[Condition], size: &Size, table: &mut Table<'_>) {
    let (n_cond, frames, reps) = (size.conditions, size.frames, size.reps);
    let n_frames = (n_cond * frames) as f64;
    let (t_exact, exact) = timed(reps, || {
        conds
            .iter()
            .map(|c| {
                (0..frames as u64)
                    .map(|k| c.shutter.frame_on_fraction(&c.pwm, k, c.rows.clone()))
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>()
    });
    table.push(BenchRow {
        method: "exact closed form".into(),
        per: "frame",
        time_s: t_exact / n_frames,
        max_error: Some(0.0),
        note: format!("{n_cond} conditions x {frames} frames, 2-row rolling ROI"),
    });

    for dt in [100e-6, 10e-6, 1e-6] {
        let reps_here = if dt < 5e-6 { 1 } else { reps };
        let (t, stepped) = timed(reps_here, || {
            conds
                .iter()
                .map(|c| {
                    (0..frames as u64)
                        .map(|k| {
                            time_stepped_on_fraction(&c.pwm, &c.shutter, k, c.rows.clone(), dt)
                        })
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        });
        let err = exact
            .iter()
            .flatten()
            .zip(stepped.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        table.push(BenchRow {
            method: format!("time-stepped, {} us", dt * 1e6),
            per: "frame",
            time_s: t / n_frames,
            max_error: Some(err),
            note: "midpoint samples of the square wave".into(),
        });
    }
}

/// The exact worst case over the PWM phase, then phase sweeps of three
/// sizes against it.
fn phase_rows(conds: &[Condition], size: &Size, table: &mut Table<'_>) {
    let (n_cond, reps) = (size.conditions, size.reps);
    let exact_worst: Vec<(f64, f64)> = conds
        .iter()
        .map(|c| c.shutter.phase_envelope(&c.pwm, c.rows.clone()))
        .collect();
    let (t_env, _) = timed(reps, || {
        conds
            .iter()
            .map(|c| c.shutter.phase_envelope(&c.pwm, c.rows.clone()))
            .collect::<Vec<_>>()
    });
    table.push(BenchRow {
        method: "exact worst case over phase".into(),
        per: "case",
        time_s: t_env / n_cond as f64,
        max_error: Some(0.0),
        note: "corners of the piecewise-linear response".into(),
    });
    for n in [16usize, 64, 256] {
        let (t, swept) = timed(reps, || {
            conds
                .iter()
                .map(|c| {
                    let f = c.pwm.frequency_hz();
                    let mut lo = f64::INFINITY;
                    let mut hi = f64::NEG_INFINITY;
                    for i in 0..n {
                        let pwm = PwmDrive::new(f, c.pwm.duty(), -(i as f64 / n as f64) / f)
                            .expect("valid drive");
                        let v = c.shutter.frame_on_fraction(&pwm, 0, c.rows.clone());
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                    (lo, hi)
                })
                .collect::<Vec<_>>()
        });
        let err = exact_worst
            .iter()
            .zip(&swept)
            .map(|(e, s)| (s.0 - e.0).abs().max((e.1 - s.1).abs()))
            .fold(0.0, f64::max);
        table.push(BenchRow {
            method: format!("phase sweep, {n} phases"),
            per: "case",
            time_s: t / n_cond as f64,
            max_error: Some(err),
            note: "min/max over sampled phases vs exact".into(),
        });
    }
}

/// Whole-plan times of the bench plan on two camera profiles.
fn plan_rows(quick: bool, table: &mut Table<'_>) -> Result<(), Box<dyn std::error::Error>> {
    for (label, profile) in [
        (
            "daylight plan, ideal rolling profile",
            "reference-data/cameras/ideal-rolling.toml",
        ),
        (
            "daylight plan, 3-capture HDR + AE profile",
            "reference-data/cameras/deegan2018-hdr3.toml",
        ),
    ] {
        let plan = bench_plan(Some(profile))?;
        let cases = plan::expand_cases(&plan);
        let backend = ledflicker_core::backend::for_plan(&plan, None)?;
        let (t, results) = timed(if quick { 1 } else { 3 }, || {
            runner::run(&plan, &cases, &backend, None, &|_| {})
        });
        results?;
        let frames =
            ledflicker_core::backend::sim::SegmentFrames::new(&plan.sequence, plan.dut.camera.fps)
                .total();
        table.push(BenchRow {
            method: label.into(),
            per: "plan",
            time_s: t,
            max_error: None,
            note: format!(
                "{} cases x {frames} frames ({} s at {} fps), {} threads",
                cases.len(),
                plan.sequence.on_s + plan.sequence.off_s + plan.sequence.pwm_s,
                plan.dut.camera.fps,
                rayon::current_num_threads()
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_stepping_converges_to_the_closed_form() {
        let c = &conditions(3)[1];
        let exact = c.shutter.frame_on_fraction(&c.pwm, 5, c.rows.clone());
        let coarse =
            (time_stepped_on_fraction(&c.pwm, &c.shutter, 5, c.rows.clone(), 100e-6) - exact).abs();
        let fine =
            (time_stepped_on_fraction(&c.pwm, &c.shutter, 5, c.rows.clone(), 1e-6) - exact).abs();
        // Midpoint sampling errs by at most two samples per edge crossing.
        let steps = (c.shutter.exposure_s / 1e-6).ceil();
        assert!(fine <= 2.0 * 2.0 / steps + 1e-12, "{fine}");
        assert!(fine <= coarse + 1e-12);
    }

    /// The ratio printed by `bench` means something only if the numpy peer
    /// computes the same grid: read the script's constants and compare.
    #[test]
    fn core_grid_is_the_numpy_peers_grid() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scripts/peer_closedform.py");
        let text = std::fs::read_to_string(path).unwrap();
        let numbers = |name: &str| -> Vec<f64> {
            let line = text
                .lines()
                .find_map(|l| l.strip_prefix(&format!("{name} = ")))
                .unwrap_or_else(|| panic!("no `{name} = ` line"));
            let inner = match (line.find('['), line.find(']')) {
                (Some(a), Some(b)) => &line[a + 1..b],
                _ => line,
            };
            inner
                .split(',')
                .map(|t| {
                    t.trim()
                        .parse::<f64>()
                        .unwrap_or_else(|_| panic!("{name}: {t}"))
                })
                .collect()
        };
        let grid = core_grid();
        let (pwm, shutter) = grid[0];
        assert_eq!(numbers("FREQS"), CORE_FREQUENCIES_HZ);
        assert_eq!(numbers("DUTIES"), CORE_DUTIES);
        assert_eq!(numbers("FRAMES"), [CORE_FRAMES as f64]);
        let rows: Vec<f64> = CORE_ROWS.map(f64::from).collect();
        assert_eq!(numbers("ROWS"), rows);
        assert_eq!(numbers("FPS"), [shutter.fps]);
        assert_eq!(numbers("EXPOSURE_S"), [shutter.exposure_s]);
        assert_eq!(numbers("DELAY_S"), [pwm.first_rise_s()]);
        let ShutterModel::Rolling { line_time_s } = shutter.model else {
            panic!("the core grid is a rolling shutter");
        };
        assert_eq!(numbers("LINE_S"), [line_time_s]);
        assert_eq!(grid.len(), CORE_FREQUENCIES_HZ.len() * CORE_DUTIES.len());
        assert!(grid.iter().all(|(_, s)| *s == shutter));
        assert_eq!(core_integrals(), 12 * 6 * 1920 * 2);
    }

    #[test]
    fn bench_plan_has_at_least_100_cases_of_64_s() {
        let plan = bench_plan(Some("reference-data/cameras/deegan2018-hdr3.toml")).unwrap();
        assert!(plan::expand_cases(&plan).len() >= 100);
        let s = plan.sequence;
        assert_eq!(s.on_s + s.off_s + s.pwm_s, 64.0);
        assert!(plan.dut.camera.physical.is_some());
    }
}
