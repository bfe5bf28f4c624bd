//! The lab-rig backend: `[dut] backend = "command"` runs the plan's
//! `[capture] command` once per case, to drive the PWM controller and the
//! camera, and reads the frames it leaves in a directory.
//!
//! Protocol (docs/command-backend.md):
//! - the case goes in as environment variables `LEDFLICKER_*` and as one
//!   JSON object on stdin (same fields, plus the ROIs);
//! - the command writes frames into `LEDFLICKER_OUT_DIR` (PNG/TIFF frames
//!   in name order, or one `.y4m`, video or `.csv` trace file) and exits 0;
//! - it is killed after `[capture] timeout-s`;
//! - segments come from `[capture]` when given, else from `[sequence]`
//!   (ON, OFF, PWM in that order, by frame time).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use super::aravis;
use super::captured::{
    CaptureSummary, find_segments_with, keep_colour_planes, read_options, roi_rects, to_acquisition,
};
use super::rig::{self, RigError};
use super::scpi::light::LightSource;
use super::scpi::sequence;
use super::segments::Detection;
use super::{Acquisition, Backend, BackendError};
use crate::capture::{self, SourceKind};
use ledflicker_plan::plan::recorder::{CameraSettings, RecorderKind, pipeline_args};
use ledflicker_plan::plan::{CaptureConfig, Plan, Roi, SegmentSpec, Sequence, Span, TestCase};
use ledflicker_plan::trace::{CameraLog, Ratio, SourceLog};
use std::sync::atomic::AtomicBool;

/// Name prefix of the rigs' scratch directories in the temporary
/// directory: `ledflicker-rig-<pid>-<case id>-<random>`.
const SCRATCH_PREFIX: &str = "ledflicker-rig-";

/// What [`clean_stale_scratch`] found of runs killed with SIGKILL.
#[derive(Debug, Default)]
pub struct StaleRigs {
    /// Scratch directories removed.
    pub removed: usize,
    /// Rig processes of those runs that were still running, and were
    /// stopped (SIGKILL): pid and command line.
    pub stopped: Vec<(u32, String)>,
}

impl StaleRigs {
    /// A line for the user about the stopped rig processes, if any.
    pub fn warning(&self) -> Option<String> {
        if self.stopped.is_empty() {
            return None;
        }
        let list: Vec<String> = self
            .stopped
            .iter()
            .map(|(pid, cmd)| format!("{pid} `{cmd}`"))
            .collect();
        Some(format!(
            "warning: stopped {} rig process(es) left running by an earlier run that was killed: {}",
            list.len(),
            list.join(", ")
        ))
    }
}

/// Removes the scratch directories that runs killed with SIGKILL left in
/// the temporary directory (their process is gone). A killed run cannot
/// kill its rig's process group, which then runs on and writes into that
/// directory: every process still working for it (its environment names
/// the directory, as each rig process inherits it) is stopped first.
pub fn clean_stale_scratch() -> StaleRigs {
    let mut stale = StaleRigs::default();
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return stale;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(SCRATCH_PREFIX)
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if ledflicker_plan::util::alive(pid) {
            continue;
        }
        stale.stopped.extend(stop_processes_of(&e.path()));
        if std::fs::remove_dir_all(e.path()).is_ok() {
            stale.removed += 1;
        }
    }
    stale
}

/// Stops (SIGKILL) every process of this user whose environment gives
/// `LEDFLICKER_OUT_DIR` inside `scratch`; returns their pids and command
/// lines. Read from /proc; elsewhere nothing is found.
fn stop_processes_of(scratch: &Path) -> Vec<(u32, String)> {
    let Ok(procs) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let mut want = b"LEDFLICKER_OUT_DIR=".to_vec();
    want.extend_from_slice(scratch.as_os_str().as_encoded_bytes());
    let mut stopped = Vec::new();
    for p in procs.flatten() {
        let Some(pid) = p.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else {
            continue;
        };
        if pid == std::process::id() {
            continue;
        }
        // Another user's processes are unreadable here, and never ours.
        let Ok(environ) = std::fs::read(p.path().join("environ")) else {
            continue;
        };
        let ours = environ
            .split(|&b| b == 0)
            .any(|var| var.starts_with(&want) && matches!(var.get(want.len()), None | Some(b'/')));
        if !ours {
            continue;
        }
        let cmdline = std::fs::read(p.path().join("cmdline")).unwrap_or_default();
        let cmdline: Vec<String> = cmdline
            .split(|&b| b == 0)
            .filter(|a| !a.is_empty())
            .map(|a| String::from_utf8_lossy(a).into_owned())
            .collect();
        if let Ok(raw) = libc::pid_t::try_from(pid) {
            // SAFETY: kill(2) on one process that this user owns (its
            // environ was readable) and that works for a dead run's rig.
            unsafe {
                libc::kill(raw, libc::SIGKILL);
            }
            stopped.push((pid, super::rig::escape_controls(&cmdline.join(" "))));
        }
    }
    stopped.sort();
    stopped
}

/// Moves the directory `from` to `to` (which must not exist): a rename,
/// or across file systems (the scratch directory is in the temporary
/// directory, the report anywhere) a copy of every file, then removal.
fn move_dir(from: &Path, to: &Path) -> std::io::Result<()> {
    if std::fs::rename(from, to).is_ok() {
        return Ok(());
    }
    copy_dir(from, to)?;
    std::fs::remove_dir_all(from)
}

fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir(to)?;
    for e in std::fs::read_dir(from)? {
        let e = e?;
        let target = to.join(e.file_name());
        if e.file_type()?.is_dir() {
            copy_dir(&e.path(), &target)?;
        } else {
            std::fs::copy(e.path(), target)?;
        }
    }
    Ok(())
}

/// Runs a lab-rig command per case.
#[derive(Debug, Clone)]
pub struct CommandRig {
    argv: Vec<String>,
    timeout: Duration,
    plan_dir: PathBuf,
    capture: CaptureConfig,
    sequence: Sequence,
    fps: f64,
    rois: Vec<Roi>,
    /// The plan's `[source]`, driven while the command records (boxed:
    /// the other backends are far smaller).
    light: Option<Box<LightSource>>,
    /// How a `[source]` recording's segments are found: the plan's
    /// sequence, settle time and LED ROIs.
    detection: Detection,
    /// The command is the plan's `[recorder]`, whose arguments name the
    /// case's output directory as `{out-dir}`.
    recorder: bool,
    /// The camera settings of the plan's `[recorder]`, when it sets any.
    camera: Option<CameraSettings>,
    /// The Aravis camera an `aravissrc` recorder records (`None` inside:
    /// Aravis' first), whose settings are read back after each recording.
    aravis: Option<Option<String>>,
    /// Where each case's recording is moved after the analysis
    /// (`--keep-captures`), as `<dir>/<case id>/`, and the name it is
    /// reported under (relative to the report directory); `None`: removed.
    keep: Option<(PathBuf, String)>,
    /// The plan has colour: each LED ROI keeps the recording's R, G and B.
    colour: bool,
}

impl CommandRig {
    /// A rig for `plan`; `None` when the plan has no command.
    pub fn new(plan: &Plan) -> Option<Self> {
        let cap = plan.capture.clone()?;
        let cmd = cap.command.clone()?;
        if let Some(warning) = clean_stale_scratch().warning() {
            eprintln!("{warning}");
        }
        Some(Self {
            argv: cmd.argv,
            timeout: Duration::from_secs_f64(cmd.timeout_s),
            plan_dir: plan
                .path
                .parent()
                .map(|d| {
                    if d.as_os_str().is_empty() {
                        Path::new(".")
                    } else {
                        d
                    }
                })
                // A folder that does not exist keeps its name, for the
                // message when the rig cannot start there.
                .map(|d| d.canonicalize().unwrap_or_else(|_| d.to_path_buf()))
                .unwrap_or_default(),
            capture: cap,
            sequence: plan.sequence,
            fps: plan.dut.camera.fps,
            rois: plan.rois.clone(),
            light: plan
                .source
                .clone()
                .map(|cfg| Box::new(LightSource::new(cfg, plan.sequence))),
            detection: Detection::for_plan(plan),
            recorder: plan.recorder.is_some(),
            camera: plan
                .recorder
                .as_ref()
                .map(|r| r.settings)
                .filter(|s| !s.is_empty()),
            keep: None,
            colour: plan.colour.is_some(),
            aravis: match plan.recorder.as_ref().map(|r| &r.kind) {
                Some(RecorderKind::GStreamer(pipeline)) => {
                    aravis::camera_of(&pipeline_args(pipeline).unwrap_or_default())
                }
                _ => None,
            },
        })
    }

    /// Keeps each case's recording in `dir/<case id>/` after the analysis
    /// instead of removing it; `label` is `dir` as results.json names it
    /// (relative to the report directory, e.g. `captures`).
    pub fn keep_captures(&mut self, dir: PathBuf, label: &str) {
        self.keep = Some((dir, label.to_string()));
    }

    /// Moves the recording in `out` to the keep folder, when captures are
    /// kept; returns its name for results.json.
    fn keep_recording(&self, case: &TestCase, out: &Path) -> Result<Option<String>, BackendError> {
        let Some((dir, label)) = &self.keep else {
            return Ok(None);
        };
        let to = dir.join(&case.id);
        std::fs::create_dir_all(dir)
            .and_then(|()| move_dir(out, &to))
            .map_err(|e| {
                self.fail(
                    case,
                    format!("cannot keep the recording in `{}`: {e}", to.display()),
                )
            })?;
        Ok(Some(format!("{label}/{}", case.id)))
    }

    /// What the recorder set, and the frame rate its recording states;
    /// warns when that rate is not the one set.
    fn camera_log(&self, case: &TestCase, stated: Option<Ratio>) -> Option<CameraLog> {
        let set = self.camera?;
        let read = stated.map(Ratio::value);
        let (exposure_read_us, gain_read_db) = match &self.aravis {
            Some(camera) => aravis::read_back(camera.as_deref()),
            None => (None, None),
        };
        if let (Some(want), Some(got)) = (set.frame_rate_fps, read)
            && (want - got).abs() > 1e-3 * want
        {
            eprintln!(
                "warning: case `{}`: the camera was set to {want} fps and its recording states {got:.3} fps: the camera did not take the rate",
                case.id
            );
        }
        Some(CameraLog {
            exposure_us: set.exposure_us,
            gain_db: set.gain_db,
            frame_rate_fps: set.frame_rate_fps,
            frame_rate_read_fps: read,
            exposure_read_us,
            gain_read_db,
        })
    }

    fn env(&self, case: &TestCase, out: &Path) -> Vec<(String, String)> {
        let s = &self.sequence;
        [
            ("CASE_ID", case.id.clone()),
            ("LIGHT_LUX", case.light_lux.to_string()),
            ("FREQUENCY_HZ", case.frequency_hz.to_string()),
            ("DUTY", case.duty.to_string()),
            ("SEED", case.seed.to_string()),
            ("ON_S", s.on_s.to_string()),
            ("OFF_S", s.off_s.to_string()),
            ("PWM_S", s.pwm_s.to_string()),
            ("FRAME_RATE_FPS", self.fps.to_string()),
            (
                "LEAD_IN_S",
                self.light
                    .as_ref()
                    .map_or(0.0, |l| l.lead_in_s())
                    .to_string(),
            ),
            ("OUT_DIR", out.display().to_string()),
        ]
        .into_iter()
        .map(|(k, v)| (format!("LEDFLICKER_{k}"), v))
        .collect()
    }

    fn fail(&self, case: &TestCase, message: String) -> BackendError {
        BackendError {
            backend: self.id().to_string(),
            case: case.id.clone(),
            message,
        }
    }

    /// The case as one JSON object for the command's stdin: the same fields
    /// as the environment, numbers as numbers (the seed as an exact
    /// integer), plus the ROIs.
    fn stdin_json(&self, case: &TestCase, out: &Path) -> String {
        let s = &self.sequence;
        serde_json::json!({
            "case_id": case.id,
            "light_lux": case.light_lux,
            "frequency_hz": case.frequency_hz,
            "duty": case.duty,
            "seed": case.seed,
            "on_s": s.on_s,
            "off_s": s.off_s,
            "pwm_s": s.pwm_s,
            "frame_rate_fps": self.fps,
            "out_dir": out.display().to_string(),
            "rois": self.rois,
        })
        .to_string()
    }

    /// Program and arguments, with paths relative to the plan resolved
    /// and a recorder's `{out-dir}` filled with `out`.
    fn program_and_args(&self, out: &Path) -> (PathBuf, Vec<String>) {
        let mut program = PathBuf::from(&self.argv[0]);
        let local = self.plan_dir.join(&program);
        if program.is_relative() && program.components().count() > 1 && local.exists() {
            program = local;
        }
        let args: Vec<String> = self.argv[1..]
            .iter()
            .map(|a| {
                let a = if self.recorder {
                    a.replace("{out-dir}", &out.display().to_string())
                } else {
                    a.clone()
                };
                let p = self.plan_dir.join(&a);
                if Path::new(&a).is_relative() && a.contains('/') && p.exists() {
                    p.display().to_string()
                } else {
                    a
                }
            })
            .collect();
        (program, args)
    }

    /// Runs the command for `case`, with the light source's sequence when
    /// the plan has one; returns the capture it left in `out`.
    fn record(
        &self,
        case: &TestCase,
        out: &Path,
    ) -> Result<(PathBuf, Option<SourceLog>), BackendError> {
        match &self.light {
            None => Ok((self.run_command(case, out, &AtomicBool::new(false))?, None)),
            Some(light) => light
                .during(case, |cancel| {
                    self.run_command(case, out, cancel).map_err(|e| e.message)
                })
                .map(|(path, log)| (path, Some(log)))
                .map_err(|message| self.fail(case, message)),
        }
    }

    /// Runs the command for `case` (killed when `cancel` is set); returns
    /// the capture it left in `out`.
    fn run_command(
        &self,
        case: &TestCase,
        out: &Path,
        cancel: &AtomicBool,
    ) -> Result<PathBuf, BackendError> {
        let (program, args) = self.program_and_args(out);
        let mut command = Command::new(&program);
        command
            .args(&args)
            .envs(self.env(case, out))
            .current_dir(&self.plan_dir);
        // The rig may call ledflicker back: this executable, unless the
        // engine is embedded (in Python, whose interpreter is no
        // ledflicker), where the caller's environment says where it is.
        if !crate::interrupt::is_embedded() {
            command.env(
                "LEDFLICKER_EXE",
                std::env::current_exe().unwrap_or_default(),
            );
        }
        let finished = rig::run_until(
            &mut command,
            self.stdin_json(case, out),
            self.timeout,
            cancel,
        )
        .map_err(|e| self.fail(case, self.describe(&program, e)))?;
        if !finished.status.success() {
            let tail: Vec<&str> = finished.stderr.lines().rev().take(5).collect();
            return Err(self.fail(
                case,
                format!(
                    "`{}` failed ({}){}",
                    self.argv.join(" "),
                    finished.status,
                    if tail.is_empty() {
                        String::new()
                    } else {
                        format!(
                            ": {}",
                            tail.into_iter().rev().collect::<Vec<_>>().join("; ")
                        )
                    }
                ),
            ));
        }
        // One capture file, or a directory of frames. Anything but a
        // directory counts as a file: a FIFO the command left is then
        // refused by the capture reader, naming it, not passed over.
        let files: Vec<PathBuf> = std::fs::read_dir(out)
            .map_err(|e| self.fail(case, format!("cannot list `{}`: {e}", out.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                !p.is_dir()
                    && !p.to_string_lossy().ends_with(".timestamps.csv")
                    && capture::source_kind(p) != SourceKind::Image
            })
            .collect();
        match files.as_slice() {
            [one] => Ok(one.clone()),
            [] => Ok(out.to_path_buf()),
            _ => Err(self.fail(
                case,
                format!(
                    "the command left {} capture files in its output directory; expected frames or one file",
                    files.len()
                ),
            )),
        }
    }

    /// The message of a command that did not run to its end.
    fn describe(&self, program: &Path, e: RigError) -> String {
        match e {
            // The rig runs in the plan's folder: when that is missing (a
            // built-in plan run away from the source tree), spawning fails
            // with "not found", which is not the program's fault.
            RigError::Spawn(_) if !self.plan_dir.is_dir() => format!(
                "cannot run `{}`: the rig runs in the plan's folder `{}`, which does not exist\n    hint: run the plan from the folder that holds it (a built-in plan's rig script is in the ledflicker source tree)",
                program.display(),
                self.plan_dir.display()
            ),
            RigError::Spawn(e) => format!("cannot run `{}`: {e}", program.display()),
            RigError::TimedOut { after, stderr } => {
                let last = stderr
                    .lines()
                    .last()
                    .map(|l| format!(" (last stderr line: {l})"));
                format!(
                    "`{}` did not finish within {:.1} s and was killed with its process group{}\n    hint: raise [capture] timeout-s",
                    self.argv.join(" "),
                    after.as_secs_f64(),
                    last.unwrap_or_default()
                )
            }
            RigError::Interrupted { signal } => format!(
                "`{}` was killed with its process group: interrupted by {}",
                self.argv.join(" "),
                crate::interrupt::signal_name(signal)
            ),
            RigError::Wait(e) => format!("waiting for the command: {e}"),
            RigError::Cancelled => format!(
                "`{}` was killed with its process group: the light source failed",
                self.argv.join(" ")
            ),
        }
    }

    fn segments(&self) -> SegmentSpec {
        // A recording behind a light source starts with a dark lead-in of
        // unknown length (the camera's start-up): its steps are found.
        if !self.capture.segments.detect() || self.light.is_some() {
            return self.capture.segments;
        }
        let s = &self.sequence;
        let span = |a: f64, b: Option<f64>| Some(Span::Seconds { start: a, end: b });
        SegmentSpec {
            on: (s.on_s > 0.0).then(|| span(0.0, Some(s.on_s))).flatten(),
            off: (s.off_s > 0.0)
                .then(|| span(s.on_s, Some(s.on_s + s.off_s)))
                .flatten(),
            pwm: span(s.on_s + s.off_s, None),
        }
    }
}

impl Backend for CommandRig {
    fn id(&self) -> &str {
        "command"
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        // A private scratch directory (random name, mode 0700), removed
        // when `scratch` drops, whatever happens; the frames go into
        // `frames/` inside it, so files a rig writes next to its output
        // directory are removed too.
        let scratch = tempfile::Builder::new()
            .prefix(&format!(
                "{SCRATCH_PREFIX}{}-{}-",
                std::process::id(),
                case.id
            ))
            .permissions(std::os::unix::fs::PermissionsExt::from_mode(0o700))
            .tempdir()
            .map_err(|e| self.fail(case, format!("cannot create a scratch directory: {e}")))?;
        let out = scratch.path().join("frames");
        std::fs::create_dir(&out)
            .map_err(|e| self.fail(case, format!("cannot create `{}`: {e}", out.display())))?;
        let result = (|| {
            let (source, light_source) = self.record(case, &out)?;
            let names: Vec<String> = self.rois.iter().map(|r| r.name.clone()).collect();
            // Frames without timestamps run at the plan's frame rate.
            let mut opts = read_options(&self.capture);
            opts.fps = opts.fps.or(Some(self.fps));
            let mut trace = capture::read_capture(&source, &roi_rects(&self.rois), &names, &opts)
                .map_err(|e| self.fail(case, format!("the command's frames: {e}")))?;
            // The scratch directory's name is random: results name the
            // rig's output `frames/...`, so the same plan gives the same
            // results.json on every run.
            trace.format = trace.format.replace(&out.display().to_string(), "frames");
            let found = find_segments_with(&self.segments(), &trace, &source, &self.detection)
                .map_err(|e| self.fail(case, e.to_string()))?;
            if let Some(log) = &light_source {
                let frame_s = 1.0 / self.fps;
                for w in sequence::timing_warnings(&found.steps, &log.steps, frame_s) {
                    eprintln!("warning: case `{}`: {w}", case.id);
                }
            }
            let mut acq = to_acquisition(&trace, &found, &self.rois, self.capture.saturation_dn);
            if self.colour {
                keep_colour_planes(&mut acq, &trace, &self.rois, &source)
                    .map_err(|e| self.fail(case, format!("the command's frames: {e}")))?;
            }
            let camera = self.camera_log(case, trace.stated_fps);
            let kept = self.keep_recording(case, &out)?;
            acq.capture = Some(CaptureSummary {
                source: format!("command: {}", self.argv.join(" ")),
                format: trace.format.clone(),
                timestamps: trace.timestamps,
                segments: found,
                time_base_s: trace.time_base_s,
                stated_frame_rate_fps: trace.stated_fps,
                light_source,
                camera,
                kept,
                // The recording may be gone after the analysis: no frame of
                // it is shown.
                lit_frame: None,
            });
            Ok(acq)
        })();
        drop(scratch);
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_killed_runs_rig_still_running_is_stopped_before_its_scratch_goes() {
        // The scratch directory of a run that no longer exists (no pid is
        // that large), and its rig, still writing into it.
        let dead = u32::MAX - 1;
        let scratch = std::env::temp_dir().join(format!("{SCRATCH_PREFIX}{dead}-case-x1"));
        std::fs::create_dir_all(scratch.join("frames")).unwrap();
        let mut rig = Command::new("sleep")
            .arg("30")
            .env("LEDFLICKER_OUT_DIR", scratch.join("frames"))
            .spawn()
            .unwrap();
        // Not one of its processes: another directory's name as a prefix.
        let mut other = Command::new("sleep")
            .arg("30")
            .env(
                "LEDFLICKER_OUT_DIR",
                format!("{}9/frames", scratch.display()),
            )
            .spawn()
            .unwrap();
        // /proc shows the environment once the child has exec'd.
        std::thread::sleep(Duration::from_millis(200));
        let stale = clean_stale_scratch();
        assert!(!scratch.exists());
        let pids: Vec<u32> = stale.stopped.iter().map(|(p, _)| *p).collect();
        assert_eq!(pids, [rig.id()]);
        assert!(stale.warning().unwrap().contains("sleep 30"));
        let status = rig.wait().unwrap();
        assert_eq!(
            std::os::unix::process::ExitStatusExt::signal(&status),
            Some(9)
        );
        assert!(
            other.try_wait().unwrap().is_none(),
            "a stranger was stopped"
        );
        other.kill().unwrap();
        other.wait().unwrap();
    }
}
