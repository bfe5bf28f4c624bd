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
        let safe = terminal_safe(buf);
        Stdout::absorb(
            std::io::stdout()
                .lock()
                .write_all(&safe)
                .map(|()| buf.len()),
            buf.len(),
        )
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if CLOSED.load(Ordering::Relaxed) {
            return Ok(());
        }
        Stdout::absorb(std::io::stdout().lock().flush().map(|()| 0), 0).map(|_| ())
    }
}

/// `bytes` with every control character but newline and tab written out
/// as `\xHH` (C0 and DEL) or `\u{HH}` (C1, U+0080 to U+009F): what the
/// commands print includes strings from plans, imported reports, the
/// results database and instruments, and an ESC, OSC, CR or BEL among
/// them would drive the operator's terminal (rewrite the screen, set the
/// title, hide a line).
pub fn terminal_safe(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let is_c1 =
        |i: usize| bytes[i] == 0xc2 && bytes.get(i + 1).is_some_and(|b| (0x80..=0x9f).contains(b));
    let unsafe_at = |i: usize| {
        let b = bytes[i];
        (b < 0x20 && b != b'\n' && b != b'\t') || b == 0x7f || is_c1(i)
    };
    if !(0..bytes.len()).any(unsafe_at) {
        return std::borrow::Cow::Borrowed(bytes);
    }
    let mut out = Vec::with_capacity(bytes.len() + 16);
    let mut i = 0;
    while i < bytes.len() {
        if is_c1(i) {
            out.extend_from_slice(format!("\\u{{{:02x}}}", bytes[i + 1]).as_bytes());
            i += 2;
        } else if unsafe_at(i) {
            out.extend_from_slice(format!("\\x{:02x}", bytes[i]).as_bytes());
            i += 1;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    std::borrow::Cow::Owned(out)
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
    fn control_characters_are_written_out_and_text_is_left_alone() {
        let raw = "EX-1\u{1b}]0;owned\u{7}\r\u{9b}2J ü\tok\n";
        let safe = terminal_safe(raw.as_bytes());
        assert_eq!(
            String::from_utf8(safe.into_owned()).unwrap(),
            "EX-1\\x1b]0;owned\\x07\\x0d\\u{9b}2J ü\tok\n"
        );
        let plain = "run 1  2026-01-01  δ ✓\n";
        assert!(matches!(
            terminal_safe(plain.as_bytes()),
            std::borrow::Cow::Borrowed(_)
        ));
    }

    #[test]
    fn a_broken_pipe_is_absorbed_and_other_errors_are_not() {
        let broken = std::io::Error::from(std::io::ErrorKind::BrokenPipe);
        assert_eq!(Stdout::absorb(Err(broken), 7).unwrap(), 7);
        let full = std::io::Error::from(std::io::ErrorKind::StorageFull);
        assert!(Stdout::absorb(Err(full), 7).is_err());
        CLOSED.store(false, Ordering::Relaxed);
    }
}
