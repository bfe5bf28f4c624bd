//! The captured-data backend: `[dut] backend = "captured"`.
//!
//! Each `[[case]]` names a capture (video, Y4M, image frames or a CSV
//! trace). [`Captured::load`] reads them all up front, in parallel, so that
//! a bad input stops the run with a [`CaptureError`] naming the file and
//! frame (exit code 2) before any report is written; `acquire` then hands
//! out the traces. Segments come from the plan or are detected from the
//! luma: a dark baseline, then the step where the light comes on.

use std::collections::HashMap;
use std::path::Path;

use rayon::prelude::*;

use super::{Acquisition, Backend, BackendError, FrameInfo, RoiTrace};
use crate::capture::{self, CaptureError, CaptureTrace, ReadOptions, RoiRect};
use crate::metrics::flicker::Segment;
use crate::plan::{CaptureConfig, Plan, Roi, SegmentSpec, Span, TestCase};

/// Frames kept out of the segments on each side of a detected ON step.
pub const DETECT_GUARD_FRAMES: u64 = 2;
/// Time skipped after a detected ON step before the PWM segment starts,
/// seconds (auto-exposure settling).
pub const DETECT_SETTLE_S: f64 = 0.5;

/// Where a case's segments are, in frames (start inclusive, end exclusive).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentsFound {
    /// "plan" or "detected".
    pub method: &'static str,
    /// OFF reference frames.
    pub off: Option<(u64, u64)>,
    /// Steady-ON frames.
    pub on: Option<(u64, u64)>,
    /// PWM frames.
    pub pwm: (u64, u64),
    /// Frames in the capture.
    pub capture_frames: u64,
    /// Detection threshold on the mean ROI luma, DN (detected only).
    pub threshold_dn: Option<f64>,
}

/// Turns the plan's ROIs into pixel rectangles.
pub fn roi_rects(rois: &[Roi]) -> Vec<RoiRect> {
    rois.iter()
        .map(|r| RoiRect {
            x: r.x_px,
            y: r.y_px,
            width: r.width_px,
            height: r.height_px,
        })
        .collect()
}

/// Read options of a plan's `[capture]`.
pub fn read_options(cap: &CaptureConfig) -> ReadOptions {
    ReadOptions {
        luma: cap.luma,
        video_decode: cap.video_decode,
        range: cap.video_range,
        fps: cap.frame_rate_fps,
    }
}

fn resolve(span: &Span, trace: &CaptureTrace) -> (u64, Option<u64>) {
    match *span {
        Span::Frames { start, end } => (start, end),
        Span::Seconds { start, end } => {
            let t0 = trace.time_s.first().copied().unwrap_or(0.0);
            let first_at = |t: f64| trace.time_s.iter().position(|&x| x - t0 >= t - 1e-9);
            let n = trace.time_s.len() as u64;
            let s = first_at(start).map_or(n, |i| i as u64);
            let e = end.map(|e| first_at(e).map_or(n, |i| i as u64));
            (s, e)
        }
    }
}

/// Finds the segments of `trace` from the plan or from its luma.
pub fn find_segments(
    spec: &SegmentSpec,
    trace: &CaptureTrace,
    path: &Path,
) -> Result<SegmentsFound, CaptureError> {
    let n = trace.time_s.len() as u64;
    let short = |what: &str, s: u64, e: Option<u64>| CaptureError::Invalid {
        path: path.to_path_buf(),
        message: format!(
            "the capture has {n} frames, shorter than the plan's {what} segment (frames {s}..{})",
            e.map_or("end".to_string(), |e| e.to_string())
        ),
        hint: "check the capture, or the segment keys (off-frames, pwm-frames, ...) in the plan"
            .to_string(),
    };
    if !spec.detect() {
        let get = |what: &str, span: &Option<Span>| -> Result<Option<(u64, u64)>, CaptureError> {
            let Some(span) = span else { return Ok(None) };
            let (s, e) = resolve(span, trace);
            if s >= n || e.is_some_and(|e| e > n) {
                return Err(short(what, s, e));
            }
            Ok(Some((s, e.unwrap_or(n))))
        };
        let off = get("OFF", &spec.off)?;
        let on = get("ON", &spec.on)?;
        let pwm = get("PWM", &spec.pwm)?.ok_or_else(|| short("PWM", 0, None))?;
        return Ok(SegmentsFound {
            method: "plan",
            off,
            on,
            pwm,
            capture_frames: n,
            threshold_dn: None,
        });
    }
    // Detection: the mean over ROIs per frame; a dark baseline, then the step.
    let m: Vec<f64> = (0..n as usize)
        .map(|k| trace.luma.iter().map(|t| t[k]).sum::<f64>() / trace.luma.len().max(1) as f64)
        .collect();
    let lo = m.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = m.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let fail = |message: String| CaptureError::Invalid {
        path: path.to_path_buf(),
        message,
        hint:
            "give the segments in the plan: off-frames = [a, b] and pwm-frames = [c] (or *-time-s)"
                .to_string(),
    };
    if hi - lo <= 0.02 * trace.full_scale_dn || !hi.is_finite() || !lo.is_finite() {
        return Err(fail(format!(
            "cannot detect segments: the ROI luma stays within {lo:.2}..{hi:.2} DN (no ON step)"
        )));
    }
    // The ON step: the first frame above a quarter of the range. The OFF
    // baseline ends where the luma first leaves the dark level (2 % of the
    // range), so a slow rise is not averaged into x_off.
    let threshold = lo + 0.25 * (hi - lo);
    let step = m.iter().position(|&x| x > threshold).unwrap_or(0) as u64;
    let rise = m
        .iter()
        .position(|&x| x > lo + 0.02 * (hi - lo))
        .unwrap_or(0) as u64;
    if rise <= DETECT_GUARD_FRAMES {
        return Err(fail(
            "cannot detect segments: the capture does not start with a dark OFF baseline"
                .to_string(),
        ));
    }
    let fps = if n > 1 {
        (n - 1) as f64 / (trace.time_s[n as usize - 1] - trace.time_s[0]).max(1e-9)
    } else {
        30.0
    };
    let pwm_start = step + ((DETECT_SETTLE_S * fps).round() as u64).max(DETECT_GUARD_FRAMES);
    if pwm_start + 2 > n {
        return Err(fail(format!(
            "the light comes on at frame {step}, too late for a PWM segment of 2 frames or more"
        )));
    }
    Ok(SegmentsFound {
        method: "detected",
        off: Some((0, rise - DETECT_GUARD_FRAMES)),
        on: None,
        pwm: (pwm_start, n),
        capture_frames: n,
        threshold_dn: Some(threshold),
    })
}

/// Builds the acquisition of a capture: frames inside a segment, labelled;
/// frames outside every segment are left out.
pub fn to_acquisition(
    trace: &CaptureTrace,
    found: &SegmentsFound,
    rois: &[Roi],
    saturation_dn: Option<f64>,
) -> Acquisition {
    let label = |k: u64| {
        let inside = |s: Option<(u64, u64)>| s.is_some_and(|(a, b)| k >= a && k < b);
        if inside(Some(found.pwm)) {
            Some(Segment::Pwm)
        } else if inside(found.off) {
            Some(Segment::Off)
        } else if inside(found.on) {
            Some(Segment::On)
        } else {
            None
        }
    };
    let keep: Vec<(usize, Segment)> = (0..trace.time_s.len())
        .filter_map(|k| label(k as u64).map(|s| (k, s)))
        .collect();
    let frames = keep
        .iter()
        .map(|&(k, segment)| FrameInfo {
            index: k as u64,
            time_s: trace.time_s[k],
            segment,
        })
        .collect();
    let traces = rois
        .iter()
        .zip(&trace.luma)
        .map(|(roi, luma)| RoiTrace {
            name: roi.name.clone(),
            luma: keep.iter().map(|&(k, _)| luma[k]).collect(),
            phase_envelope: None,
        })
        .collect();
    Acquisition {
        frames,
        rois: traces,
        saturation_dn: saturation_dn.unwrap_or(trace.full_scale_dn * 240.0 / 255.0),
    }
}

/// What was read for one case, for the report.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CaptureSummary {
    /// The source as written in the plan.
    pub source: String,
    /// What was read, e.g. "video h264 yuv420p 1280x800 (ffmpeg, rgb24)".
    pub format: String,
    /// Where frame times came from.
    pub timestamps: &'static str,
    /// Segments and how they were found.
    pub segments: SegmentsFound,
}

/// The captured backend: every case's capture, read.
#[derive(Debug)]
pub struct Captured {
    acquisitions: HashMap<String, Acquisition>,
    summaries: HashMap<String, CaptureSummary>,
}

impl Captured {
    /// Reads every case's capture (in parallel, on the current rayon pool).
    pub fn load(plan: &Plan) -> Result<Self, CaptureError> {
        let Some(cap) = &plan.capture else {
            return Ok(Self {
                acquisitions: HashMap::new(),
                summaries: HashMap::new(),
            });
        };
        let rects = roi_rects(&plan.rois);
        let names: Vec<String> = plan.rois.iter().map(|r| r.name.clone()).collect();
        let opts = read_options(cap);
        let loaded: Vec<(String, Acquisition, CaptureSummary)> = cap
            .cases
            .par_iter()
            .map(|c| {
                let trace = capture::read_capture(&c.source, &rects, &names, &opts)?;
                let found = find_segments(&c.segments, &trace, &c.source)?;
                let acq = to_acquisition(&trace, &found, &plan.rois, cap.saturation_dn);
                let summary = CaptureSummary {
                    source: c.source_text.clone(),
                    format: trace.format.clone(),
                    timestamps: trace.timestamps,
                    segments: found,
                };
                Ok((c.id.clone(), acq, summary))
            })
            .collect::<Result<_, CaptureError>>()?;
        let mut acquisitions = HashMap::new();
        let mut summaries = HashMap::new();
        for (id, acq, summary) in loaded {
            acquisitions.insert(id.clone(), acq);
            summaries.insert(id, summary);
        }
        Ok(Self {
            acquisitions,
            summaries,
        })
    }

    /// What was read for each case, by case id.
    pub fn summaries(&self) -> &HashMap<String, CaptureSummary> {
        &self.summaries
    }
}

impl Backend for Captured {
    fn id(&self) -> &str {
        "captured"
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        self.acquisitions
            .get(&case.id)
            .cloned()
            .ok_or_else(|| BackendError {
                backend: self.id().to_string(),
                case: case.id.clone(),
                message: "no capture was loaded for this case".to_string(),
            })
    }
}
