//! ROIs seen in their frame, before a run (`ledflicker roi`, docs/roi.md).
//!
//! Sits beside the analyses: it reads a capture's pixels through
//! [`ledflicker_acquisition::capture::read_grey_frames`] (or renders a frame with the
//! simulator) and draws ROIs on it; [`detect`] proposes ROIs from a
//! capture's ON -> OFF step. Nothing here is part of a run or a report.
//!
//! - [`previews`]: the first frame of each capture of a plan (the first
//!   lit one when it is dark; a simulator plan: frame 0 of its first case,
//!   as the simulator renders it);
//! - [`annotate`]: a picture with ROIs outlined and named, full resolution;
//! - [`write_files`]: PNGs into a directory ledflicker creates or wrote
//!   before, each file atomically, never over a file it did not write.

pub mod detect;
mod draw;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use ledflicker_acquisition::backend::Backend;
use ledflicker_acquisition::capture::{
    self, CaptureError, FrameSink, GreyFrame, ReadOptions, RoiRect,
};
use ledflicker_plan::plan::{BackendKind, Plan, RoiKind};

pub use draw::annotate;

/// A grey picture of a whole frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Frame number in its capture (0-based).
    pub frame: u64,
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Full scale of the source, DN (255 for 8-bit).
    pub full_scale_dn: f64,
    /// Luma, DN, row-major (`width * height` values).
    pub luma: Vec<f32>,
}

/// A ROI to draw: its name, kind and rectangle.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// Name, drawn beside the outline.
    pub name: String,
    /// LED (red) or background (blue).
    pub kind: RoiKind,
    /// Frame pixels.
    pub rect: RoiRect,
}

impl Overlay {
    /// The plan's ROIs, in plan order.
    pub fn of_plan(plan: &Plan) -> Vec<Overlay> {
        plan.rois
            .iter()
            .map(|r| Overlay {
                name: r.name.clone(),
                kind: r.kind,
                rect: RoiRect {
                    x: r.x_px,
                    y: r.y_px,
                    width: r.width_px,
                    height: r.height_px,
                },
            })
            .collect()
    }
}

/// Why a preview could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PreviewError {
    /// A capture could not be read.
    #[error(transparent)]
    Capture(#[from] CaptureError),
    /// The simulator could not render the frame.
    #[error("cannot render the simulator's frame: {0}")]
    Render(String),
    /// The plan has no frames to show (a command plan).
    #[error(
        "plan `{plan}` has no frames before a run: its backend is a lab rig command\n    hint: record a capture with the rig and run `ledflicker roi --detect CAPTURE`"
    )]
    NoFrames {
        /// Plan id.
        plan: String,
    },
}

impl PreviewError {
    /// True for problems with the input (exit code 2).
    pub fn is_input_error(&self) -> bool {
        match self {
            PreviewError::Capture(e) => e.is_input_error(),
            PreviewError::Render(_) => false,
            PreviewError::NoFrames { .. } => true,
        }
    }
}

/// The frames `ledflicker roi PLAN` shows: for a captured plan, the first
/// frame of each case's capture, named by case id; for a simulator plan,
/// frame 0 (ON) of its first case.
pub fn previews(plan: &Plan) -> Result<Vec<(String, Picture)>, PreviewError> {
    match plan.dut.backend {
        BackendKind::Captured => {
            let Some(cap) = &plan.capture else {
                return Ok(Vec::new());
            };
            let opts = ledflicker_acquisition::backend::captured::read_options(cap);
            cap.cases
                .iter()
                .map(|c| Ok((c.id.clone(), first_frame(&c.source, &opts)?)))
                .collect()
        }
        BackendKind::Simulator => {
            let cases = ledflicker_plan::plan::expand_cases(plan);
            let Some(case) = cases.first() else {
                return Ok(Vec::new());
            };
            let sim = ledflicker_acquisition::backend::sim::Simulator::new(plan);
            let frame = sim
                .render_frame(case, 0)
                .ok_or_else(|| PreviewError::Render("the simulator renders no frames".into()))?
                .map_err(|e| PreviewError::Render(e.message))?;
            let mut luma = Vec::with_capacity(frame.width as usize * frame.height as usize);
            for y in 0..frame.height {
                frame.for_each_in_row(y, (0, frame.width), |_, v| luma.push(v as f32));
            }
            let picture = Picture {
                frame: 0,
                width: frame.width,
                height: frame.height,
                full_scale_dn: frame.full_scale_dn,
                luma,
            };
            Ok(vec![(case.id.clone(), picture)])
        }
        BackendKind::Command => Err(PreviewError::NoFrames {
            plan: plan.id.clone(),
        }),
    }
}

/// Share of a frame's pixels that must exceed [`DARK_DN`] for the frame
/// to show anything.
const LIT_SHARE: f64 = 0.001;
/// Level below which a pixel is dark, DN (2 % of 8-bit full scale).
const DARK_DN: u32 = 5;

/// The first frame of the capture at `path`, whole, as grey; when it is
/// dark (a capture that starts in OFF, as the P2020 samples do), the first
/// frame that is not (more than 0.1 % of its pixels above 5 DN), so that
/// the ROIs are seen on what they measure. The capture is read to its end
/// (its frames are checked as a run would).
pub fn first_frame(path: &Path, opts: &ReadOptions) -> Result<Picture, CaptureError> {
    #[derive(Default)]
    struct First {
        picture: Option<Picture>,
        lit: bool,
        row: Vec<u32>,
    }
    impl FrameSink for First {
        fn frame(&mut self, f: &GreyFrame<'_>) {
            if self.lit {
                return;
            }
            let (w, h) = (f.width(), f.height());
            self.row.resize(w as usize, 0);
            let mut luma = Vec::with_capacity(w as usize * h as usize);
            let mut bright = 0usize;
            for y in 0..h {
                f.row(y, &mut self.row);
                bright += self.row.iter().filter(|&&v| v > DARK_DN).count();
                luma.extend(self.row.iter().map(|&v| v as f32));
            }
            self.lit = bright as f64 > LIT_SHARE * luma.len() as f64;
            if self.lit || self.picture.is_none() {
                self.picture = Some(Picture {
                    frame: f.index,
                    width: w,
                    height: h,
                    full_scale_dn: 255.0,
                    luma,
                });
            }
        }
    }
    let mut first = First::default();
    let trace = capture::read_grey_frames(path, opts, &mut first)?;
    let mut picture = first.picture.ok_or_else(|| CaptureError::Invalid {
        path: path.to_path_buf(),
        message: "the capture has no frames".to_string(),
        hint: "check that the recording finished and the file is complete".to_string(),
    })?;
    picture.full_scale_dn = trace.full_scale_dn;
    Ok(picture)
}

/// ROIs that do not lie inside a `width` x `height` frame, as messages
/// naming them (1-based, as the plan lists them).
pub fn outside(overlays: &[Overlay], (width, height): (u32, u32)) -> Vec<String> {
    overlays
        .iter()
        .enumerate()
        .filter(|(_, o)| {
            u64::from(o.rect.x) + u64::from(o.rect.width) > u64::from(width)
                || u64::from(o.rect.y) + u64::from(o.rect.height) > u64::from(height)
        })
        .map(|(i, o)| {
            format!(
                "ROI {} `{}` (columns {}..{}, rows {}..{}) falls outside the {width}x{height} frame",
                i + 1,
                o.name,
                o.rect.x,
                u64::from(o.rect.x) + u64::from(o.rect.width),
                o.rect.y,
                u64::from(o.rect.y) + u64::from(o.rect.height)
            )
        })
        .collect()
}

/// `img` as PNG bytes.
pub fn png(img: &image::RgbImage) -> Result<Vec<u8>, image::ImageError> {
    let (w, h) = img.dimensions();
    ledflicker_plan::image_io::encode_png(img.as_raw(), w, h, image::ExtendedColorType::Rgb8)
}

/// File in an output directory listing what `ledflicker roi` wrote there,
/// one name a line, so a later run replaces those files and no other.
pub const MARKER: &str = ".ledflicker-roi";

/// Why files could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The directory or a file in it is the user's (exit code 2).
    #[error("{message}\n    hint: {hint}")]
    Refused {
        /// What is in the way.
        message: String,
        /// What to do.
        hint: String,
    },
    /// The file system failed (exit code 3).
    #[error("cannot write `{path}`: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

/// Writes `files` (name, bytes) into `dir`: creates it when missing; an
/// existing directory must be empty or hold [`MARKER`], and a file is
/// replaced only when the marker lists it. Each file is written atomically,
/// then the marker. Returns the paths written.
pub fn write_files(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<Vec<PathBuf>, WriteError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| WriteError::Io { path, source }
    };
    let marker = dir.join(MARKER);
    let mut ours: BTreeSet<String> = BTreeSet::new();
    match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(dir).map_err(io(dir))?;
        }
        Err(e) => return Err(io(dir)(e)),
        Ok(m) if !m.is_dir() => {
            return Err(WriteError::Refused {
                message: format!("`{}` is not a directory", dir.display()),
                hint: "give --out a new or empty directory".to_string(),
            });
        }
        Ok(_) => match std::fs::read_to_string(&marker) {
            Ok(text) => ours.extend(text.lines().skip(1).map(str::to_string)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let empty = std::fs::read_dir(dir).map_err(io(dir))?.next().is_none();
                if !empty {
                    return Err(WriteError::Refused {
                        message: format!(
                            "`{}` is not empty and ledflicker did not write it (no `{MARKER}` in it)",
                            dir.display()
                        ),
                        hint: "give --out a new or empty directory, or one an earlier `ledflicker roi` wrote".to_string(),
                    });
                }
            }
            Err(e) => return Err(io(&marker)(e)),
        },
    }
    for (name, _) in files {
        let path = dir.join(name);
        if std::fs::symlink_metadata(&path).is_ok() && !ours.contains(name) {
            return Err(WriteError::Refused {
                message: format!(
                    "`{}` exists and ledflicker did not write it",
                    path.display()
                ),
                hint: "move it away, or give --out another directory".to_string(),
            });
        }
    }
    let mut written = Vec::new();
    for (name, bytes) in files {
        let path = dir.join(name);
        ledflicker_plan::util::write_atomic(&path, bytes).map_err(io(&path))?;
        ours.insert(name.clone());
        written.push(path);
    }
    let mut text = String::from("files written by `ledflicker roi`:\n");
    for name in &ours {
        text.push_str(name);
        text.push('\n');
    }
    ledflicker_plan::util::write_atomic(&marker, text.as_bytes()).map_err(io(&marker))?;
    Ok(written)
}

/// A file name for `id`: letters, digits, `-`, `_` and `.` kept, anything
/// else `_`.
pub fn file_stem(id: &str) -> String {
    id.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_files_refuses_a_file_it_did_not_write_and_replaces_its_own() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("out");
        let one = vec![("a.png".to_string(), b"1".to_vec())];
        write_files(&dir, &one).unwrap();
        assert_eq!(std::fs::read(dir.join("a.png")).unwrap(), b"1");
        // Its own file is replaced.
        write_files(&dir, &[("a.png".to_string(), b"2".to_vec())]).unwrap();
        assert_eq!(std::fs::read(dir.join("a.png")).unwrap(), b"2");
        // A file the user put there is not.
        std::fs::write(dir.join("b.png"), b"user").unwrap();
        let e = write_files(&dir, &[("b.png".to_string(), b"3".to_vec())]).unwrap_err();
        assert!(matches!(e, WriteError::Refused { .. }), "{e}");
        assert!(e.to_string().contains("did not write"), "{e}");
        assert_eq!(std::fs::read(dir.join("b.png")).unwrap(), b"user");
        // A directory of the user's without the marker is refused whole.
        let theirs = tmp.path().join("theirs");
        std::fs::create_dir(&theirs).unwrap();
        std::fs::write(theirs.join("notes.txt"), b"x").unwrap();
        let e = write_files(&theirs, &one).unwrap_err();
        assert!(e.to_string().contains("is not empty"), "{e}");
        assert!(!theirs.join("a.png").exists());
    }

    #[test]
    fn file_stems_keep_only_safe_characters() {
        assert_eq!(file_stem("test_vid1"), "test_vid1");
        assert_eq!(file_stem("../a b"), ".._a_b");
    }
}
