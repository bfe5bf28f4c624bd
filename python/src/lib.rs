//! `ledflicker._ledflicker`: the native half of the Python package
//! (python/ledflicker/ is the other). It calls the library, never the
//! binary: a plan's run through the one run path the command line takes
//! too ([`ledflicker::pipeline::run_plan`]), report directories read back,
//! the metrics on numpy arrays, the results database. Errors are the
//! command line's, raised as exceptions ([`errors`]); a panic never
//! crosses into Python (PyO3 turns one into `PanicException`).

use pyo3::prelude::*;

mod arrays;
mod campaign;
mod errors;
mod run;
mod simulate;

#[pymodule]
fn _ledflicker(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Python owns SIGINT: the engine installs no handler of its own and
    // is asked to stop by the waiting thread (run.rs).
    ledflicker::interrupt::embed();
    errors::register(m)?;
    m.add("ON", arrays::SEGMENT_CODES[0].0)?;
    m.add("OFF", arrays::SEGMENT_CODES[1].0)?;
    m.add("PWM", arrays::SEGMENT_CODES[2].0)?;
    m.add("LEFT_OUT", simulate::LEFT_OUT)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(run::run_plan, m)?)?;
    m.add_function(wrap_pyfunction!(run::read_report, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::flicker_2018, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::p2020_kpis, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::light_json, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::rust_call_seconds, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::detect_segments, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::history_json, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::compare_runs, m)?)?;
    Ok(())
}
