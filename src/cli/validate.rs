//! `ledflicker validate`: checks a plan without running it and says what
//! a run would do.

use super::output::outln;
use super::{ExitCode, Failure};
use crate::plan;

pub(super) fn validate(arg: &str, limits: plan::ResourceLimits) -> Result<ExitCode, Failure> {
    let plan = load(arg, limits)?;
    let cases = plan::expand_cases(&plan);
    if plan.dut.backend == plan::BackendKind::Captured {
        outln!(
            "plan `{}` ({}) is valid: {} captured cases, {} ROIs",
            plan.id,
            plan.source_label(),
            cases.len(),
            plan.rois.len()
        )?;
        outln!("{}", plan::WorkEstimate::of(&plan).summary())?;
        return Ok(ExitCode::Pass);
    }
    let frames = crate::backend::sim::SegmentFrames::new(&plan.sequence, plan.dut.camera.fps);
    outln!(
        "plan `{}` ({}) is valid: {} cases ({} light levels x {} frequencies x {} duty cycles), {} ROIs, {} frames per case",
        plan.id,
        plan.source_label(),
        cases.len(),
        plan.light_levels_lux.len(),
        plan.frequencies_hz.len(),
        plan.duty_cycles.len(),
        plan.rois.len(),
        frames.total()
    )?;
    outln!("{}", plan::WorkEstimate::of(&plan).summary())?;
    Ok(ExitCode::Pass)
}

/// Finds and validates a plan for `validate` and `plan`: a captured
/// plan's ROIs are checked against each capture's frame size (read from
/// its header), its work estimate against `limits`, and the plausibility
/// warnings are printed to stderr.
pub(super) fn load(arg: &str, limits: plan::ResourceLimits) -> Result<plan::Plan, Failure> {
    // With the handler installed, Ctrl-C during a probe stops its ffprobe
    // (in a process group of its own, which the terminal's signal does not
    // reach) rather than end ledflicker and leave ffprobe behind.
    crate::interrupt::install();
    let mut plan = plan::find_and_load_with(arg, &crate::capture::frame_size, limits)?;
    crate::interrupt::check()?;
    if let (Some(source), Ok(address)) = (
        plan.source.as_mut(),
        std::env::var(plan::source::ADDRESS_ENV),
    ) {
        source
            .set_address(&address)
            .map_err(crate::error::UsageError)?;
    }
    eprint!("{}", plan.warnings_text());
    Ok(plan)
}
