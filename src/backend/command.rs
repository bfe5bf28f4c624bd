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

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::captured::{CaptureSummary, find_segments, read_options, roi_rects, to_acquisition};
use super::{Acquisition, Backend, BackendError};
use crate::capture::{self, SourceKind};
use crate::plan::{CaptureConfig, Plan, Roi, SegmentSpec, Sequence, Span, TestCase};

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
    scratch: PathBuf,
    summaries: Arc<Mutex<HashMap<String, CaptureSummary>>>,
}

impl CommandRig {
    /// A rig for `plan`; `None` when the plan has no command.
    pub fn new(plan: &Plan) -> Option<Self> {
        let cap = plan.capture.clone()?;
        let cmd = cap.command.clone()?;
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
                .and_then(|d| d.canonicalize().ok())
                .unwrap_or_default(),
            capture: cap,
            sequence: plan.sequence,
            fps: plan.dut.camera.fps,
            rois: plan.rois.clone(),
            summaries: Arc::default(),
            scratch: std::env::temp_dir().join(format!("ledflicker-rig-{}", std::process::id())),
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

    /// Runs the command for `case`; returns the capture it left in `out`.
    fn run_command(&self, case: &TestCase, out: &Path) -> Result<PathBuf, BackendError> {
        let mut program = PathBuf::from(&self.argv[0]);
        let local = self.plan_dir.join(&program);
        if program.is_relative() && program.components().count() > 1 && local.exists() {
            program = local;
        }
        let args: Vec<String> = self.argv[1..]
            .iter()
            .map(|a| {
                let p = self.plan_dir.join(a);
                if Path::new(a).is_relative() && a.contains('/') && p.exists() {
                    p.display().to_string()
                } else {
                    a.clone()
                }
            })
            .collect();
        let env = self.env(case, out);
        let mut json = serde_json::Map::new();
        for (k, v) in &env {
            let key = k.trim_start_matches("LEDFLICKER_").to_ascii_lowercase();
            let value = v
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && key != "case_id" && key != "out_dir")
                .map_or(serde_json::Value::from(v.clone()), serde_json::Value::from);
            json.insert(key, value);
        }
        json.insert(
            "rois".to_string(),
            serde_json::to_value(&self.rois).unwrap_or_default(),
        );
        let exe = std::env::current_exe().unwrap_or_default();
        let mut child = Command::new(&program)
            .args(&args)
            .envs(env)
            .env("LEDFLICKER_EXE", exe)
            .current_dir(&self.plan_dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| self.fail(case, format!("cannot run `{}`: {e}", program.display())))?;
        if let Some(mut stdin) = child.stdin.take() {
            // A command that does not read stdin closes it early; not an error.
            let _ = stdin.write_all(serde_json::Value::Object(json).to_string().as_bytes());
        }
        let mut stderr = child.stderr.take();
        let err_thread = std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(e) = stderr.as_mut() {
                let _ = e.read_to_string(&mut s);
            }
            s
        });
        let start = Instant::now();
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if start.elapsed() > self.timeout => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(self.fail(
                        case,
                        format!(
                            "`{}` did not finish within {:.1} s and was killed\n    hint: raise [capture] timeout-s",
                            self.argv.join(" "),
                            self.timeout.as_secs_f64()
                        ),
                    ));
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(10)),
                Err(e) => return Err(self.fail(case, format!("waiting for the command: {e}"))),
            }
        };
        let stderr_text = err_thread.join().unwrap_or_default();
        if !status.success() {
            let tail: Vec<&str> = stderr_text.lines().rev().take(5).collect();
            return Err(self.fail(
                case,
                format!(
                    "`{}` failed ({status}){}",
                    self.argv.join(" "),
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
        // One capture file, or a directory of frames.
        let files: Vec<PathBuf> = std::fs::read_dir(out)
            .map_err(|e| self.fail(case, format!("cannot list `{}`: {e}", out.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.is_file()
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

    /// What was read for each case so far, by case id.
    pub fn summaries(&self) -> HashMap<String, CaptureSummary> {
        self.summaries.lock().map(|m| m.clone()).unwrap_or_default()
    }

    fn segments(&self) -> SegmentSpec {
        if !self.capture.segments.detect() {
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

impl Drop for CommandRig {
    fn drop(&mut self) {
        // Each case removes its own directory; this removes their parent.
        let _ = std::fs::remove_dir(&self.scratch);
    }
}

impl Backend for CommandRig {
    fn id(&self) -> &str {
        "command"
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        let out = self.scratch.join(&case.id);
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out)
            .map_err(|e| self.fail(case, format!("cannot create `{}`: {e}", out.display())))?;
        let result = (|| {
            let source = self.run_command(case, &out)?;
            let names: Vec<String> = self.rois.iter().map(|r| r.name.clone()).collect();
            // Frames without timestamps run at the plan's frame rate.
            let mut opts = read_options(&self.capture);
            opts.fps = opts.fps.or(Some(self.fps));
            let trace = capture::read_capture(&source, &roi_rects(&self.rois), &names, &opts)
                .map_err(|e| self.fail(case, format!("the command's frames: {e}")))?;
            let found = find_segments(&self.segments(), &trace, &source)
                .map_err(|e| self.fail(case, e.to_string()))?;
            let acq = to_acquisition(&trace, &found, &self.rois, self.capture.saturation_dn);
            if let Ok(mut m) = self.summaries.lock() {
                m.insert(
                    case.id.clone(),
                    CaptureSummary {
                        source: format!("command: {}", self.argv.join(" ")),
                        format: trace.format.clone(),
                        timestamps: trace.timestamps,
                        segments: found,
                    },
                );
            }
            Ok(acq)
        })();
        let _ = std::fs::remove_dir_all(&out);
        result
    }
}
