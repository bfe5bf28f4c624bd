//! The `ledflicker` binary: parse arguments, run, map the outcome to an
//! exit code (see `ledflicker::cli::Failure::exit_code`).

/// `--version`: the package version and the commit it was built from
/// (build.rs; `unknown` outside a git checkout). It is set here, not in the
/// library, so that a new commit relinks the binary without recompiling
/// the library.
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (git ",
    env!("LEDFLICKER_GIT_COMMIT"),
    ")"
);

fn main() {
    std::process::exit(ledflicker::cli::main(VERSION));
}
