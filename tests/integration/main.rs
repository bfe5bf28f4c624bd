//! Integration tests: one binary (ripgrep style) with a module per area.

mod advice;
mod banding;
mod beyond;
mod calibrate;
mod camera_model;
mod capture_inputs;
mod captured;
mod cli;
mod detect;
mod exact;
mod mutate;
mod physics;
mod plans;
mod ranges;
mod recgen;
mod render;
mod report;
mod results;
mod robust;
mod shard;
mod shard_input;
mod signoff;
mod timing;
mod verdicts;
mod visual;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh, empty scratch directory under target/.
pub fn scratch(name: &str) -> PathBuf {
    let dir = root()
        .join("target")
        .join("test-scratch")
        .join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the binary in `dir`, hermetically: no `SOURCE_DATE_EPOCH` or
/// PKCS#12 passphrase from the caller's environment.
pub fn ledflicker_in(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .args(args)
        .current_dir(dir)
        .env_remove("SOURCE_DATE_EPOCH")
        .env_remove("LEDFLICKER_P12_PASSPHRASE")
        .output()
        .unwrap()
}

/// Runs the binary in the repository root (see [`ledflicker_in`]).
pub fn ledflicker(args: &[&str]) -> Output {
    ledflicker_in(args, root())
}

/// The command's stderr, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The command's stdout then stderr, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Makes a FIFO at `path`, which the tests never write: whatever opens it
/// for reading without care waits for ever.
pub fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.as_os_str().as_encoded_bytes()).unwrap();
    // SAFETY: a NUL-terminated path that lives across the call.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "{path:?}");
}
