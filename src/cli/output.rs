//! Standard output of the commands. A reader that closes the pipe early
//! (`ledflicker verify DIR | head -c 5`) ends the output, not the command:
//! what is left to print is dropped and the command finishes its work and
//! returns its own exit code, so a pipe can never turn a failed
//! verification or a failing run into a success, nor a success into a
//! crash. Every command prints through [`Stdout`] (the `out!` and `outln!`
//! macros); `clippy::print_stdout` is denied in the CLI so that no
//! `println!`, which panics on a closed pipe, comes back.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once a write found the reader gone; later output is dropped.
static CLOSED: AtomicBool = AtomicBool::new(false);

/// The process's standard output, where a closed pipe swallows the rest.
#[derive(Debug, Clone, Copy, Default)]
pub struct Stdout;

impl Stdout {
    fn absorb(result: std::io::Result<usize>, len: usize) -> std::io::Result<usize> {
        match result {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                CLOSED.store(true, Ordering::Relaxed);
                Ok(len)
            }
            other => other,
        }
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if CLOSED.load(Ordering::Relaxed) {
            return Ok(buf.len());
        }
        Stdout::absorb(std::io::stdout().lock().write(buf), buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if CLOSED.load(Ordering::Relaxed) {
            return Ok(());
        }
        Stdout::absorb(std::io::stdout().lock().flush().map(|()| 0), 0).map(|_| ())
    }
}

/// `print!` to [`Stdout`]; evaluates to `std::io::Result<()>`.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!($crate::cli::output::Stdout, $($arg)*)
    }};
}

/// `println!` to [`Stdout`]; evaluates to `std::io::Result<()>`.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!($crate::cli::output::Stdout, $($arg)*)
    }};
}

pub(crate) use {out, outln};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_broken_pipe_is_absorbed_and_other_errors_are_not() {
        let broken = std::io::Error::from(std::io::ErrorKind::BrokenPipe);
        assert_eq!(Stdout::absorb(Err(broken), 7).unwrap(), 7);
        let full = std::io::Error::from(std::io::ErrorKind::StorageFull);
        assert!(Stdout::absorb(Err(full), 7).is_err());
        CLOSED.store(false, Ordering::Relaxed);
    }
}
