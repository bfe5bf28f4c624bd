//! `ledflicker advise`: the shortest exposure that never loses a PWM LED
//! over a frequency and a duty range, the flicker it leaves and its
//! motion-blur cost.

use super::output::{out, outln};
use std::path::PathBuf;

use super::failure::Context;
use clap::Args;

use super::{ExitCode, Failure};
use crate::error::UsageError;
use crate::report;

#[derive(Args, Debug)]
pub(super) struct AdviseArgs {
    /// Lowest PWM frequency, Hz (> 0).
    #[arg(long)]
    min_hz: f64,
    /// Highest PWM frequency, Hz (>= --min-hz).
    #[arg(long)]
    max_hz: f64,
    /// Lowest duty cycle, (0, 1).
    #[arg(long)]
    min_duty: f64,
    /// Highest duty cycle, (0, 1] (>= --min-duty).
    #[arg(long, default_value_t = 1.0)]
    max_duty: f64,
    /// Frequency step of the residual grid, Hz.
    #[arg(long, default_value_t = 1.0)]
    hz_step: f64,
    /// Duty step of the residual grid.
    #[arg(long, default_value_t = 0.01)]
    duty_step: f64,
    /// Image speed of a moving object in pixels per second: adds motion blur.
    #[arg(long)]
    speed_px_per_s: Option<f64>,
    /// Exposure ratio of a shorter HDR capture (repeatable), e.g. 4 and 16.
    #[arg(long)]
    hdr_ratio: Vec<f64>,
    /// The camera's frame rate: no exposure beyond its frame time (less the
    /// shorter HDR captures, taken one after the other) is offered.
    #[arg(long)]
    fps: Option<f64>,
    /// Also write a plot of residual flicker against exposure to this SVG.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Print the advice as JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub(super) fn advise(a: AdviseArgs) -> Result<ExitCode, Failure> {
    use crate::advise::{AdviseRequest, advise, curve, table};
    if a.hdr_ratio.iter().any(|r| !(r.is_finite() && *r > 1.0)) {
        return Err(UsageError("--hdr-ratio must be > 1".into()).into());
    }
    if a.speed_px_per_s
        .is_some_and(|v| !(v.is_finite() && v >= 0.0))
    {
        return Err(UsageError("--speed-px-per-s must be >= 0".into()).into());
    }
    if a.fps
        .is_some_and(|f| !(f.is_finite() && f > 0.0 && f <= 1000.0))
    {
        return Err(UsageError("--fps must be > 0 and at most 1000".into()).into());
    }
    let req = AdviseRequest {
        frame: a
            .fps
            .map(|f| crate::advise::FrameBound::sequential(f, &a.hdr_ratio)),
        frequency_hz: (a.min_hz, a.max_hz),
        duty: (a.min_duty, a.max_duty),
        frequency_step_hz: a.hz_step,
        duty_step: a.duty_step,
        speed_px_per_s: a.speed_px_per_s,
        hdr_ratios: a.hdr_ratio.clone(),
    };
    let advice = advise(&req).map_err(|e| UsageError(e.to_string()))?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&advice)?)?;
    } else {
        out!("{}", table(&advice))?;
    }
    if let Some(path) = &a.svg {
        let points = curve(&req, 49).map_err(|e| UsageError(e.to_string()))?;
        let svg = report::charts::advise_svg(&points, advice.min_exposure_s)?;
        crate::util::write_atomic(path, svg.as_bytes())
            .with_context(|| format!("cannot write `{}`", path.display()))?;
    }
    Ok(ExitCode::Pass)
}
