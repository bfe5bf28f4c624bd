//! `roi --detect`: LED ROIs proposed from the step between a capture's lit
//! and dark frames (docs/roi.md).
//!
//! Two reads of the capture, each streamed frame by frame:
//! 1. the mean of tiles of about 1/4096 of the frame; the tiles that change
//!    most stand in for the LED ROIs, and the plan's segment detection
//!    ([`ledflicker_acquisition::backend::segments`]) finds the ON -> OFF step of the paper's
//!    sequence on them, or, when the capture has none, the step from a
//!    dark baseline to the light (the `off-then-pwm` rule);
//! 2. per pixel, the mean over the lit segment (ON, or PWM after a dark
//!    baseline) and the mean and spread over the OFF segment.
//!
//! A pixel is lit when its lit mean exceeds its OFF mean by
//! [`NOISE_FACTOR`] times the frame's noise (the median over pixels of the
//! OFF-segment spread), and by at least [`MIN_STEP_OF_FULL_SCALE`] of full
//! scale. Lit pixels are grouped into 4-connected blobs; inside each blob
//! one strip of 2 rows by up to 100 px (the paper's ROI) is proposed where
//! both rows are lit, and a background ROI of the same size beside the blob
//! where nothing changes.

use std::path::{Path, PathBuf};

use ledflicker_acquisition::backend::segments::{self, Detection};
use ledflicker_acquisition::capture::{
    self, CaptureError, CaptureTrace, FrameSink, GreyFrame, ReadOptions, RoiRect,
};
use ledflicker_plan::plan::{RoiKind, Sequence};
use ledflicker_plan::trace::{DetectionRule, SegmentsFound};

/// A pixel is lit when its step exceeds this many times the frame's noise.
pub const NOISE_FACTOR: f64 = 6.0;
/// ...and this fraction of full scale (2.55 DN of 255): compression and
/// quantisation leave steps of a DN or two where nothing changed.
pub const MIN_STEP_OF_FULL_SCALE: f64 = 0.01;
/// Blobs of fewer pixels are noise, not a lamp.
pub const MIN_BLOB_PX: u64 = 8;
/// At most this many blobs get proposals (the largest).
pub const MAX_BLOBS: usize = 64;
/// The paper's ROI: 2 rows...
pub const STRIP_ROWS: u32 = 2;
/// ...by up to 100 px.
pub const STRIP_MAX_PX: u32 = 100;
/// A strip narrower than this is not proposed.
pub const STRIP_MIN_PX: u32 = 4;
/// Gap between a blob and its background ROI, px.
const BACKGROUND_GAP_PX: u32 = 4;
/// Tiles of the first read: about this many per frame.
const TILES_PER_FRAME: f64 = 4096.0;
/// Tiles whose luma range is at least this share of the largest range
/// stand in for the LED ROIs in segment detection.
const LED_TILE_SHARE: f64 = 0.5;

/// What `roi --detect` reads and which sequence it expects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectOptions {
    /// How to read the capture.
    pub read: ReadOptions,
    /// Steady-ON duration of the sequence, seconds (> 0).
    pub on_s: f64,
    /// OFF duration of the sequence, seconds (> 0).
    pub off_s: f64,
    /// Frames within this time after a step are left out, seconds (>= 0).
    pub settle_s: f64,
}

/// A 4-connected group of lit pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Bounding box, frame pixels.
    pub bbox: RoiRect,
    /// Lit pixels.
    pub area_px: u64,
    /// Mean step (lit minus OFF) over the blob's pixels, DN.
    pub step_dn: f64,
    /// Index of the blob's label in [`Proposal::labels`] (1-based).
    pub label: u32,
}

/// A proposed ROI.
#[derive(Debug, Clone, PartialEq)]
pub struct ProposedRoi {
    /// Name, unique: `led<N>`, `background<N>` for blob N (1-based).
    pub name: String,
    /// LED strip or background.
    pub kind: RoiKind,
    /// The rectangle, frame pixels.
    pub rect: RoiRect,
    /// The blob it belongs to or stands beside (0-based in [`Proposal::blobs`]).
    pub blob: usize,
}

/// What detection found in a capture.
#[derive(Clone)]
pub struct Proposal {
    /// The capture.
    pub capture: PathBuf,
    /// Frame width and height, px.
    pub frame_size: (u32, u32),
    /// Full scale of the source, DN.
    pub full_scale_dn: f64,
    /// The rule that found the step.
    pub rule: DetectionRule,
    /// Lit frames (first, one past the last): ON, or PWM after a dark baseline.
    pub lit_frames: (u64, u64),
    /// OFF frames (first, one past the last).
    pub off_frames: (u64, u64),
    /// Frame noise: median over pixels of the OFF-segment standard deviation, DN.
    pub noise_dn: f64,
    /// Step above which a pixel is lit, DN.
    pub threshold_dn: f64,
    /// Blobs, in reading order (top to bottom, then left to right).
    pub blobs: Vec<Blob>,
    /// Blobs found beyond [`MAX_BLOBS`] or smaller than [`MIN_BLOB_PX`].
    pub blobs_left_out: usize,
    /// Proposed ROIs: each blob's strip, then its background ROI.
    pub rois: Vec<ProposedRoi>,
    /// Per pixel, row-major: the blob label (1-based into `blobs`' `label`), 0 when unlit.
    pub labels: Vec<u32>,
    /// Per pixel, row-major: mean luma over the lit frames, DN (the preview).
    pub lit_mean: Vec<f32>,
}

// Without the per-pixel arrays, which would fill a terminal.
impl std::fmt::Debug for Proposal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Proposal")
            .field("capture", &self.capture)
            .field("frame_size", &self.frame_size)
            .field("rule", &self.rule)
            .field("lit_frames", &self.lit_frames)
            .field("off_frames", &self.off_frames)
            .field("noise_dn", &self.noise_dn)
            .field("threshold_dn", &self.threshold_dn)
            .field("blobs", &self.blobs)
            .field("rois", &self.rois)
            .finish_non_exhaustive()
    }
}

impl Proposal {
    /// The blob (0-based) that pixel (x, y) belongs to.
    pub fn blob_at(&self, x: u32, y: u32) -> Option<usize> {
        let (w, h) = self.frame_size;
        if x >= w || y >= h {
            return None;
        }
        let l = self.labels[y as usize * w as usize + x as usize];
        self.blobs.iter().position(|b| b.label == l && l != 0)
    }
}

/// Proposes ROIs for the capture at `path`.
pub fn detect(path: &Path, opts: &DetectOptions) -> Result<Proposal, CaptureError> {
    let mut tiles = TileSink::default();
    let trace = capture::read_grey_frames(path, &opts.read, &mut tiles)?;
    let (w, h) = trace.frame_size;
    let full_scale = trace.full_scale_dn;
    let times = trace.time_s.clone();
    let found = find_step(path, opts, &tiles, trace)?;
    let (lit, off) = windows(&found, &times, opts.on_s);
    let mut stats = WindowSink::new(w, h, lit, off);
    capture::read_grey_frames(path, &opts.read, &mut stats)?;
    let field = stats.finish();
    let noise = median(field.off_sd.clone());
    let threshold = (NOISE_FACTOR * noise).max(MIN_STEP_OF_FULL_SCALE * full_scale);
    let (labels, blobs, left_out) = find_blobs(&field.step, w, h, threshold);
    if blobs.is_empty() {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "no lit region: no {MIN_BLOB_PX} or more connected pixels are brighter in frames {}..{} than in the OFF frames {}..{} by {threshold:.2} DN (noise {noise:.2} DN)",
                lit.0, lit.1, off.0, off.1
            ),
            hint: "the LED must be in view and lit in the ON segment; check the capture, or give --on-s and --off-s of its sequence".to_string(),
        });
    }
    let rois = propose(&labels, &blobs, &field.step, threshold, (w, h));
    Ok(Proposal {
        capture: path.to_path_buf(),
        frame_size: (w, h),
        full_scale_dn: full_scale,
        rule: found.rule.unwrap_or(DetectionRule::Sequence),
        lit_frames: lit,
        off_frames: off,
        noise_dn: noise,
        threshold_dn: threshold,
        blobs,
        blobs_left_out: left_out,
        rois,
        labels,
        lit_mean: field.lit_mean,
    })
}

/// The lit and OFF frame windows of the segments found. After a dark
/// baseline the lit window is the PWM segment's first `on_s` seconds (as
/// long as an ON segment): more frames would not place the LED better,
/// only take longer.
fn windows(found: &SegmentsFound, trace_times: &[f64], on_s: f64) -> ((u64, u64), (u64, u64)) {
    let off = found.off.unwrap_or((0, 0));
    let lit = match found.rule {
        Some(DetectionRule::OffThenPwm) => {
            let (a, b) = found.pwm;
            let t0 = trace_times.get(a as usize).copied().unwrap_or(0.0);
            let end = trace_times.partition_point(|&t| t < t0 + on_s) as u64;
            (a, end.clamp(a + 1, b.max(a + 1)))
        }
        _ => found.on.unwrap_or(found.pwm),
    };
    (lit, off)
}

/// The ON -> OFF step of the paper's sequence, or else the step from a dark
/// baseline to the light, on the tiles that change most.
fn find_step(
    path: &Path,
    opts: &DetectOptions,
    tiles: &TileSink,
    mut trace: CaptureTrace,
) -> Result<SegmentsFound, CaptureError> {
    trace.luma = tiles.traces();
    let led_rois = changing_tiles(&trace.luma);
    let range = led_rois.first().map_or(0.0, |&i| spread(&trace.luma[i]));
    if range < segments::MIN_STEP_OF_FULL_SCALE * trace.full_scale_dn {
        return Err(CaptureError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "no ON -> OFF step: no part of the {}x{} frame changes by more than {range:.2} DN over the {} frames",
                trace.frame_size.0,
                trace.frame_size.1,
                trace.time_s.len()
            ),
            hint: "record the paper's sequence (ON, OFF, PWM) or a dark baseline before the light comes on, with the LED in view".to_string(),
        });
    }
    // The PWM segment's length does not matter to where the LED is: the
    // capture need only go on past the OFF segment.
    let sequence = Sequence {
        on_s: opts.on_s,
        off_s: opts.off_s,
        pwm_s: opts.on_s.min(opts.off_s),
    };
    let det = Detection {
        sequence,
        settle_s: opts.settle_s,
        led_rois: led_rois.clone(),
    };
    let by_sequence = match segments::detect(&trace, &det, path) {
        Ok(found) => return Ok(found),
        Err(e) => e,
    };
    let baseline = Detection {
        settle_s: opts.settle_s,
        led_rois,
        ..Detection::off_then_pwm()
    };
    segments::detect(&trace, &baseline, path).map_err(|by_baseline| CaptureError::Invalid {
        path: path.to_path_buf(),
        message: format!(
            "no ON -> OFF step found in the parts of the frame that change most; by the sequence ({} s ON, {} s OFF): {}; by a dark baseline then light: {}",
            opts.on_s,
            opts.off_s,
            detail(&by_sequence),
            detail(&by_baseline)
        ),
        hint: "record the paper's sequence (2 s ON, 2 s OFF, then PWM) with the LED in view, or give --on-s and --off-s of the recording".to_string(),
    })
}

/// The message of a refusal, without its path and hint.
fn detail(e: &CaptureError) -> String {
    match e {
        CaptureError::Invalid { message, .. } => message.clone(),
        other => other.to_string(),
    }
}

/// Indices of the tiles whose luma range is within [`LED_TILE_SHARE`] of
/// the largest, largest first.
fn changing_tiles(luma: &[Vec<f64>]) -> Vec<usize> {
    let ranges: Vec<f64> = luma.iter().map(|t| spread(t)).collect();
    let top = ranges.iter().copied().fold(0.0, f64::max);
    let mut picked: Vec<usize> = (0..ranges.len())
        .filter(|&i| top > 0.0 && ranges[i] >= LED_TILE_SHARE * top)
        .collect();
    picked.sort_by(|&a, &b| ranges[b].total_cmp(&ranges[a]));
    picked
}

/// The 2nd to 98th percentile range of `v` (single outlier frames ignored).
fn spread(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let q = |p: f64| s[((s.len() - 1) as f64 * p).round() as usize];
    q(0.98) - q(0.02)
}

fn median(mut v: Vec<f32>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f32::total_cmp);
    f64::from(*m)
}

/// The first read: each frame's tile means.
#[derive(Default)]
struct TileSink {
    /// Tile side, px (0 before the first frame).
    side: u32,
    cols: u32,
    /// Pixels in each tile (edge tiles are smaller).
    counts: Vec<f64>,
    /// `means[frame][tile]`, DN.
    means: Vec<Vec<f64>>,
    row: Vec<u32>,
}

impl TileSink {
    fn setup(&mut self, w: u32, h: u32) {
        let side = ((f64::from(w) * f64::from(h) / TILES_PER_FRAME)
            .sqrt()
            .ceil() as u32)
            .max(8);
        let side = side + side % 2;
        let (cols, rows) = (w.div_ceil(side), h.div_ceil(side));
        self.side = side;
        self.cols = cols;
        self.counts = (0..rows * cols)
            .map(|t| {
                let (tx, ty) = (t % cols, t / cols);
                let tw = (w - tx * side).min(side);
                // The even rows of the tile (side is even).
                let (y0, y1) = (ty * side, (ty * side + side).min(h));
                let th = y1.div_ceil(2) - y0.div_ceil(2);
                f64::from(tw * th)
            })
            .collect();
        self.row = vec![0; w as usize];
    }

    /// `[tile][frame]`.
    fn traces(&self) -> Vec<Vec<f64>> {
        (0..self.counts.len())
            .map(|t| self.means.iter().map(|m| m[t]).collect())
            .collect()
    }
}

impl FrameSink for TileSink {
    fn frame(&mut self, f: &GreyFrame<'_>) {
        let (w, h) = (f.width(), f.height());
        if self.side == 0 {
            self.setup(w, h);
        }
        let mut sums = vec![0u64; self.counts.len()];
        // Every other row: the tiles' means stand in for the LED's only to
        // find the steps in time, and any lamp of 2 rows or more is seen.
        for y in (0..h).step_by(2) {
            f.row(y, &mut self.row);
            let base = (y / self.side * self.cols) as usize;
            for (x, &v) in self.row.iter().enumerate() {
                sums[base + x / self.side as usize] += u64::from(v);
            }
        }
        self.means.push(
            sums.iter()
                .zip(&self.counts)
                .map(|(&s, &n)| s as f64 / n)
                .collect(),
        );
    }
}

/// The second read: per-pixel sums over the lit and OFF windows.
struct WindowSink {
    width: usize,
    lit: (u64, u64),
    off: (u64, u64),
    lit_sum: Vec<u64>,
    off_sum: Vec<u64>,
    off_sq: Vec<u64>,
    row: Vec<u32>,
}

/// Per-pixel results of the second read, row-major.
struct Field {
    /// Lit mean minus OFF mean, DN.
    step: Vec<f32>,
    /// OFF-segment standard deviation, DN.
    off_sd: Vec<f32>,
    /// Lit mean, DN.
    lit_mean: Vec<f32>,
}

impl WindowSink {
    fn new(w: u32, h: u32, lit: (u64, u64), off: (u64, u64)) -> Self {
        let n = w as usize * h as usize;
        Self {
            width: w as usize,
            lit,
            off,
            lit_sum: vec![0; n],
            off_sum: vec![0; n],
            off_sq: vec![0; n],
            row: vec![0; w as usize],
        }
    }

    fn finish(self) -> Field {
        let n_lit = (self.lit.1 - self.lit.0).max(1) as f64;
        let n_off = (self.off.1 - self.off.0).max(1) as f64;
        let mut step = Vec::with_capacity(self.lit_sum.len());
        let mut off_sd = Vec::with_capacity(self.lit_sum.len());
        let mut lit_mean = Vec::with_capacity(self.lit_sum.len());
        for i in 0..self.lit_sum.len() {
            let l = self.lit_sum[i] as f64 / n_lit;
            let o = self.off_sum[i] as f64 / n_off;
            let var = (self.off_sq[i] as f64 / n_off - o * o).max(0.0);
            step.push((l - o) as f32);
            off_sd.push(var.sqrt() as f32);
            lit_mean.push(l as f32);
        }
        Field {
            step,
            off_sd,
            lit_mean,
        }
    }
}

impl FrameSink for WindowSink {
    fn frame(&mut self, f: &GreyFrame<'_>) {
        let k = f.index;
        let in_lit = (self.lit.0..self.lit.1).contains(&k);
        let in_off = (self.off.0..self.off.1).contains(&k);
        if !in_lit && !in_off {
            return;
        }
        for y in 0..f.height() {
            f.row(y, &mut self.row);
            let base = y as usize * self.width;
            for (x, &v) in self.row.iter().enumerate() {
                let v = u64::from(v);
                if in_lit {
                    self.lit_sum[base + x] += v;
                }
                if in_off {
                    self.off_sum[base + x] += v;
                    self.off_sq[base + x] += v * v;
                }
            }
        }
    }
}

/// Labels the 4-connected blobs of pixels whose step exceeds `threshold`.
/// Returns the labels (0 = unlit or left out), the blobs kept (at least
/// [`MIN_BLOB_PX`] pixels, the [`MAX_BLOBS`] largest, in reading order)
/// and how many were left out.
pub fn find_blobs(step: &[f32], w: u32, h: u32, threshold: f64) -> (Vec<u32>, Vec<Blob>, usize) {
    let (wu, n) = (w as usize, w as usize * h as usize);
    let lit = |i: usize| f64::from(step[i]) > threshold;
    let mut labels = vec![0u32; n];
    let mut found: Vec<Blob> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..n {
        if labels[start] != 0 || !lit(start) {
            continue;
        }
        let label = found.len() as u32 + 1;
        labels[start] = label;
        stack.push(start);
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        let (mut area, mut sum) = (0u64, 0.0f64);
        while let Some(i) = stack.pop() {
            let (x, y) = ((i % wu) as u32, (i / wu) as u32);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            area += 1;
            sum += f64::from(step[i]);
            let mut visit = |j: usize| {
                if labels[j] == 0 && lit(j) {
                    labels[j] = label;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - wu);
            }
            if y + 1 < h {
                visit(i + wu);
            }
        }
        found.push(Blob {
            bbox: RoiRect {
                x: x0,
                y: y0,
                width: x1 - x0 + 1,
                height: y1 - y0 + 1,
            },
            area_px: area,
            step_dn: sum / area as f64,
            label,
        });
    }
    let total = found.len();
    found.retain(|b| b.area_px >= MIN_BLOB_PX);
    found.sort_by(|a, b| b.area_px.cmp(&a.area_px).then(a.label.cmp(&b.label)));
    found.truncate(MAX_BLOBS);
    let mut keep = vec![false; total + 1];
    found.iter().for_each(|b| keep[b.label as usize] = true);
    labels.iter_mut().for_each(|l| {
        if !keep[*l as usize] {
            *l = 0;
        }
    });
    found.sort_by_key(|b| (b.bbox.y, b.bbox.x));
    let left_out = total - found.len();
    (labels, found, left_out)
}

/// Each blob's strip and background ROI.
pub fn propose(
    labels: &[u32],
    blobs: &[Blob],
    step: &[f32],
    threshold: f64,
    (w, h): (u32, u32),
) -> Vec<ProposedRoi> {
    let still = Still::new(labels, step, threshold, w, h);
    let mut out = Vec::new();
    for (k, blob) in blobs.iter().enumerate() {
        let Some(strip) = strip_in(labels, blob, w) else {
            continue;
        };
        out.push(ProposedRoi {
            name: format!("led{}", k + 1),
            kind: RoiKind::Led,
            rect: strip,
            blob: k,
        });
        if let Some(rect) = background_beside(&still, blob, strip) {
            out.push(ProposedRoi {
                name: format!("background{}", k + 1),
                kind: RoiKind::Background,
                rect,
                blob: k,
            });
        }
    }
    out
}

/// The widest strip of [`STRIP_ROWS`] rows, up to [`STRIP_MAX_PX`] wide,
/// whose pixels all belong to `blob`; among equally wide ones, the nearest
/// to the blob's centre. `None` when no strip of [`STRIP_MIN_PX`] fits.
fn strip_in(labels: &[u32], blob: &Blob, w: u32) -> Option<RoiRect> {
    let b = blob.bbox;
    if b.height < STRIP_ROWS {
        return None;
    }
    let (cx, cy) = (
        f64::from(b.x) + f64::from(b.width) / 2.0,
        f64::from(b.y) + f64::from(b.height) / 2.0,
    );
    let at = |x: u32, y: u32| labels[y as usize * w as usize + x as usize] == blob.label;
    // (width, distance from the centre, rect): the best so far.
    let mut best: Option<(u32, f64, RoiRect)> = None;
    for y in b.y..=b.y + b.height - STRIP_ROWS {
        let mut x = b.x;
        while x < b.x + b.width {
            if !(y..y + STRIP_ROWS).all(|r| at(x, r)) {
                x += 1;
                continue;
            }
            let start = x;
            while x < b.x + b.width && (y..y + STRIP_ROWS).all(|r| at(x, r)) {
                x += 1;
            }
            let width = (x - start).min(STRIP_MAX_PX);
            // Centred on the blob's centre as far as the run allows.
            let left = (cx - f64::from(width) / 2.0).round().max(f64::from(start)) as u32;
            let left = left.min(x - width);
            let rect = RoiRect {
                x: left,
                y,
                width,
                height: STRIP_ROWS,
            };
            let dist =
                (f64::from(left) + f64::from(width) / 2.0 - cx).hypot(f64::from(y) + 1.0 - cy);
            let better = match best {
                None => true,
                Some((bw, bd, _)) => width > bw || (width == bw && dist < bd),
            };
            if better {
                best = Some((width, dist, rect));
            }
        }
    }
    best.filter(|(width, _, _)| *width >= STRIP_MIN_PX)
        .map(|(_, _, r)| r)
}

/// Counts of changing pixels (lit or with a step beyond the threshold
/// either way), summed over rectangles in constant time.
struct Still {
    w: u32,
    h: u32,
    /// Integral image, (w + 1) x (h + 1).
    sum: Vec<u32>,
}

impl Still {
    fn new(labels: &[u32], step: &[f32], threshold: f64, w: u32, h: u32) -> Self {
        let (wu, stride) = (w as usize, w as usize + 1);
        let mut sum = vec![0u32; stride * (h as usize + 1)];
        for y in 0..h as usize {
            let mut row = 0u32;
            for x in 0..wu {
                let i = y * wu + x;
                row += u32::from(labels[i] != 0 || f64::from(step[i].abs()) > threshold);
                sum[(y + 1) * stride + x + 1] = sum[y * stride + x + 1] + row;
            }
        }
        Self { w, h, sum }
    }

    /// Whether `r` lies in the frame and nothing in it changes.
    fn holds(&self, r: RoiRect) -> bool {
        if r.x + r.width > self.w || r.y + r.height > self.h {
            return false;
        }
        let s = self.w as usize + 1;
        let at = |x: u32, y: u32| self.sum[y as usize * s + x as usize];
        let (x1, y1) = (r.x + r.width, r.y + r.height);
        at(x1, y1) + at(r.x, r.y) == at(r.x, y1) + at(x1, r.y)
    }
}

/// A rectangle of the strip's size where nothing changes, beside `blob`:
/// below it, above, right or left, the nearest first.
fn background_beside(still: &Still, blob: &Blob, strip: RoiRect) -> Option<RoiRect> {
    let b = blob.bbox;
    let (sw, sh) = (strip.width, strip.height);
    for k in 0..32u32 {
        let gap = BACKGROUND_GAP_PX + 4 * k;
        let candidates = [
            Some((strip.x, b.y + b.height + gap)),
            (b.y).checked_sub(gap + sh).map(|y| (strip.x, y)),
            Some((b.x + b.width + gap, strip.y)),
            (b.x).checked_sub(gap + sw).map(|x| (x, strip.y)),
        ];
        for (x, y) in candidates.into_iter().flatten() {
            let r = RoiRect {
                x,
                y,
                width: sw,
                height: sh,
            };
            if still.holds(r) {
                return Some(r);
            }
        }
    }
    None
}

/// The proposal as `[[roi]]` blocks of a plan, with comments saying what
/// was found.
pub fn to_toml(p: &Proposal) -> String {
    let mut s = format!(
        "# ROIs proposed by `ledflicker roi --detect` from `{}` ({}x{} px)\n",
        p.capture.display(),
        p.frame_size.0,
        p.frame_size.1
    );
    s.push_str(&format!(
        "# lit frames {}..{} ({}), OFF frames {}..{}; a pixel is lit above a step of {:.2} DN (noise {:.2} DN)\n",
        p.lit_frames.0,
        p.lit_frames.1,
        match p.rule {
            DetectionRule::Sequence => "the ON segment",
            DetectionRule::OffThenPwm => "after a dark baseline",
        },
        p.off_frames.0,
        p.off_frames.1,
        p.threshold_dn,
        p.noise_dn
    ));
    if p.blobs_left_out > 0 {
        s.push_str(&format!(
            "# {} smaller lit regions left out\n",
            p.blobs_left_out
        ));
    }
    for (k, b) in p.blobs.iter().enumerate() {
        s.push_str(&format!(
            "\n# lit region {}: x {}..{}, y {}..{} ({} px lit), mean step {:.1} DN\n",
            k + 1,
            b.bbox.x,
            b.bbox.x + b.bbox.width,
            b.bbox.y,
            b.bbox.y + b.bbox.height,
            b.area_px,
            b.step_dn
        ));
        let mine: Vec<&ProposedRoi> = p.rois.iter().filter(|r| r.blob == k).collect();
        if mine.is_empty() {
            s.push_str("# no strip of 2 rows fits inside it\n");
        }
        if mine.len() == 1 {
            s.push_str("# no still region of the strip's size beside it for a background ROI\n");
        }
        for r in mine {
            s.push_str(&format!(
                "[[roi]]\nname = \"{}\"\nkind = \"{}\"\nx-px = {}\ny-px = {}\nwidth-px = {}\nheight-px = {}\n",
                r.name,
                match r.kind {
                    RoiKind::Led => "led",
                    RoiKind::Background => "background",
                },
                r.rect.x,
                r.rect.y,
                r.rect.width,
                r.rect.height
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests;
