//! The beat of a case and where its apparent frequency came from.

use serde::{Deserialize, Serialize};

/// Where an apparent frequency came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ApparentMethod {
    /// The PWM frequency is known: `|f - fps round(f / fps)|` with the
    /// frame rate of the frames' own times (the simulator's clock, or a
    /// capture's container timestamps, sidecar or `frame-rate-fps`).
    FrameTimes,
    /// The PWM frequency is unknown: the dominant frequency of the LED
    /// trace's spectrum, to within `resolution_hz`.
    Spectrum,
}

/// The beat of a case: its apparent frequency and whether the capture was
/// long enough to show one full beat.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Beat {
    /// Apparent frequency, Hz (0 when phase locked, or when the PWM
    /// frequency is unknown and the spectrum shows none).
    pub apparent_frequency_hz: f64,
    /// How `apparent_frequency_hz` was found.
    pub method: ApparentMethod,
    /// Frame rate used, frames/s: the camera's, or measured from the frames'
    /// times for captures and rigs.
    pub frame_rate_fps: f64,
    /// Resolution of the spectrum (one bin, `fps / frames`), Hz, when the
    /// frequency comes from the spectrum.
    pub resolution_hz: Option<f64>,
    /// One beat, `1 / f_a`, in seconds; `None` when phase locked (infinite).
    pub period_s: Option<f64>,
    /// Duration of the PWM capture, seconds.
    pub capture_s: f64,
    /// The beat period is longer than the capture (or infinite): the video
    /// shows a drift or a constant level, not the whole flicker cycle.
    pub longer_than_capture: bool,
    /// A sentence for the report.
    pub note: String,
}

/// Why a spectrum gave no frequency.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    /// Fewer than 4 samples.
    #[error("too few frames ({0}) for a spectrum")]
    TooShort(usize),
    /// The trace is constant: no flicker to measure.
    #[error("the trace is constant (peak-to-peak {0:.3e} of its mean): no flicker to measure")]
    Flat(f64),
    /// The strongest component is at the lowest resolvable frequency: the
    /// beat is longer than the capture.
    #[error(
        "the strongest component is below {0:.4} Hz (1.5 / capture length): the beat is longer than the capture"
    )]
    Unresolved(f64),
}
