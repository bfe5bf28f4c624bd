//! The captures built into the binary (a shipped plan's videos), read
//! through a private temporary copy when they are not on disk.

use std::path::Path;

use super::CaptureError;

/// A private copy of the capture built into the binary at `path`
/// ([`ledflicker_plan::plan::shipped::data_at`]) when nothing stands at `path`: a
/// shipped plan's capture, read away from the source tree. The readers
/// (and ffmpeg) take a file, so the bytes go to a temporary file of
/// ledflicker's own, removed when the copy is dropped. `None` when `path`
/// is on disk or names no built-in capture.
pub(crate) fn built_in_copy(path: &Path) -> Result<Option<tempfile::TempPath>, CaptureError> {
    if std::fs::symlink_metadata(path).is_ok() {
        return Ok(None);
    }
    let Some(data) = ledflicker_plan::plan::shipped::data_at(path) else {
        return Ok(None);
    };
    let suffix = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let failed = |e: std::io::Error| CaptureError::Read {
        path: path.to_path_buf(),
        message: format!("cannot copy the built-in capture to a temporary file: {e}"),
    };
    let mut file = tempfile::Builder::new()
        .prefix("ledflicker-built-in-")
        .suffix(&suffix)
        .tempfile()
        .map_err(failed)?;
    std::io::Write::write_all(&mut file, data.bytes).map_err(failed)?;
    Ok(Some(file.into_temp_path()))
}

/// Runs `read` on the capture at `path`, or on its built-in copy
/// ([`built_in_copy`]); errors name `path` either way.
pub(super) fn with_built_in<T>(
    path: &Path,
    read: impl FnOnce(&Path) -> Result<T, CaptureError>,
) -> Result<T, CaptureError> {
    match built_in_copy(path)? {
        None => read(path),
        Some(copy) => read(&copy).map_err(|e| e.at(path)),
    }
}

impl CaptureError {
    /// The capture the error names.
    pub fn path(&self) -> &Path {
        match self {
            CaptureError::Read { path, .. }
            | CaptureError::Frame { path, .. }
            | CaptureError::RoiOutside { path, .. }
            | CaptureError::Invalid { path, .. }
            | CaptureError::Tool { path, .. }
            | CaptureError::Interrupted { path, .. } => path,
        }
    }

    /// The error naming `path` as the capture (a built-in capture read
    /// through a temporary copy is named by its path in the plan).
    pub(crate) fn at(mut self, path: &Path) -> CaptureError {
        match &mut self {
            CaptureError::Read { path: p, .. }
            | CaptureError::Frame { path: p, .. }
            | CaptureError::RoiOutside { path: p, .. }
            | CaptureError::Invalid { path: p, .. }
            | CaptureError::Tool { path: p, .. }
            | CaptureError::Interrupted { path: p, .. } => *p = path.to_path_buf(),
        }
        self
    }
}
