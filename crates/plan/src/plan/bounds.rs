//! Physical bounds, the work estimate and unique case ids: the checks a
//! plan passes after [`super::validate`], so that a plan `validate` accepts
//! runs in bounded time, memory and disk space.
//!
//! ResourceLimits are documented in docs/plan-format.md, "ResourceLimits". The estimate is
//! an upper bound calibrated on the simulator (see [`WorkEstimate`]).

use super::spans::SpanIndex;
use super::{BackendKind, Diagnostic, Plan, TestCase};

/// Highest PWM frequency, Hz. Automotive LED drivers run at up to a few
/// tens of kHz; the ideal camera's closed-form integral is exact at any
/// frequency, but above this the figures only say "steady light".
pub const MAX_FREQUENCY_HZ: f64 = 1.0e6;
/// Highest ambient illuminance, lux (direct sunlight is about 1e5 lux).
pub const MAX_LIGHT_LUX: f64 = 2.0e5;
/// Shortest exposure, seconds (1 us).
pub const MIN_EXPOSURE_S: f64 = 1.0e-6;
/// Highest frame rate, frames per second.
pub const MAX_FPS: f64 = 1000.0;
/// Largest sensor side, pixels.
pub const MAX_SENSOR_SIDE: u32 = 16_384;
/// Largest sensor, pixels (an 8K sensor is 33.2 Mpx).
pub const MAX_SENSOR_PIXELS: u64 = 40_000_000;
/// Most frames in one case (55 min at 30 fps).
pub const MAX_FRAMES_PER_CASE: u64 = 100_000;
/// Most row integrals in a run: cases x frames x ROI rows. At about 10 M
/// row integrals per second and core this is an hour on 2 cores.
pub const MAX_ROW_INTEGRALS: f64 = 5.0e10;
/// Largest estimated peak memory of a run by default, bytes
/// (`--max-memory` raises it).
pub const MAX_MEMORY_BYTES: f64 = 1.0e9;
/// Largest estimated report directory by default, bytes (`--max-report`
/// raises it).
pub const MAX_OUTPUT_BYTES: f64 = 2.0e9;

/// Lowest ambient illuminance, lux: a moonless, overcast night is about
/// 1e-4 lux, and a case id (6 decimals) still names it.
pub const MIN_LIGHT_LUX: f64 = 1.0e-4;
/// Lowest duty cycle: finer than the step of a 20-bit PWM counter, and a
/// case id (percent, 6 decimals) still names it.
pub const MIN_DUTY: f64 = 1.0e-6;
/// Lowest frame rate, frames per second: a slower camera takes stills,
/// and at 1 fps the sequence's frame limit is already a day long.
pub const MIN_FPS: f64 = 1.0;
/// Largest PWM delay either way, seconds (`simulate --pwm-delay-ms` has
/// the same bound). The phase of the PWM is the delay times the frequency
/// in cycles; within 1000 s at 1 MHz f64 keeps it to 1e-7 of a cycle, and
/// a delay of more than a period is the same as its remainder.
pub const MAX_PWM_DELAY_S: f64 = 1000.0;
/// The ideal camera's response, DN per cd/m^2 per second of exposure: the
/// reference cameras use 1 to 300. Within this range the brightest scene
/// (1e9 cd/m^2 for a 1 s exposure) stays finite and the darkest above
/// f64's subnormal numbers.
pub const RESPONSE_RANGE: (f64, f64) = (1.0e-6, 1.0e6);
/// Output full scale, DN: 1 DN up to a 24-bit output.
pub const FULL_SCALE_DN_RANGE: (f64, f64) = (1.0, 16_777_215.0);
/// Highest LED luminance, cd/m^2: the sun's disc is 1.6e9.
pub const MAX_LUMINANCE_CD_M2: f64 = 1.0e9;
/// Analogue gain of a physical camera: it amplifies (at least 1); sensors
/// offer up to about 64.
pub const ANALOG_GAIN_RANGE: (f64, f64) = (1.0, 1.0e4);
/// Digital gain of a physical camera, either way.
pub const DIGITAL_GAIN_RANGE: (f64, f64) = (1.0e-4, 1.0e4);
/// Pixel sensitivity, electrons per cd/m^2 per second (a 3 um automotive
/// pixel: a few thousand).
pub const SENSITIVITY_RANGE: (f64, f64) = (1.0e-3, 1.0e9);
/// Full-well capacity, electrons (automotive HDR pixels: 10 to 100 ke-).
pub const FULL_WELL_E_RANGE: (f64, f64) = (1.0, 1.0e9);
/// Electrons per DN at unit gain.
pub const E_PER_DN_RANGE: (f64, f64) = (1.0e-3, 1.0e9);
/// Shortest HDR capture as a fraction of the L capture: with a 1 us
/// exposure floor and exposures up to a second, shorter ratios fall below
/// what a sensor can expose.
pub const MIN_EXPOSURE_RATIO: f64 = 1.0e-6;
/// Sensitivity of an HDR capture relative to the L capture (split pixels:
/// 1/16 to 1/256).
pub const SENSITIVITY_RATIO_RANGE: (f64, f64) = (1.0e-6, 1.0e6);
/// `[hdr] white-dn`, the L-equivalent DN mapped to white.
pub const WHITE_DN_RANGE: (f64, f64) = (1.0, 1.0e15);
/// `[tone] gamma`: output = input^(1/gamma); sRGB is about 2.2.
pub const GAMMA_RANGE: (f64, f64) = (0.1, 10.0);
/// `[tone] log-a`, the log curve's compression: below 1e-3 the curve is
/// linear within 0.05 % (use `curve = "linear"`), and 1e9 is 180 dB.
pub const LOG_A_RANGE: (f64, f64) = (1.0e-3, 1.0e9);

/// `[capture] frame-rate-fps` of captures without timestamps: high-speed
/// cameras record up to 1e5 fps.
pub const CAPTURE_FPS_RANGE: (f64, f64) = (MIN_FPS, 1.0e5);
/// `[capture] timeout-s` of a lab rig's command, seconds: waits are timed
/// to the millisecond, and a day is the longest (a `Duration` of 1e300 s
/// does not exist). A rig that overruns its timeout fails its run
/// (exit code 3), as documented for the command backend.
pub const TIMEOUT_S_RANGE: (f64, f64) = (1.0e-3, 86_400.0);

/// Most cases a run may have for its report to list every case in its
/// per-case tables; a larger run, a sweep, lists its worst
/// [`LISTED_CASES_MAX`] (`model::listing`, docs/report.md "Large runs").
pub const EVERY_CASE_LISTED_MAX: usize = 200;
/// Cases a report of a run larger than [`EVERY_CASE_LISTED_MAX`] lists
/// in its per-case tables: its worst.
pub const LISTED_CASES_MAX: usize = 100;
/// Most case pages a report gives at `--detail standard`.
pub const CASE_PAGES_MAX: usize = 20;

/// Memory of the process before the first case: code, the PDF engine's
/// fonts, the thread pool, bytes.
///
/// The memory constants below were fitted together to the peaks of every
/// shipped plan run twice, as shipped and with every case made to fail
/// (a `percent-flicker-max` of 0.001): a failing case gets a page of
/// charts in report.pdf, so a plan's peak is highest when all its cases
/// fail (daylight: 109 MB as shipped, 205 MB failing). Each estimate is
/// 1.1 to 1.35 times the higher of the two peaks (docs/plan-format.md,
/// "ResourceLimits").
const BASE_MEMORY_BYTES: f64 = 79.0e6;
/// Memory every case the results model holds costs until the report is
/// written: its entry (what results.json says of it; the phase folds' bins
/// only for the cases that get a page); its result, trace and files are
/// read back from the case store a chunk at a time (measured: 7.7 kB a case
/// of 2 ROIs; the rest is room for the report stage's copies of its
/// figures). A run of at most [`EVERY_CASE_LISTED_MAX`] cases, or one
/// reported at `--detail full`, holds every case; a larger one spills its
/// cases to disk and holds only [`MODEL_CASES_HELD`].
const CASE_MEMORY_BYTES: f64 = 10.5e3;
/// The model entries a spilled run holds: its listed cases, its paged
/// ones and the one its ROI map is drawn from (its cases with a worst-phase
/// run are held too; they are among the listed ones unless more than
/// [`LISTED_CASES_MAX`] fail).
const MODEL_CASES_HELD: f64 = (LISTED_CASES_MAX + CASE_PAGES_MAX + 1) as f64;
/// Memory every case of a spilled run costs while the report is written:
/// the few figures of it that the passes over every case gather at once
/// (its rank for the listing, its conditions and segments, its matrix
/// cell), and its offset in the spill file.
const SPILLED_CASE_MEMORY_BYTES: f64 = 200.0;
/// Memory a shard holds per case, on top of its frames and ROIs
/// ([`SHARD_FRAME_ROI_MEMORY_BYTES`]): its result until the shard's
/// directory is written.
const SHARD_CASE_MEMORY_BYTES: f64 = 16.0e3;
/// Memory a case the report lists costs on top: its result read back for
/// its pictures, its rows of the PDF's and the HTML's tables and their
/// part of the PDF layout.
const LISTED_MEMORY_BYTES: f64 = 1.0e6;
/// Memory a case with charts costs per frame and ROI: its trace, zoom and
/// phase-fold charts in report.html (the PDF engine's memo cache is freed
/// after the layout, so the stages after it no longer add to the peak).
const CHARTED_FRAME_ROI_MEMORY_BYTES: f64 = 310.0;
/// Memory a case page of report.pdf costs (a failing case's, or every
/// case's at `--detail full`): its charts parsed and laid out by the PDF
/// engine. A plan is estimated as if every case it could page failed.
const PAGE_MEMORY_BYTES: f64 = 2.5e6;
/// Memory a case page costs per ROI: each ROI's charts on it.
const PAGE_ROI_MEMORY_BYTES: f64 = 0.42e6;
/// Memory per sensor pixel while the report draws the frame views, once
/// per run: frames are held as runs of equal values, a view is a PNG of
/// its pixels (measured: 46 MB for a 3840 x 2160 sensor).
const PIXEL_MEMORY_BYTES: f64 = 6.0;
/// Memory of each light level's fine map (simulated ideal cameras only):
/// its 1951 x 100 cells, and their copies in results.json and in the
/// HTML's and the PDF's template data.
const FINE_MAP_MEMORY_BYTES: f64 = 20.0e6;
/// Size of the report that does not grow with cases, bytes.
const BASE_OUTPUT_BYTES: f64 = 1.5e6;
/// Memory a shard's case costs per frame and ROI while the shard holds
/// it, on top of [`SHARD_CASE_MEMORY_BYTES`]: its trace and analyses (measured:
/// 264 MB for a shard of 10,000 cases of 120 frames and 2 ROIs, 79 MB for
/// 2,500).
const SHARD_FRAME_ROI_MEMORY_BYTES: f64 = 40.0;
/// Report bytes every case costs: its frame and view, its results.json
/// entry, its store row and table rows (measured: 32 kB a case of 120
/// frames and 2 ROIs in a sweep of 4000).
const CASE_OUTPUT_BYTES: f64 = 25.0e3;
/// Report bytes every case costs per frame and ROI: its trace CSV.
const FRAME_ROI_OUTPUT_BYTES: f64 = 30.0;
/// Report bytes a charted case costs on top (every case of a run the
/// report lists whole, else the cases with a page): its charts, in
/// charts/ and in report.html and report.pdf (fitted to daylight: 330 kB
/// a case of 1920 frames and 2 ROIs).
const CHARTED_OUTPUT_BYTES: f64 = 55.0e3;
/// Report bytes a charted case costs per frame and ROI: its trace charts.
const CHARTED_FRAME_ROI_OUTPUT_BYTES: f64 = 35.0;
/// Bytes of the temporary directory a spilled run's case costs: its
/// results.json entry, compact (measured on a 1,000-case sweep of 2 ROIs
/// with failing cases: 2.4 kB on average and 3.6 kB at most, besides
/// 1.2 kB on average and 1.5 kB at most per ROI; the spill is the sum, so
/// the averages with some room).
const SPILL_CASE_BYTES: f64 = 3.0e3;
/// Bytes of the temporary directory a spilled run's case costs per ROI.
const SPILL_ROI_BYTES: f64 = 1.3e3;

/// The resources a run may use; `validate` refuses a plan whose estimate
/// exceeds them. The defaults suit a 2-core machine with a few GB;
/// `--max-memory` and `--max-report` raise them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResourceLimits {
    /// Peak resident memory, bytes.
    pub memory_bytes: f64,
    /// Size of the report directory, bytes.
    pub output_bytes: f64,
    /// Free space of the temporary directory, where a large run spills its
    /// cases' model entries, bytes (infinite: not checked).
    pub scratch_free_bytes: f64,
    /// The report gives every case a page (`--detail full`): every case
    /// is listed and charted, which the estimate counts.
    pub every_case: bool,
}

impl ResourceLimits {
    /// No limit on memory or disk: for what runs no case or writes no
    /// report of its own (`merge` takes the plan its shards ran, `rig
    /// check` sets up an instrument).
    pub fn unbounded() -> Self {
        ResourceLimits {
            memory_bytes: f64::INFINITY,
            output_bytes: f64::INFINITY,
            scratch_free_bytes: f64::INFINITY,
            every_case: false,
        }
    }
}

impl Default for ResourceLimits {
    fn default() -> Self {
        ResourceLimits {
            memory_bytes: MAX_MEMORY_BYTES,
            output_bytes: MAX_OUTPUT_BYTES,
            scratch_free_bytes: f64::INFINITY,
            every_case: false,
        }
    }
}

/// Parses a size such as `4GB`, `1500 MB`, `2GiB` or `800000000` (bytes)
/// for `--max-memory` and `--max-report`.
pub fn parse_bytes(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let scale = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "kb" | "k" => 1e3,
        "mb" | "m" => 1e6,
        "gb" | "g" => 1e9,
        "tb" | "t" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0f64.powi(4),
        u => {
            return Err(format!(
                "unknown unit `{u}` in `{text}`; use B, kB, MB, GB, TB or KiB, MiB, GiB, TiB"
            ));
        }
    };
    match number.parse::<f64>() {
        Ok(n) if n.is_finite() && n > 0.0 => Ok(n * scale),
        _ => Err(format!(
            "`{text}` is not a size; give a positive number of bytes with a unit, e.g. 4GB or 1500MB"
        )),
    }
}

/// What running a plan costs, estimated before running it. Every figure is
/// an upper bound for the simulator; for captured and command backends the
/// frames come from files and only the report part is estimated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorkEstimate {
    /// Test cases.
    pub cases: usize,
    /// Frames per case (simulator; 0 when the frames come from files).
    pub frames_per_case: u64,
    /// Sensor rows integrated per frame: the rows of every ROI.
    pub rows_per_frame: u64,
    /// cases x frames x rows: closed-form row integrals of the run.
    pub row_integrals: f64,
    /// Pixels of one rendered sample frame (0 when none is rendered).
    pub frame_pixels: u64,
    /// Peak resident memory, bytes.
    pub memory_bytes: f64,
    /// Size of the report directory, bytes.
    pub output_bytes: f64,
    /// Bytes the run writes to the temporary directory (`TMPDIR`) and
    /// removes when it ends: the spill of a run whose report does not hold
    /// every case (docs/report.md, "Large runs"); 0 for other runs.
    pub scratch_bytes: f64,
}

impl WorkEstimate {
    /// The estimate for `plan`, its report at the default detail.
    pub fn of(plan: &Plan) -> WorkEstimate {
        WorkEstimate::with_report(plan, false)
    }

    /// The estimate for `plan`; with `every_case`, a report that gives every
    /// case a page (`--detail full`).
    pub fn with_report(plan: &Plan, every_case: bool) -> WorkEstimate {
        let cases = super::expand_cases(plan).len();
        let Shape {
            sim,
            frames,
            rows,
            pixels,
            frame_rois,
        } = Shape::of(plan);
        let n = cases as f64;
        // Every case is modelled and exported, a chunk at a time from the
        // case store; the report lists (tables, PDF layout) and charts at
        // most its worst cases, unless it gives every case a page.
        let (listed, charted) = if every_case || cases <= EVERY_CASE_LISTED_MAX {
            (n, n)
        } else {
            (LISTED_CASES_MAX as f64, CASE_PAGES_MAX as f64)
        };
        let output = n * (CASE_OUTPUT_BYTES + FRAME_ROI_OUTPUT_BYTES * frame_rois)
            + charted * (CHARTED_OUTPUT_BYTES + CHARTED_FRAME_ROI_OUTPUT_BYTES * frame_rois);
        // Frames are held as runs of equal values, so the sensor's size
        // costs memory only while a view is drawn.
        let spilled = !(every_case || cases <= EVERY_CASE_LISTED_MAX);
        let held = if spilled {
            MODEL_CASES_HELD * CASE_MEMORY_BYTES + n * SPILLED_CASE_MEMORY_BYTES
        } else {
            n * CASE_MEMORY_BYTES
        };
        let scratch = if spilled {
            n * (SPILL_CASE_BYTES + SPILL_ROI_BYTES * plan.rois.len() as f64)
        } else {
            0.0
        };
        let pages = if every_case {
            n
        } else {
            n.min(CASE_PAGES_MAX as f64)
        };
        let memory = held
            + listed * LISTED_MEMORY_BYTES
            + charted * CHARTED_FRAME_ROI_MEMORY_BYTES * frame_rois
            + pages * (PAGE_MEMORY_BYTES + PAGE_ROI_MEMORY_BYTES * plan.rois.len() as f64);
        // The fine maps' condition is `analysis::fine_maps_note`'s, which
        // this layer cannot call.
        let fine_maps = sim
            && plan.dut.camera.physical.is_none()
            && plan.rois.iter().any(|r| r.kind == super::RoiKind::Led);
        let memory = memory
            + if fine_maps {
                FINE_MAP_MEMORY_BYTES * plan.light_levels_lux.len() as f64
            } else {
                0.0
            };
        WorkEstimate {
            cases,
            frames_per_case: frames,
            rows_per_frame: rows,
            row_integrals: n * frames as f64 * rows as f64,
            frame_pixels: pixels,
            memory_bytes: BASE_MEMORY_BYTES + PIXEL_MEMORY_BYTES * pixels as f64 + memory,
            output_bytes: BASE_OUTPUT_BYTES + output,
            scratch_bytes: scratch,
        }
    }

    /// The estimate for one shard of `plan` that runs `cases` of its
    /// cases (`plan --shard K/N`): a shard holds its cases' results until
    /// it writes its directory, and draws no report, so its memory and
    /// disk grow with its own share, not with the plan.
    pub fn of_shard(plan: &Plan, cases: usize) -> WorkEstimate {
        let Shape {
            frames,
            rows,
            pixels,
            frame_rois,
            ..
        } = Shape::of(plan);
        let n = cases as f64;
        WorkEstimate {
            cases,
            frames_per_case: frames,
            rows_per_frame: rows,
            row_integrals: n * frames as f64 * rows as f64,
            frame_pixels: pixels,
            memory_bytes: BASE_MEMORY_BYTES
                + PIXEL_MEMORY_BYTES * pixels as f64
                + n * (SHARD_CASE_MEMORY_BYTES + SHARD_FRAME_ROI_MEMORY_BYTES * frame_rois),
            output_bytes: BASE_OUTPUT_BYTES
                + n * (CASE_OUTPUT_BYTES + FRAME_ROI_OUTPUT_BYTES * frame_rois),
            scratch_bytes: 0.0,
        }
    }

    /// The estimate for `merge` of a sharded run of `plan` whose largest
    /// shard holds `largest` cases: the shards' cases pass through memory
    /// one shard at a time on their way to the case store, then the report
    /// is drawn from the store as `plan`'s is (`every_case` as for
    /// [`WorkEstimate::with_report`]). Nothing is simulated.
    pub fn of_merge(plan: &Plan, largest: usize, every_case: bool) -> WorkEstimate {
        let report = WorkEstimate::with_report(plan, every_case);
        let shard = WorkEstimate::of_shard(plan, largest);
        WorkEstimate {
            row_integrals: 0.0,
            memory_bytes: report.memory_bytes.max(shard.memory_bytes),
            ..report
        }
    }

    /// Why merging a sharded run of `plan` whose largest shard holds
    /// `largest` cases does not fit `limits` ([`WorkEstimate::of_merge`]),
    /// or `None` when it does.
    pub fn merge_too_large(plan: &Plan, largest: usize, limits: ResourceLimits) -> Option<String> {
        let e = WorkEstimate::of_merge(plan, largest, limits.every_case);
        let over = e.over(limits);
        (!over.is_empty()).then(|| format!("the merge is too large: {}", over.join(", ")))
    }

    /// What the estimate exceeds of `limits`, one phrase each naming the
    /// figure and the flag that raises it; empty when it fits.
    fn over(&self, limits: ResourceLimits) -> Vec<String> {
        [
            (
                self.row_integrals > MAX_ROW_INTEGRALS,
                format!(
                    "{:.3e} row integrals (at most {MAX_ROW_INTEGRALS:.0e})",
                    self.row_integrals
                ),
            ),
            (
                self.memory_bytes > limits.memory_bytes,
                format!(
                    "peak memory {} (at most {}; --max-memory raises it)",
                    bytes(self.memory_bytes),
                    bytes(limits.memory_bytes)
                ),
            ),
            (
                self.output_bytes > limits.output_bytes,
                format!(
                    "a report of {} (at most {}; --max-report raises it)",
                    bytes(self.output_bytes),
                    bytes(limits.output_bytes)
                ),
            ),
            (
                self.scratch_bytes > limits.scratch_free_bytes,
                format!(
                    "{} of cases spilled to the temporary directory `{}` ({} free there; \
                     TMPDIR names another)",
                    bytes(self.scratch_bytes),
                    std::env::temp_dir().display(),
                    bytes(limits.scratch_free_bytes)
                ),
            ),
        ]
        .into_iter()
        .filter_map(|(over, m)| over.then_some(m))
        .collect()
    }

    /// Why a shard of `cases` cases of `plan` does not fit `limits`
    /// ([`WorkEstimate::of_shard`]), or `None` when it does.
    pub fn shard_too_large(plan: &Plan, cases: usize, limits: ResourceLimits) -> Option<String> {
        let e = WorkEstimate::of_shard(plan, cases);
        let over = e.over(limits);
        (!over.is_empty()).then(|| {
            format!(
                "the shard is too large to run: {}; {}",
                over.join(", "),
                e.summary()
            )
        })
    }

    /// One line for `ledflicker validate`.
    pub fn summary(&self) -> String {
        let scratch = match self.scratch_bytes > 0.0 {
            true => format!("; temporary files {}", bytes(self.scratch_bytes)),
            false => String::new(),
        };
        format!(
            "estimated work: {} cases x {} frames x {} rows = {:.3e} row integrals; peak memory {}; report {}{scratch}",
            self.cases,
            self.frames_per_case,
            self.rows_per_frame,
            self.row_integrals,
            bytes(self.memory_bytes),
            bytes(self.output_bytes)
        )
    }
}

/// `1.2 GB`, `340 MB`, `12 kB`.
pub fn bytes(b: f64) -> String {
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.0} MB", b / 1e6)
    } else {
        format!("{:.0} kB", b / 1e3)
    }
}

/// Pushes a diagnostic for `key`, located at the key or its nearest table.
fn error(index: &SpanIndex, diags: &mut Vec<Diagnostic>, key: &str, message: String, hint: &str) {
    let mut location = index.location(key);
    let mut k = key;
    while location.is_none() {
        let Some(i) = k.rfind(['.', '[']) else {
            break;
        };
        k = &k[..i];
        location = index.location(k);
    }
    diags.push(Diagnostic {
        file: None,
        key: key.to_string(),
        location,
        message,
        hint: Some(hint.to_string()),
    });
}

/// What a case of a plan is made of, for the estimates.
struct Shape {
    /// The simulator runs the cases.
    sim: bool,
    /// Frames a simulated case renders (0 for other backends).
    frames: u64,
    /// ROI rows integrated per frame.
    rows: u64,
    /// Sensor pixels of a simulated camera (0 for other backends).
    pixels: u64,
    /// Frames of a case's trace times its ROIs.
    frame_rois: f64,
}

impl Shape {
    fn of(plan: &Plan) -> Shape {
        let sim = plan.dut.backend == BackendKind::Simulator;
        let frames = if sim {
            super::SegmentFrames::new(&plan.sequence, plan.dut.camera.fps).total()
        } else {
            0
        };
        // Captured and command runs read whatever frames they are given; the
        // report part is estimated at the sequence's length.
        let trace_frames = if sim {
            frames
        } else {
            let s = &plan.sequence;
            ((s.on_s + s.off_s + s.pwm_s) * plan.dut.camera.fps).ceil() as u64
        };
        let pixels = if sim {
            u64::from(plan.dut.camera.sensor_rows) * u64::from(plan.dut.camera.sensor_columns)
        } else {
            0
        };
        Shape {
            sim,
            frames,
            rows: plan.rois.iter().map(|r| u64::from(r.height_px)).sum(),
            pixels,
            frame_rois: trace_frames as f64 * plan.rois.len() as f64,
        }
    }
}

/// Checks the physical bounds, the uniqueness of case ids and, with
/// `work`, the work estimate of a validated plan against those limits.
pub(super) fn check(
    plan: &Plan,
    index: &SpanIndex,
    diags: &mut Vec<Diagnostic>,
    work: Option<ResourceLimits>,
) {
    let before = diags.len();
    physical(plan, index, diags);
    let cases = super::expand_cases(plan);
    unique_ids(&cases, index, diags);
    let Some(limits) = work.filter(|_| diags.len() == before) else {
        return;
    };
    let e = WorkEstimate::with_report(plan, limits.every_case);
    let problems = e.over(limits);
    if !problems.is_empty() {
        error(
            index,
            diags,
            "grid",
            format!(
                "the plan is too large to run: {}; {}",
                problems.join(", "),
                e.summary()
            ),
            "use fewer grid points, a shorter [sequence], fewer or smaller ROIs or a smaller sensor, or split the plan (docs/plan-format.md, \"ResourceLimits\")",
        );
    }
}

fn physical(plan: &Plan, index: &SpanIndex, diags: &mut Vec<Diagnostic>) {
    let mut bound = |ok: bool, key: &str, message: String, hint: &str| {
        if !ok {
            error(index, diags, key, message, hint);
        }
    };
    // Grid values, frame rates and the other keys of one value each are
    // checked against their ranges in `validate`, with the other errors
    // of their tables; these bounds are on what the simulator makes.
    if plan.dut.backend != BackendKind::Simulator {
        return;
    }
    let cam = &plan.dut.camera;
    let key = |k: &str| format!("dut.camera.{k}");
    bound(
        cam.exposure_s >= MIN_EXPOSURE_S,
        &key("exposure-ms"),
        format!(
            "{} ms is below the 0.001 ms (1 us) limit",
            cam.exposure_s * 1e3
        ),
        "exposures are given in milliseconds",
    );
    let pixels = u64::from(cam.sensor_rows) * u64::from(cam.sensor_columns);
    bound(
        cam.sensor_rows <= MAX_SENSOR_SIDE
            && cam.sensor_columns <= MAX_SENSOR_SIDE
            && pixels <= MAX_SENSOR_PIXELS,
        &key("sensor-rows"),
        format!(
            "a {} x {} sensor is above the limit of {MAX_SENSOR_SIDE} pixels a side and {} Mpx",
            cam.sensor_columns,
            cam.sensor_rows,
            MAX_SENSOR_PIXELS / 1_000_000
        ),
        "an 8K automotive sensor is 7680 x 4320",
    );
    let frames = super::SegmentFrames::new(&plan.sequence, cam.fps).total();
    bound(
        frames <= MAX_FRAMES_PER_CASE,
        "sequence.pwm-s",
        format!("the sequence is {frames} frames long; at most {MAX_FRAMES_PER_CASE}"),
        "shorten the sequence or lower the frame rate",
    );
}

/// Two grid points whose ids coincide would share one trace file and one
/// row of the report (e.g. 90.0 and 90.0000001 Hz).
fn unique_ids(cases: &[TestCase], index: &SpanIndex, diags: &mut Vec<Diagnostic>) {
    let mut seen: std::collections::HashMap<&str, &TestCase> = std::collections::HashMap::new();
    let mut reported = 0;
    for c in cases {
        if let Some(first) = seen.insert(&c.id, c)
            && reported < 10
        {
            reported += 1;
            let point = |t: &TestCase| {
                format!(
                    "({} lux, {} Hz, duty {})",
                    t.light_lux, t.frequency_hz, t.duty
                )
            };
            error(
                index,
                diags,
                "grid",
                format!(
                    "grid points {} and {} both have the case id `{}`",
                    point(first),
                    point(c),
                    c.id
                ),
                "case ids keep 6 decimals; make grid values differ within them",
            );
            seen.insert(&first.id, first);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep() -> Plan {
        let path = std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../test-plans/sweep-23k.toml"
        ));
        crate::plan::load(path).unwrap()
    }

    #[test]
    fn a_spilled_run_is_refused_when_its_temporary_files_do_not_fit() {
        let plan = sweep();
        let e = WorkEstimate::of(&plan);
        let free = |scratch_free_bytes| ResourceLimits {
            scratch_free_bytes,
            ..ResourceLimits::unbounded()
        };
        assert!(e.over(free(e.scratch_bytes * 1.01)).is_empty());
        let over = e.over(free(e.scratch_bytes * 0.99));
        assert_eq!(over.len(), 1, "{over:?}");
        assert!(over[0].contains("TMPDIR"), "{over:?}");
        // At --detail full nothing is spilled; nor is a run of 200 cases.
        assert_eq!(WorkEstimate::with_report(&plan, true).scratch_bytes, 0.0);
        let daylight = crate::plan::find_and_load("daylight").unwrap();
        let small = WorkEstimate::of(&daylight);
        assert_eq!(small.scratch_bytes, 0.0);
        assert!(small.over(free(0.0)).is_empty());
        assert!(!small.summary().contains("temporary"));
        assert!(
            e.summary().contains("temporary files 131 MB"),
            "{}",
            e.summary()
        );
    }

    #[test]
    fn a_merge_needs_the_larger_of_its_largest_shard_and_the_report_stage() {
        let plan = sweep();
        let report = WorkEstimate::of(&plan);
        let merge = |largest| WorkEstimate::of_merge(&plan, largest, false);
        // Nothing is simulated, whatever the shards held.
        assert_eq!(merge(100).row_integrals, 0.0);
        assert_eq!(merge(100).output_bytes, report.output_bytes);
        // The larger of the two stages, for small shards and for one shard
        // of every case; the shard's term grows with its cases.
        for largest in [100, report.cases] {
            let shard = WorkEstimate::of_shard(&plan, largest).memory_bytes;
            assert_eq!(merge(largest).memory_bytes, shard.max(report.memory_bytes));
        }
        assert!(
            WorkEstimate::of_shard(&plan, report.cases).memory_bytes
                > WorkEstimate::of_shard(&plan, 100).memory_bytes
        );
        let need = merge(report.cases).memory_bytes;
        let limits = |memory_bytes| ResourceLimits {
            memory_bytes,
            ..ResourceLimits::unbounded()
        };
        assert_eq!(
            WorkEstimate::merge_too_large(&plan, report.cases, limits(need * 1.01)),
            None
        );
        let refused =
            WorkEstimate::merge_too_large(&plan, report.cases, limits(need * 0.99)).unwrap();
        assert!(
            refused.contains("the merge is too large: peak memory")
                && refused.contains("--max-memory raises it"),
            "{refused}"
        );
    }
}
