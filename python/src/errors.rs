//! The command line's errors as Python exceptions: every library error is
//! first made a [`Failure`], so the exception carries the message, the
//! hint and the exit code `ledflicker` would print and return.

use ledflicker::cli::Failure;
use ledflicker::plan::PlanError as RustPlanError;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

create_exception!(
    _ledflicker,
    LedflickerError,
    PyException,
    "An error of the ledflicker engine: `message` as the command line prints it after `error: `, `hint` (or None), `exit_code` as the command line returns it."
);
create_exception!(
    _ledflicker,
    PlanError,
    LedflickerError,
    "The plan cannot be found, read or validated; `errors` lists every problem with its key, line, column, message and hint."
);
create_exception!(
    _ledflicker,
    UsageError,
    LedflickerError,
    "An argument, a file or an input of the caller's is wrong (exit code 2)."
);
create_exception!(
    _ledflicker,
    ReportError,
    LedflickerError,
    "A report directory cannot be read, or is not as ledflicker wrote it."
);

/// The hints of a message: the text after each `hint: `.
fn hints(message: &str) -> Vec<String> {
    message
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("hint: "))
        .map(str::to_string)
        .collect()
}

/// The line and column of a TOML syntax error, from toml's message
/// ("TOML parse error at line 1, column 6").
fn syntax_location(message: &str) -> Option<(usize, usize)> {
    let rest = &message[message.find("line ")? + 5..];
    let (line, rest) = rest.split_once(", column ")?;
    let column: String = rest.chars().take_while(char::is_ascii_digit).collect();
    Some((line.trim().parse().ok()?, column.parse().ok()?))
}

/// `failure` as the exception of its kind, with `message`, `hint`,
/// `exit_code` and, for an invalid plan, `errors`.
pub fn to_py(py: Python<'_>, failure: Failure) -> PyErr {
    let message = failure.message();
    let code = failure.exit_code().code();
    let err = match &failure {
        Failure::Plan(_) => PlanError::new_err(message.clone()),
        Failure::Usage(_) => UsageError::new_err(message.clone()),
        Failure::Report(_) => ReportError::new_err(message.clone()),
        // Exit code 2 is the caller's input: a file, an argument, an array.
        _ if code == 2 => UsageError::new_err(message.clone()),
        _ => LedflickerError::new_err(message.clone()),
    };
    if let Err(e) = annotate(py, &err, &failure, &message, code) {
        return e;
    }
    err
}

fn annotate(
    py: Python<'_>,
    err: &PyErr,
    failure: &Failure,
    message: &str,
    code: i32,
) -> PyResult<()> {
    let value = err.value(py);
    value.setattr("message", message)?;
    value.setattr("hint", hints(message).into_iter().next())?;
    value.setattr("exit_code", code)?;
    let errors = PyList::empty(py);
    if let Failure::Plan(RustPlanError::Syntax { message, .. }) = failure {
        // TOML stops at its first error: one entry, located as toml says.
        let (line, column) = syntax_location(message).unzip();
        let e = PyDict::new(py);
        e.set_item("key", None::<String>)?;
        e.set_item("line", line)?;
        e.set_item("column", column)?;
        e.set_item("message", message.lines().next().unwrap_or(message))?;
        e.set_item("hint", None::<String>)?;
        e.set_item("text", message)?;
        errors.append(e)?;
    }
    if let Failure::Plan(RustPlanError::Invalid { diagnostics, .. }) = failure {
        for d in diagnostics {
            let e = PyDict::new(py);
            e.set_item("key", &d.key)?;
            e.set_item("line", d.location.map(|l| l.0))?;
            e.set_item("column", d.location.map(|l| l.1))?;
            e.set_item("message", &d.message)?;
            e.set_item("hint", &d.hint)?;
            e.set_item("text", d.to_string())?;
            errors.append(e)?;
        }
    }
    value.setattr("errors", errors)?;
    Ok(())
}

/// A usage error in the command line's words, raised as [`UsageError`].
pub fn usage(py: Python<'_>, message: String) -> PyErr {
    to_py(py, ledflicker::error::UsageError(message).into())
}

/// Registers the exception classes on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("LedflickerError", py.get_type::<LedflickerError>())?;
    m.add("PlanError", py.get_type::<PlanError>())?;
    m.add("UsageError", py.get_type::<UsageError>())?;
    m.add("ReportError", py.get_type::<ReportError>())?;
    Ok(())
}
