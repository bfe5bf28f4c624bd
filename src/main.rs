//! The `ledflicker` binary: parse arguments, run, map the outcome to an
//! exit code (see `ledflicker::cli::exit_code`).

fn main() {
    std::process::exit(ledflicker::cli::main());
}
