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

/// [`crate::pipeline::load_plan`], its plausibility warnings printed to
/// stderr (`validate`, `plan`, `rig`).
pub(super) fn load(arg: &str, limits: plan::ResourceLimits) -> Result<plan::Plan, Failure> {
    let plan = crate::pipeline::load_plan(arg, limits)?;
    eprint!("{}", plan.warnings_text());
    Ok(plan)
}
