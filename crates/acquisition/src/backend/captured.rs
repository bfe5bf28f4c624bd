//! The captured-data backend: `[dut] backend = "captured"`.
//!
//! Each `[[case]]` names a capture (video, Y4M, image frames or a CSV
//! trace). [`Captured::load`] reads them all up front, in parallel, so that
//! a bad input stops the run with a [`CaptureError`] naming the file and
//! frame (exit code 2) before any report is written; `acquire` then hands
//! out the traces. Segments come from the plan or are detected from the
//! luma of the LED ROIs, following the plan's sequence ([`super::segments`]).

use std::collections::HashMap;
use std::path::Path;

use rayon::prelude::*;

pub use super::segments::SegmentsFound;
use super::segments::{self, Detection};
use super::{Acquisition, Backend, BackendError, FrameInfo, RoiTrace};
use crate::capture::{self, CaptureError, CaptureTrace, ColourTransfer, ReadOptions, RoiRect};
use ledflicker_metrics::metrics::flicker::Segment;
use ledflicker_plan::plan::{CaptureConfig, Plan, Roi, RoiKind, SegmentSpec, Span, TestCase};
use ledflicker_plan::trace::{LitFrame, RenderedFrame, Run};

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
        // Linear when the plan has no colour: its planes are then unused.
        colour_transfer: cap.colour_transfer.unwrap_or(ColourTransfer::Linear),
        fps: cap.frame_rate_fps,
        decoder_threads: None,
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

/// Finds the segments of `trace` from the plan, or detects them by the
/// `off-then-pwm` rule over every ROI (for callers without a sequence).
pub fn find_segments(
    spec: &SegmentSpec,
    trace: &CaptureTrace,
    path: &Path,
) -> Result<SegmentsFound, CaptureError> {
    find_segments_with(spec, trace, path, &Detection::off_then_pwm())
}

/// Finds the segments of `trace` from the plan, or detects them from its
/// luma as `detection` says ([`segments::detect`]).
pub fn find_segments_with(
    spec: &SegmentSpec,
    trace: &CaptureTrace,
    path: &Path,
    detection: &Detection,
) -> Result<SegmentsFound, CaptureError> {
    if spec.detect() {
        return segments::detect(trace, detection, path);
    }
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
    let t0 = trace.time_s.first().copied().unwrap_or(0.0);
    let span_s = |(a, b): (u64, u64)| {
        let at = |k: u64| match trace.time_s.get(k as usize) {
            Some(t) => t - t0,
            None => {
                let last = trace.time_s[trace.time_s.len() - 1] - t0;
                last + last / (n.max(2) - 1) as f64
            }
        };
        (at(a), at(b))
    };
    let found = SegmentsFound {
        method: ledflicker_plan::trace::SegmentMethod::Plan,
        rule: None,
        off,
        on,
        pwm,
        off_time_s: off.map(span_s),
        on_time_s: on.map(span_s),
        pwm_time_s: span_s(pwm),
        capture_frames: n,
        threshold_dn: None,
        settle_s: None,
        levels_dn: None,
        steps: Vec::new(),
        text: String::new(),
        signal: Vec::new(),
    };
    Ok(found.with_text("given in the plan"))
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
            rgb: None,
        })
        .collect();
    Acquisition {
        frames,
        rois: traces,
        saturation_dn: saturation_dn.unwrap_or(trace.full_scale_dn * 240.0 / 255.0),
        capture: None,
    }
}

/// Gives each LED ROI of `acq` its R, G and B means, frame by frame, from
/// `trace`: the colour planes of a plan with colour. A capture without
/// colour is refused, naming it: its colour figures cannot be made.
pub fn keep_colour_planes(
    acq: &mut Acquisition,
    trace: &CaptureTrace,
    rois: &[Roi],
    path: &Path,
) -> Result<(), CaptureError> {
    let Some(rgb) = &trace.rgb else {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "the plan has colour (scene.led-chromaticity-xy) but this capture has no R, G and B: {}",
                grey_reason(&trace.format)
            ),
            hint: "record RGB frames (RGB PNG or TIFF, or a colour video with capture.video-decode = \"rgb\"), or remove the colour keys from the plan".to_string(),
        });
    };
    for ((out, roi), planes) in acq.rois.iter_mut().zip(rois).zip(rgb) {
        if roi.kind == RoiKind::Led {
            out.rgb = Some(
                acq.frames
                    .iter()
                    .map(|f| planes[f.index as usize])
                    .collect(),
            );
        }
    }
    Ok(())
}

/// Why a capture of `format` has no colour planes.
fn grey_reason(format: &str) -> &'static str {
    if format.starts_with("csv") {
        "a CSV trace holds luma only"
    } else if format.starts_with("y4m") {
        "a Y4M file is read as its Y' plane only"
    } else {
        "its frames are greyscale"
    }
}

pub use ledflicker_plan::trace::CaptureSummary;

/// The captured backend: every case's capture, read.
#[derive(Debug)]
pub struct Captured {
    acquisitions: HashMap<String, Acquisition>,
    /// Each case's capture and how it is read, for its sample frame.
    sources: HashMap<String, Source>,
    /// The plan's ROIs, pixels.
    rects: Vec<RoiRect>,
}

/// Most bytes a case's shown frames hold while it is rendered, per pixel of
/// its frame: two frames (the sample and the lit frame), each kept as runs
/// of equal grey levels (at most 16 bytes a pixel, for a frame whose
/// neighbours all differ).
const FRAME_BYTES_PER_PIXEL: u64 = 2 * 16;

/// Most bytes the cases a captured run has in flight beyond one per core
/// may hold in frames ([`Backend::cases_at_once`]): 64 MB, two extra cases
/// of 1280 x 800 frames.
const EXTRA_FRAMES_BYTES: u64 = 64 << 20;

/// Cases of `videos` videos of at most `pixels` pixels a frame worth
/// running at once on `cores` cores: one per video, at most
/// [`capture::AT_ONCE`], and beyond one per core only as many as
/// [`EXTRA_FRAMES_BYTES`] of frames allow. (A worker hands on a finished
/// case deflated for the store, so the queue between the workers and the
/// store holds no frames as runs.)
fn cases_at_once(videos: usize, pixels: u64, cores: usize) -> usize {
    let per_case = (pixels * FRAME_BYTES_PER_PIXEL).max(1);
    let extra = usize::try_from(EXTRA_FRAMES_BYTES / per_case).unwrap_or(usize::MAX);
    videos
        .min(capture::AT_ONCE)
        .min(cores.saturating_add(extra))
}

/// A case's capture, to read one frame of it again.
#[derive(Debug)]
struct Source {
    path: std::path::PathBuf,
    opts: ReadOptions,
    /// For a video with its frames' times: the times, the frame size and
    /// how it was read, so that a frame is read by seeking.
    seek: Option<(Vec<f64>, (u32, u32), capture::VideoRead)>,
}

impl Captured {
    /// Reads every case's capture, all at once ([`capture::read_captures`]),
    /// then finds each one's segments (in parallel, on the current rayon
    /// pool). A reading error comes first; then the segments error of the
    /// first such case in plan order.
    pub fn load(plan: &Plan) -> Result<Self, CaptureError> {
        let Some(cap) = &plan.capture else {
            return Ok(Self {
                acquisitions: HashMap::new(),
                sources: HashMap::new(),
                rects: Vec::new(),
            });
        };
        let rects = roi_rects(&plan.rois);
        let names: Vec<String> = plan.rois.iter().map(|r| r.name.clone()).collect();
        let opts = read_options(cap);
        let paths: Vec<&Path> = cap.cases.iter().map(|c| c.source.as_path()).collect();
        let traces = capture::read_captures(&paths, &rects, &names, &opts)?;
        let detection = Detection::for_plan(plan);
        let led = plan.rois.iter().position(|r| r.kind == RoiKind::Led);
        let seeks: Vec<_> = traces
            .iter()
            .map(|t| {
                let video = t.video.filter(|v| v.origin_s.is_some())?;
                Some((t.time_s.clone(), t.frame_size, video))
            })
            .collect();
        let acquisitions = cap
            .cases
            .par_iter()
            .zip(traces)
            .map(|(c, trace)| {
                let found = find_segments_with(&c.segments, &trace, &c.source, &detection)?;
                let mut acq = to_acquisition(&trace, &found, &plan.rois, cap.saturation_dn);
                if plan.colour.is_some() {
                    keep_colour_planes(&mut acq, &trace, &plan.rois, &c.source)?;
                }
                acq.capture = Some(CaptureSummary {
                    source: c.source_text.clone(),
                    format: trace.format.clone(),
                    timestamps: trace.timestamps,
                    segments: found,
                    time_base_s: trace.time_base_s,
                    stated_frame_rate_fps: trace.stated_fps,
                    light_source: None,
                    camera: None,
                    kept: None,
                    // A CSV trace has no frame to show.
                    lit_frame: led
                        .filter(|_| capture::source_kind(&c.source) != capture::SourceKind::Csv)
                        .and_then(|led| LitFrame::of(&acq, led)),
                });
                Ok((c.id.clone(), acq))
            })
            .collect::<Vec<Result<_, CaptureError>>>()
            .into_iter()
            .collect::<Result<HashMap<_, _>, CaptureError>>()?;
        let sources = cap
            .cases
            .iter()
            .zip(seeks)
            .map(|(c, seek)| {
                let source = Source {
                    path: c.source.clone(),
                    opts,
                    seek,
                };
                (c.id.clone(), source)
            })
            .collect();
        Ok(Self {
            acquisitions,
            sources,
            rects,
        })
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

    /// A case's frames come from its own FFmpeg process, so a case waits
    /// on a pipe while it is rendered: more cases than cores keep the cores
    /// busy ([`cases_at_once`]). Only when every case is a video: the
    /// extra cases' frames are counted at the videos' size.
    fn cases_at_once(&self) -> Option<usize> {
        let videos: Vec<_> = self.sources.values().map(|s| s.seek.as_ref()).collect();
        if videos.is_empty() || videos.iter().any(Option::is_none) {
            return None;
        }
        let pixels = videos
            .iter()
            .flatten()
            .map(|(_, (w, h), _)| u64::from(*w) * u64::from(*h))
            .max()
            .unwrap_or(0);
        Some(cases_at_once(
            videos.len(),
            pixels,
            rayon::current_num_threads(),
        ))
    }

    /// Frame `frame` of the case's capture, read again (frames are not kept
    /// while the traces are made): the sample frame the report shows, with
    /// its ROIs, as the simulator's rendered frame is. None for a CSV trace.
    fn render_frame(
        &self,
        case: &TestCase,
        frame: u64,
    ) -> Option<Result<RenderedFrame, BackendError>> {
        self.render_frames(case, &[frame]).pop().flatten()
    }

    /// The frames of a video are read by seeking, all in one FFmpeg process;
    /// a frame that cannot be sought, or whose seek lands elsewhere, is
    /// read from the start.
    fn render_frames(
        &self,
        case: &TestCase,
        frames: &[u64],
    ) -> Vec<Option<Result<RenderedFrame, BackendError>>> {
        let Some(source) = self.sources.get(&case.id) else {
            return frames.iter().map(|_| None).collect();
        };
        let (path, opts) = (&source.path, &source.opts);
        // A CSV trace holds ROI means, not a picture.
        if capture::source_kind(path) == capture::SourceKind::Csv {
            return frames.iter().map(|_| None).collect();
        }
        let error = |message: String| BackendError {
            backend: "captured".to_string(),
            case: case.id.clone(),
            message,
        };
        let mut grab = Grab::default();
        let landed = match self.seek(case, source, frames, &mut grab) {
            Ok(landed) => landed,
            Err(e) => {
                return frames
                    .iter()
                    .map(|_| Some(Err(error(e.to_string()))))
                    .collect();
            }
        };
        // Moved out, not copied (a frame can be tens of megabytes); a frame
        // asked for twice is read from the start the second time.
        let sought: Vec<_> = frames
            .iter()
            .zip(landed)
            .map(|(frame, landed)| landed.then(|| grab.pictures.remove(frame)).flatten())
            .collect();
        // The frames of seeks that landed elsewhere go before any is read
        // again from the start.
        drop(grab);
        frames
            .par_iter()
            .zip(sought)
            .map(|(&frame, sought)| {
                let picture = match sought {
                    Some(picture) => Some(picture),
                    None => {
                        let mut one = Grab::default();
                        let wanted = (&mut one, frame);
                        match capture::read_grey_frame(path, opts, frame, &mut Only(wanted)) {
                            Ok(full_scale_dn) => one.pictures.remove(&frame).map(|mut picture| {
                                picture.full_scale_dn = full_scale_dn;
                                picture
                            }),
                            Err(e) => return Some(Err(error(e.to_string()))),
                        }
                    }
                };
                Some(picture.ok_or_else(|| {
                    error(format!(
                        "frame {frame} is not in `{}` on a second read",
                        path.display()
                    ))
                }))
            })
            .collect()
    }
}

impl Captured {
    /// Reads `frames` of `case`'s video into `grab` by seeking, in one
    /// process, and says for each whether the frame that came is the one
    /// wanted (its ROI means are the trace's). False for a frame with no
    /// seek to make: frame 0 (as cheap from the start), a frame outside the
    /// segments (no means to check by), a capture that is not a video with
    /// times.
    fn seek(
        &self,
        case: &TestCase,
        source: &Source,
        frames: &[u64],
        grab: &mut Grab,
    ) -> Result<Vec<bool>, CaptureError> {
        let mut landed = vec![false; frames.len()];
        let Some((times, size, video)) = &source.seek else {
            return Ok(landed);
        };
        let (Some(origin), Some(acq)) = (video.origin_s, self.acquisitions.get(&case.id)) else {
            return Ok(landed);
        };
        let means: Vec<Vec<f64>> = frames
            .iter()
            .map(|&frame| {
                let row = acq.frames.iter().position(|f| f.index == frame);
                row.map_or_else(Vec::new, |row| {
                    acq.rois.iter().map(|r| r.luma[row]).collect()
                })
            })
            .collect();
        let mut sought = Vec::new();
        let mut at = Vec::new();
        for (i, (&frame, means)) in frames.iter().zip(&means).enumerate() {
            let k = frame as usize;
            let (Some(&before), Some(&time)) =
                (k.checked_sub(1).and_then(|b| times.get(b)), times.get(k))
            else {
                continue;
            };
            if means.is_empty() {
                continue;
            }
            sought.push(capture::SeekTo {
                frame,
                at_s: origin + (before + time) / 2.0,
                means,
            });
            at.push(i);
        }
        if sought.is_empty() {
            return Ok(landed);
        }
        let seek = capture::FrameSeek {
            size: *size,
            video: *video,
            rois: &self.rects,
            frames: &sought,
        };
        let got = capture::read_video_frames_seeking(&source.path, &source.opts, &seek, grab)?;
        for (i, ok) in at.into_iter().zip(got) {
            landed[i] = ok;
        }
        Ok(landed)
    }
}

/// Keeps frames of a capture, whole, as runs of equal grey levels (never
/// a value per pixel: a captured frame is mostly runs): the first picture
/// handed over under each number, as 8-bit output until told otherwise.
#[derive(Default)]
struct Grab {
    pictures: std::collections::BTreeMap<u64, RenderedFrame>,
}

impl capture::FrameSink for Grab {
    fn frame(&mut self, f: &capture::GreyFrame<'_>) {
        if self.pictures.contains_key(&f.index) {
            return;
        }
        let mut row = vec![0u32; f.width() as usize];
        let rows = (0..f.height())
            .map(|y| {
                f.row(y, &mut row);
                let mut runs: Vec<Run> = Vec::new();
                for value in row.iter().map(|&v| f64::from(v)) {
                    match runs.last_mut() {
                        Some(r) if r.value.to_bits() == value.to_bits() => r.len += 1,
                        _ => runs.push(Run { len: 1, value }),
                    }
                }
                // At most the 16 bytes of a run per pixel, not a doubled
                // vector's spare room.
                runs.shrink_to_fit();
                runs
            })
            .collect();
        let picture = RenderedFrame::from_runs(f.index, f.width(), 255.0, rows);
        self.pictures.insert(f.index, picture);
    }
}

/// Hands only frame `.1` to the grab `.0`.
struct Only<'g>((&'g mut Grab, u64));

impl capture::FrameSink for Only<'_> {
    fn frame(&mut self, f: &capture::GreyFrame<'_>) {
        let (grab, want) = &mut self.0;
        if f.index == *want {
            grab.frame(f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A captured backend of `videos` videos of `w` x `h` pixels.
    fn of_videos(videos: usize, (w, h): (u32, u32)) -> Captured {
        let opts = ReadOptions {
            luma: capture::LumaWeights::Bt601,
            video_decode: capture::VideoDecode::Rgb,
            range: capture::VideoRange::Auto,
            colour_transfer: capture::ColourTransfer::Linear,
            fps: None,
            decoder_threads: None,
        };
        let video = capture::VideoRead {
            origin_s: Some(0.0),
            full_range: false,
        };
        let sources = (0..videos)
            .map(|i| {
                let source = Source {
                    path: format!("v{i}.mp4").into(),
                    opts,
                    seek: Some((vec![0.0, 0.1], (w, h), video)),
                };
                (format!("case{i}"), source)
            })
            .collect();
        Captured {
            acquisitions: HashMap::new(),
            sources,
            rects: Vec::new(),
        }
    }

    /// One case per video, at most 8, and no more beyond one per core than
    /// 64 MB of frames allow: two more for 1280 x 800 frames, one for
    /// 1920 x 1080, none for 3840 x 2160; a plan with a capture that is
    /// not a video keeps one per core.
    #[test]
    fn a_captured_run_takes_a_case_per_video_as_far_as_memory_allows() {
        let px = |w: u64, h: u64| w * h;
        assert_eq!(cases_at_once(3, px(64, 48), 2), 3);
        assert_eq!(cases_at_once(20, px(64, 48), 2), capture::AT_ONCE);
        assert_eq!(cases_at_once(20, px(1280, 800), 2), 4);
        assert_eq!(cases_at_once(20, px(1920, 1080), 2), 3);
        assert_eq!(cases_at_once(20, px(3840, 2160), 2), 2);
        assert_eq!(cases_at_once(20, px(3840, 2160), 12), capture::AT_ONCE);
        assert_eq!(of_videos(0, (1280, 800)).cases_at_once(), None);
        let cores = rayon::current_num_threads();
        assert_eq!(
            of_videos(3, (64, 48)).cases_at_once(),
            Some(cases_at_once(3, px(64, 48), cores))
        );
        let mut mixed = of_videos(3, (64, 48));
        if let Some(s) = mixed.sources.get_mut("case0") {
            s.seek = None;
        }
        assert_eq!(mixed.cases_at_once(), None);
    }
}
