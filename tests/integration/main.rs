//! Integration tests: one binary (ripgrep style) with a module per area.

mod advice;
mod band_frames;
mod bands_robust;
mod calibrate;
mod campaign;
mod campaign_pg;
mod campaign_trust;
mod capture_inputs;
mod captured;
mod cli;
mod colour;
mod colour_captured;
mod compare_gate;
mod conditions;
mod customer;
mod detect;
mod doc_figures;
mod estimate;
mod exact;
mod features;
mod lab;
mod lab_bench;
mod lab_gst;
mod large_runs;
mod legible;
mod light;
mod mutate;
mod plans;
mod profile;
mod properties;
mod ranges;
mod recgen;
mod render;
mod report;
mod results;
mod robust;
mod roi;
mod saturation;
mod shard;
mod shard_input;
mod signoff;
mod store;
mod time_base;
mod timing;
mod units;
mod verdicts;
mod visibility;
mod visual;

use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

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

/// The results database every run of the binary in these tests records
/// into (`LEDFLICKER_DB`): never the user's own, under their home.
pub fn test_db() -> PathBuf {
    root()
        .join("target")
        .join("test-scratch")
        .join("results.sqlite")
}

/// Runs the binary in `dir`, hermetically: no `SOURCE_DATE_EPOCH` or
/// PKCS#12 passphrase from the caller's environment.
pub fn ledflicker_in(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
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
/// `pdftotext -layout` of the whole PDF, pages separated by form feeds.
pub fn pdf_text(pdf: &Path) -> String {
    let o = std::process::Command::new("pdftotext")
        .args(["-layout"])
        .arg(pdf)
        .arg("-")
        .output()
        .expect("pdftotext (poppler-utils) is needed: run scripts/test.sh, which installs it");
    assert!(o.status.success(), "pdftotext {}", pdf.display());
    String::from_utf8_lossy(&o.stdout).into_owned()
}

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

/// Opens and closes `fifo` for writing, so that whatever waits to read it
/// (a process left behind by a run that hung) sees its end.
pub fn release(fifo: &Path) {
    let _ = std::fs::OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(fifo);
}

/// What a run gave: its exit code (`None`: killed at the deadline) and
/// its stderr.
pub struct Ran {
    pub code: Option<i32>,
    pub stderr: String,
}

/// Runs `ledflicker ARGS` in `dir`, killed at `deadline`; then releases
/// `fifos`.
pub fn run_with_deadline(args: &[&str], dir: &Path, fifos: &[PathBuf], deadline: Duration) -> Ran {
    let err_path = dir.join("stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(args)
        .current_dir(dir)
        .env_remove("SOURCE_DATE_EPOCH")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if start.elapsed() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    for f in fifos {
        release(f);
    }
    Ran {
        code,
        stderr: std::fs::read_to_string(&err_path).unwrap_or_default(),
    }
}
