//! The simulator's ideal camera: linear response, no noise, fixed exposure,
//! global or rolling shutter.
//!
//! Luma mapping (documented in docs/plan-format.md):
//!
//! ```text
//! k       = response-dn-per-cd-m2-s * exposure_s
//! L_bg    = background-reflectance * lux / pi          (cd/m^2, Lambertian)
//! luma    = black-level-dn + k * (L_bg + led-fill * L_led * s)   clipped at full-scale-dn
//! ```
//!
//! where `s` is the fraction of the exposure during which the LED was ON,
//! averaged over the ROI rows: the duty cycle in the steady-ON segment (its
//! luminance is matched to the PWM average, as Deegan 2018 asks), 0 in the
//! OFF segment, and the exact closed-form integral in the PWM segment.
//! Background ROIs see `s = 0` throughout.

use super::{Acquisition, Backend, BackendError, FrameInfo, RoiTrace};
use crate::metrics::flicker::Segment;
use crate::physics::{PwmDrive, Shutter, ShutterModel};
use crate::plan::{CameraConfig, Plan, Roi, RoiKind, Scene, Sequence, ShutterKind, TestCase};

/// The ideal-camera simulator for one plan.
#[derive(Debug, Clone)]
pub struct Simulator {
    camera: CameraConfig,
    scene: Scene,
    sequence: Sequence,
    rois: Vec<Roi>,
}

/// Frame counts of the three segments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SegmentFrames {
    /// Steady-ON frames.
    pub on: u64,
    /// OFF frames.
    pub off: u64,
    /// PWM frames.
    pub pwm: u64,
}

impl SegmentFrames {
    /// Frames per segment at `fps`, each duration rounded to whole frames.
    pub fn new(sequence: &Sequence, fps: f64) -> Self {
        let frames = |s: f64| (s * fps).round() as u64;
        Self {
            on: frames(sequence.on_s),
            off: frames(sequence.off_s),
            pwm: frames(sequence.pwm_s),
        }
    }

    /// Segment of frame `k`.
    pub fn segment(&self, k: u64) -> Segment {
        if k < self.on {
            Segment::On
        } else if k < self.on + self.off {
            Segment::Off
        } else {
            Segment::Pwm
        }
    }

    /// Total frames.
    pub fn total(&self) -> u64 {
        self.on + self.off + self.pwm
    }
}

impl Simulator {
    /// A simulator for the plan's camera, scene, sequence and ROIs.
    pub fn new(plan: &Plan) -> Self {
        Self {
            camera: plan.dut.camera,
            scene: plan.scene,
            sequence: plan.sequence,
            rois: plan.rois.clone(),
        }
    }

    /// The camera's exposure timing.
    pub fn shutter(&self) -> Shutter {
        shutter_of(&self.camera)
    }
}

/// Exposure timing of a configured camera.
pub fn shutter_of(camera: &CameraConfig) -> Shutter {
    Shutter {
        model: match camera.shutter {
            ShutterKind::Global => ShutterModel::Global,
            ShutterKind::Rolling => ShutterModel::Rolling {
                line_time_s: camera.line_time_s,
            },
        },
        exposure_s: camera.exposure_s,
        fps: camera.fps,
    }
}

impl Backend for Simulator {
    fn id(&self) -> &str {
        "sim-ideal"
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        let cam = &self.camera;
        let pwm =
            PwmDrive::new(case.frequency_hz, case.duty, cam.pwm_delay_s).map_err(|message| {
                BackendError {
                    backend: self.id().to_string(),
                    case: case.id.clone(),
                    message,
                }
            })?;
        let shutter = self.shutter();
        let segments = SegmentFrames::new(&self.sequence, cam.fps);
        let frames: Vec<FrameInfo> = (0..segments.total())
            .map(|k| FrameInfo {
                index: k,
                time_s: k as f64 / cam.fps,
                segment: segments.segment(k),
            })
            .collect();
        let k = cam.response_dn_per_cd_m2_s * cam.exposure_s;
        let background = k * self.scene.background_luminance_cd_m2(case.light_lux);
        let led_peak = k * self.scene.led_fill * self.scene.led_luminance_cd_m2;
        let out =
            |s: f64, led: f64| (cam.black_level_dn + background + led * s).min(cam.full_scale_dn);
        let rois = self
            .rois
            .iter()
            .map(|roi| {
                let led = if roi.kind == RoiKind::Led {
                    led_peak
                } else {
                    0.0
                };
                let luma = frames
                    .iter()
                    .map(|f| match f.segment {
                        Segment::On => out(case.duty, led),
                        Segment::Off => out(0.0, led),
                        Segment::Pwm => {
                            out(shutter.frame_on_fraction(&pwm, f.index, roi.rows()), led)
                        }
                    })
                    .collect();
                let (lo, hi) = shutter.phase_envelope(&pwm, roi.rows());
                RoiTrace {
                    name: roi.name.clone(),
                    luma,
                    phase_envelope: Some((out(lo, led), out(hi, led))),
                }
            })
            .collect();
        Ok(Acquisition {
            frames,
            rois,
            saturation_dn: cam.saturation_dn,
        })
    }
}
