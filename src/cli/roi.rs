//! `ledflicker roi`: a plan's ROIs drawn on the first frame of each of its
//! captures, before a run; with `--detect`, ROIs proposed from a capture's
//! ON -> OFF step, as `[[roi]]` blocks to paste into a plan (docs/roi.md).

use std::path::{Path, PathBuf};

use clap::Args;

use super::output::{out, outln};
use super::{ExitCode, Failure};
use crate::analysis::roi::detect::{self, DetectOptions};
use crate::analysis::roi::{self, Overlay, PreviewError, WriteError};
use crate::calibrate::frames::FrameError;
use crate::capture::{CaptureError, ReadOptions, SourceKind};
use crate::error::UsageError;
use crate::plan::{self, LumaWeights, RoiKind, VideoDecode, VideoRange};

#[derive(Args, Debug)]
pub(super) struct RoiArgs {
    /// Plan file, or a plan name from test-plans/ (e.g. `p2020-samples`):
    /// draws its ROIs on the first frame of each capture (a simulator
    /// plan: on the frame the simulator renders).
    #[arg(required_unless_present = "detect", conflicts_with = "detect")]
    plan: Option<String>,
    /// Propose LED ROIs from the ON -> OFF step of this capture (or the
    /// step after a dark baseline) and print them as `[[roi]]` blocks.
    #[arg(long, value_name = "CAPTURE")]
    detect: Option<PathBuf>,
    /// Directory for the PNG pictures; created when missing. Default for
    /// a plan: `roi-<plan id>` in the current directory; `--detect`
    /// writes a picture only with `--out`.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// With --detect: the recording's steady-ON time, seconds.
    #[arg(long, default_value_t = 2.0, requires = "detect")]
    on_s: f64,
    /// With --detect: the recording's OFF time, seconds.
    #[arg(long, default_value_t = 2.0, requires = "detect")]
    off_s: f64,
    /// With --detect: the frame rate of an image sequence (a video has
    /// its own frame times), frames/s.
    #[arg(long, requires = "detect")]
    fps: Option<f64>,
    /// With --detect: frames within this time after a step are left out,
    /// seconds (auto exposure settling).
    #[arg(long, default_value_t = plan::DEFAULT_SETTLE_S, requires = "detect")]
    settle_s: f64,
}

pub(super) fn roi(a: RoiArgs) -> Result<ExitCode, Failure> {
    match (&a.detect, &a.plan) {
        (Some(capture), _) => detect_rois(capture, &a),
        (None, Some(plan)) => preview_plan(plan, a.out.as_deref()),
        (None, None) => Err(UsageError(
            "give a plan, or --detect CAPTURE\n    hint: `ledflicker roi p2020-samples`, `ledflicker roi --detect capture.mp4`".into(),
        )
        .into()),
    }
}

/// `roi PLAN`: a picture per capture, then the ROI table.
fn preview_plan(arg: &str, out: Option<&Path>) -> Result<ExitCode, Failure> {
    let plan = plan::find_and_load(arg)?;
    let overlays = Overlay::of_plan(&plan);
    let pictures = roi::previews(&plan).map_err(preview_failure)?;
    let mut files = Vec::new();
    let mut outside = Vec::new();
    for (id, picture) in &pictures {
        for m in roi::outside(&overlays, (picture.width, picture.height)) {
            outside.push(format!("{id}: {m}"));
        }
        let img = roi::annotate(picture, &overlays, &[]);
        let bytes =
            roi::png(&img).map_err(|e| Failure::Internal(format!("cannot encode {id}: {e}")))?;
        files.push((format!("{}.png", roi::file_stem(id)), bytes));
    }
    let dir = out.map_or_else(
        || PathBuf::from(format!("roi-{}", roi::file_stem(&plan.id))),
        Path::to_path_buf,
    );
    let written = roi::write_files(&dir, &files).map_err(write_failure)?;
    for ((id, picture), path) in pictures.iter().zip(&written) {
        outln!(
            "{id}: {} (frame {}, {}x{} px)",
            path.display(),
            picture.frame,
            picture.width,
            picture.height
        )?;
    }
    outln!()?;
    print_table(&overlays)?;
    if !outside.is_empty() {
        return Err(UsageError(format!(
            "{}\n    hint: move or shrink these ROIs in the plan (the pictures show where they are)",
            outside.join("\n")
        ))
        .into());
    }
    Ok(ExitCode::Pass)
}

/// The ROIs as a table: name, kind, x, y, w, h (pixels, 0-based).
fn print_table(overlays: &[Overlay]) -> std::io::Result<()> {
    let wide = overlays
        .iter()
        .map(|o| o.name.len())
        .max()
        .unwrap_or(4)
        .max(4);
    outln!(
        "{:<wide$}  {:<10}  {:>5}  {:>5}  {:>5}  {:>5}",
        "name",
        "kind",
        "x",
        "y",
        "w",
        "h"
    )?;
    for o in overlays {
        let kind = match o.kind {
            RoiKind::Led => "led",
            RoiKind::Background => "background",
        };
        let r = o.rect;
        outln!(
            "{:<wide$}  {:<10}  {:>5}  {:>5}  {:>5}  {:>5}",
            o.name,
            kind,
            r.x,
            r.y,
            r.width,
            r.height
        )?;
    }
    Ok(())
}

/// `roi --detect CAPTURE`: the proposal as `[[roi]]` blocks, and with
/// `--out` its picture (the lit frames' mean, lit regions in yellow).
fn detect_rois(capture: &Path, a: &RoiArgs) -> Result<ExitCode, Failure> {
    let ok = |v: f64| v.is_finite() && v > 0.0;
    if !(ok(a.on_s) && ok(a.off_s) && a.settle_s.is_finite() && a.settle_s >= 0.0) {
        return Err(
            UsageError("--on-s and --off-s must be > 0 s, --settle-s >= 0 s".into()).into(),
        );
    }
    let images = matches!(
        crate::capture::source_kind(capture),
        SourceKind::Image | SourceKind::ImageDir
    );
    if a.fps.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
        return Err(UsageError("--fps must be > 0".into()).into());
    }
    if images && a.fps.is_none() && capture.exists() {
        return Err(UsageError(format!(
            "`{}` is an image sequence: its frames have no times\n    hint: give its frame rate, e.g. --fps 30",
            capture.display()
        ))
        .into());
    }
    let opts = DetectOptions {
        // The Y' plane: a third of the bytes of RGB, and the LED is as
        // plain in it; a plan measures with its own [capture] choices.
        read: ReadOptions {
            luma: LumaWeights::Bt601,
            video_decode: VideoDecode::LumaPlane,
            range: VideoRange::Auto,
            colour_transfer: crate::capture::ColourTransfer::Linear,
            fps: a.fps,
            decoder_threads: None,
        },
        on_s: a.on_s,
        off_s: a.off_s,
        settle_s: a.settle_s,
    };
    let p = detect::detect(capture, &opts).map_err(capture_failure)?;
    if let Some(dir) = &a.out {
        let overlays: Vec<Overlay> = p
            .rois
            .iter()
            .map(|r| Overlay {
                name: r.name.clone(),
                kind: r.kind,
                rect: r.rect,
            })
            .collect();
        let regions: Vec<_> = p.blobs.iter().map(|b| b.bbox).collect();
        let picture = roi::Picture {
            frame: p.lit_frames.0,
            width: p.frame_size.0,
            height: p.frame_size.1,
            full_scale_dn: p.full_scale_dn,
            luma: p.lit_mean.clone(),
        };
        let img = roi::annotate(&picture, &overlays, &regions);
        let bytes = roi::png(&img)
            .map_err(|e| Failure::Internal(format!("cannot encode the picture: {e}")))?;
        let stem = capture.file_stem().map_or_else(
            || "capture".to_string(),
            |s| roi::file_stem(&s.to_string_lossy()),
        );
        let written = roi::write_files(dir, &[(format!("{stem}-detect.png"), bytes)])
            .map_err(write_failure)?;
        for path in written {
            eprintln!("wrote {}", path.display());
        }
    }
    out!("{}", detect::to_toml(&p))?;
    Ok(ExitCode::Pass)
}

fn capture_failure(e: CaptureError) -> Failure {
    Failure::Frames(FrameError::Capture(e))
}

fn preview_failure(e: PreviewError) -> Failure {
    match e {
        PreviewError::Capture(c) => capture_failure(c),
        PreviewError::Render(m) => Failure::Internal(m),
        e @ PreviewError::NoFrames { .. } => UsageError(e.to_string()).into(),
    }
}

fn write_failure(e: WriteError) -> Failure {
    match e {
        e @ WriteError::Refused { .. } => UsageError(e.to_string()).into(),
        e @ WriteError::Io { .. } => Failure::Internal(e.to_string()),
    }
}
