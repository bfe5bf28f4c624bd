//! Records the commit the binary is built from, for `--version`
//! (`unknown` when the source is not a git checkout, e.g. a crate package).

use std::path::PathBuf;
use std::process::Command;

/// `git ARGS`' output, trimmed, when git runs and succeeds.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_string())
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=LEDFLICKER_GIT_COMMIT={commit}");
    // A commit moves the branch HEAD names; a checkout moves HEAD. Only
    // files that exist are watched: cargo reruns a build script on every
    // build for a missing one.
    let dirs = [
        git(&["rev-parse", "--git-dir"]),
        git(&["rev-parse", "--git-common-dir"]),
    ];
    let head = git(&["symbolic-ref", "-q", "HEAD"]);
    for dir in dirs.into_iter().flatten().map(PathBuf::from) {
        let mut watch = vec![dir.join("HEAD"), dir.join("packed-refs")];
        if let Some(r) = &head {
            watch.push(dir.join(r));
        }
        for path in watch.into_iter().filter(|p| p.is_file()) {
            println!("cargo:rerun-if-changed={}", path.display());
        }
    }
}
