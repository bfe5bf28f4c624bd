//! The simulator: a camera looking at a PWM-driven LED in front of a grey
//! background, through the paper's ON / OFF / PWM sequence.
//!
//! Two camera models share the timing (global or rolling shutter, frame `k`
//! at `k / fps`, exact closed-form integrals for the ROI rows only):
//!
//! - the **ideal camera** (no `[sensor]` table): linear, noiseless, fixed
//!   exposure,
//!   `luma = black + k (L_bg + fill L_led s)` clipped at full scale, with
//!   `k = response x exposure` and `s` the ROI rows' mean ON fraction (the
//!   mean is clipped, not each row, so that the worst case over phase, the
//!   fine map and `advise` stay exact closed forms; docs/camera-model.md
//!   bounds the difference);
//! - the **physical camera**: photo-electrons per capture, shot and read
//!   noise, analogue gain, ADC clipping, multi-capture HDR (sequential or
//!   split pixel) with a merge rule, digital gain, a global tone curve, and
//!   auto exposure that runs through the whole sequence like a real camera.
//!   See docs/camera-model.md.
//!
//! `L_bg = rho E / pi` is the grey background's luminance, `s` the fraction
//! of a capture's exposure during which the LED was ON: the duty cycle in
//! the ON segment (luminance matched to the PWM average, as Deegan 2018
//! asks), 0 in the OFF segment, the exact integral in the PWM segment.
//! Background ROIs see no LED.

use super::{Acquisition, Backend, BackendError, FrameInfo, RenderedFrame, RoiTrace};
use ledflicker_metrics::metrics::flicker::Segment;
use ledflicker_physics::ae::ExposureState;
use ledflicker_physics::extremes::extremes;
use ledflicker_physics::hdr::{HdrMode, merge};
use ledflicker_physics::pwm::{on_fraction, wrap_unit};
use ledflicker_physics::sensor::{CaptureSample, Rng};
use ledflicker_physics::{PwmDrive, Shutter};
use ledflicker_plan::plan::colour::ColourConfig;
use ledflicker_plan::plan::{
    CameraConfig, PhysicalCamera, Plan, Roi, RoiKind, Scene, Sequence, ShutterKind, TestCase,
};
use ledflicker_plan::trace::Run;

mod dies;
use dies::{mixed_envelope, mixed_on_fractions, steady_fraction, weighted};

/// Phases evaluated, beside the exact corners, when searching a physical
/// camera's worst case over phase.
pub const PHASE_GRID: usize = 1024;

/// Distance, in cycles, either side of a saturation crossing at which the
/// response is also evaluated (the merge can jump there).
const CROSSING_SIDE: f64 = 1e-9;

/// The simulator for one plan.
#[derive(Debug, Clone)]
pub struct Simulator {
    camera: CameraConfig,
    scene: Scene,
    sequence: Sequence,
    rois: Vec<Roi>,
    // Boxed: the simulator is a variant of the plan's backend enum, and
    // most plans have no colour.
    colour: Option<Box<ColourConfig>>,
}

pub use ledflicker_plan::plan::SegmentFrames;

/// What the LED does during one frame.
#[derive(Debug, Clone, Copy)]
enum Light<'a> {
    /// Steady at this fraction of its ON luminance.
    Steady(f64),
    /// Driven by the PWM.
    Pwm(&'a PwmDrive),
}

/// One ROI row of one frame through the physical camera.
struct RowOutput {
    luma: f64,
    linear: f64,
}

impl Simulator {
    /// A simulator for the plan's camera, scene, sequence and ROIs.
    pub fn new(plan: &Plan) -> Self {
        Self {
            camera: plan.dut.camera.clone(),
            scene: plan.scene,
            sequence: plan.sequence,
            rois: plan.rois.clone(),
            colour: plan.colour.clone().map(Box::new),
        }
    }

    /// The camera's exposure timing.
    pub fn shutter(&self) -> Shutter {
        self.camera.exposure_timing()
    }

    /// The same simulator with the LED's first rising edge `delay_s`
    /// seconds after frame 0 starts, in place of the plan's `pwm-delay-ms`:
    /// the run at another PWM phase, which the report shows for a verdict
    /// on the worst case over phase.
    pub fn with_pwm_delay(&self, delay_s: f64) -> Self {
        let mut other = self.clone();
        other.camera.pwm_delay_s = delay_s;
        other
    }

    /// Whether this is the ideal camera (no `[sensor]` table), whose worst
    /// case over phase is a closed form of the ON fraction.
    pub fn is_ideal(&self) -> bool {
        self.camera.physical.is_none()
    }

    /// The PWM drive of `case`: its frequency on the simulator's clock
    /// (`pwm-clock-offset-ppm`), its first rise at `pwm-delay-ms`.
    pub fn pwm_for(&self, case: &TestCase) -> Result<PwmDrive, BackendError> {
        let f = case.frequency_hz * (1.0 + self.scene.pwm_clock_offset_ppm * 1e-6);
        PwmDrive::new(f, case.duty, self.camera.pwm_delay_s).map_err(|message| BackendError {
            backend: self.id().to_string(),
            case: case.id.clone(),
            message,
        })
    }

    /// Every frame of a case, as [`Backend::acquire`] lists them: frame
    /// `k` at `k / fps` seconds, labelled by the plan's sequence. The same
    /// for every case of the plan.
    pub fn frames(&self) -> Vec<FrameInfo> {
        let segments = SegmentFrames::new(&self.sequence, self.camera.fps);
        (0..segments.total())
            .map(|k| FrameInfo {
                index: k,
                time_s: k as f64 / self.camera.fps,
                segment: segments.segment(k),
            })
            .collect()
    }

    fn acquire_ideal(&self, case: &TestCase, pwm: &PwmDrive) -> Acquisition {
        let cam = &self.camera;
        let shutter = self.shutter();
        let frames = self.frames();
        let k = cam.response_dn_per_cd_m2_s * cam.exposure_s;
        let background = k * self.scene.background_luminance_cd_m2(case.light_lux);
        let led_peak = k * self.scene.led_fill * self.scene.led_luminance_cd_m2;
        let out =
            |s: f64, led: f64| (cam.black_level_dn + background + led * s).min(cam.full_scale_dn);
        let emitters = dies::emitters(self.colour.as_deref(), pwm);
        let steady = steady_fraction(&emitters);
        let rois = self
            .rois
            .iter()
            .map(|roi| {
                let led = if roi.kind == RoiKind::Led {
                    led_peak
                } else {
                    0.0
                };
                let pwm_frames = pwm_frame_range(&frames);
                let per_source =
                    mixed_on_fractions(&shutter, &emitters, pwm_frames.clone(), roi, 0.0);
                let on: Vec<f64> = (0..pwm_frames.end - pwm_frames.start)
                    .map(|i| weighted(&emitters, |j| per_source[j][i as usize], |e| e.share))
                    .collect();
                let luma = frames
                    .iter()
                    .map(|f| match f.segment {
                        Segment::On => out(steady, led),
                        Segment::Off => out(0.0, led),
                        Segment::Pwm => out(on[(f.index - pwm_frames.start) as usize], led),
                    })
                    .collect();
                let (lo, hi) = match emitters.as_slice() {
                    [one] => shutter.phase_envelope(&one.drive, roi.rows()),
                    dies => mixed_envelope(&shutter, dies, roi.rows()),
                };
                let rgb = match (&self.colour, roi.kind) {
                    (Some(colour), RoiKind::Led) => {
                        Some(self.colour_planes(case, pwm, roi, colour, &frames))
                    }
                    _ => None,
                };
                RoiTrace {
                    name: roi.name.clone(),
                    luma,
                    phase_envelope: Some((out(lo, led), out(hi, led))),
                    rgb,
                }
            })
            .collect();
        Acquisition {
            capture: None,
            frames,
            rois,
            saturation_dn: cam.saturation_dn,
        }
    }

    /// Mean DN of each colour plane of an LED ROI, frame by frame, through
    /// the ideal camera: plane `p` sees each source of the LED's light
    /// (the LED, or each die) through its camera RGB per cd/m^2 times its
    /// share (and the grey background's `white_rgb[p]`), over its own
    /// exposure, which starts `plane_offsets_s[p]` after the frame's. A
    /// later exposure sees the PWM's edges earlier: the same integral with
    /// the first rise moved back by the offset.
    fn colour_planes(
        &self,
        case: &TestCase,
        pwm: &PwmDrive,
        roi: &Roi,
        colour: &ColourConfig,
        frames: &[FrameInfo],
    ) -> Vec<[f64; 3]> {
        let cam = &self.camera;
        let shutter = self.shutter();
        let k = cam.response_dn_per_cd_m2_s * cam.exposure_s;
        let background = k * self.scene.background_luminance_cd_m2(case.light_lux);
        let led = k * self.scene.led_fill * self.scene.led_luminance_cd_m2;
        let pwm_frames = pwm_frame_range(frames);
        let emitters = dies::emitters(self.colour.as_deref(), pwm);
        let planes: Vec<Vec<f64>> = (0..3)
            .map(|p| {
                let on = mixed_on_fractions(
                    &shutter,
                    &emitters,
                    pwm_frames.clone(),
                    roi,
                    colour.plane_offsets_s[p],
                );
                let out = |fraction: &dyn Fn(usize) -> f64| {
                    let v = background * colour.white_rgb[p]
                        + weighted(&emitters, fraction, |e| led * (e.share * e.rgb[p]));
                    (cam.black_level_dn + v).min(cam.full_scale_dn)
                };
                frames
                    .iter()
                    .map(|f| match f.segment {
                        Segment::On => out(&|j| emitters[j].drive.duty()),
                        Segment::Off => out(&|_| 0.0),
                        Segment::Pwm => {
                            let i = (f.index - pwm_frames.start) as usize;
                            out(&|j| on[j][i])
                        }
                    })
                    .collect()
            })
            .collect();
        (0..frames.len())
            .map(|i| [planes[0][i], planes[1][i], planes[2][i]])
            .collect()
    }

    /// Start of capture `c` of row `row`, seconds after the frame starts.
    fn capture_offset_s(&self, p: &PhysicalCamera, t_ref: f64, row: u32, c: usize) -> f64 {
        let row_offset = match self.camera.shutter {
            ShutterKind::Global => 0.0,
            ShutterKind::Rolling => row as f64 * self.camera.line_time_s,
        };
        match p.hdr_mode {
            HdrMode::SplitPixel => row_offset,
            HdrMode::Sequential => {
                row_offset
                    + p.captures[..c]
                        .iter()
                        .map(|cap| cap.exposure_s(t_ref))
                        .sum::<f64>()
            }
        }
    }

    /// One ROI row of frame `frame` through sensor, merge and tone curve.
    #[allow(clippy::too_many_arguments)]
    fn row(
        &self,
        p: &PhysicalCamera,
        state: ExposureState,
        light: Light<'_>,
        frame: u64,
        row: u32,
        background_cd_m2: f64,
        led_cd_m2: f64,
        mut noise: Option<(&mut Rng, u32)>,
    ) -> RowOutput {
        let t_ref = state.exposure_s;
        let mut samples = [CaptureSample {
            dn: 0.0,
            saturated: false,
        }; 4];
        let mut scale = [1.0; 4];
        let n = p.captures.len();
        let ref_gain = p.captures[0].exposure_s(t_ref) * p.captures[0].sensitivity_ratio;
        for (c, cap) in p.captures.iter().enumerate() {
            let t_c = cap.exposure_s(t_ref);
            let on_s = match light {
                Light::Steady(s) => s * t_c,
                Light::Pwm(pwm) => {
                    let phase = pwm.phase_at(
                        frame,
                        self.camera.fps,
                        self.capture_offset_s(p, t_ref, row, c),
                    );
                    t_c * on_fraction(phase, t_c * pwm.frequency_hz(), pwm.duty())
                }
            };
            let electrons = p.sensor.sensitivity_e_per_cd_m2_s
                * cap.sensitivity_ratio
                * (background_cd_m2 * t_c + led_cd_m2 * on_s);
            let rng = noise.as_mut().map(|(r, px)| (&mut **r, *px));
            samples[c] = p.sensor.capture(electrons, state.analog_gain, rng);
            scale[c] = t_c * cap.sensitivity_ratio / ref_gain;
        }
        let (merged, _) = merge(&samples[..n], &scale[..n], p.merge, p.sensor.dn_max());
        let linear = merged * state.digital_gain;
        let luma =
            (self.camera.black_level_dn + p.tone.apply(linear)).min(self.camera.full_scale_dn);
        RowOutput { luma, linear }
    }

    /// Mean ROI luma for a frame whose PWM phase (row 0, capture 0) is
    /// `phase` cycles, noise off, at exposure `state`.
    #[allow(clippy::too_many_arguments)]
    fn roi_luma_at_phase(
        &self,
        p: &PhysicalCamera,
        state: ExposureState,
        pwm: &PwmDrive,
        phase: f64,
        roi: &Roi,
        background: f64,
        led: f64,
    ) -> f64 {
        let f = pwm.frequency_hz();
        // A drive of a valid frequency and duty shifted by a finite phase is
        // valid; fall back to the unshifted drive rather than panic.
        let shifted = PwmDrive::new(f, pwm.duty(), -phase / f).unwrap_or(*pwm);
        let rows = roi.rows();
        let n = rows.len() as f64;
        rows.map(|r| {
            self.row(p, state, Light::Pwm(&shifted), 0, r, background, led, None)
                .luma
        })
        .sum::<f64>()
            / n
    }

    /// Lowest and highest ROI luma over every PWM phase, with auto exposure
    /// held at `state` and noise off (docs/camera-model.md, "Worst case
    /// over phase"). Breakpoints: every capture's ON-time corners (where a
    /// capture edge meets a PWM edge), the phases where a capture's
    /// electrons cross its saturation level (and, for the weighted merge,
    /// the hat's knee) on either side, and a uniform grid of [`PHASE_GRID`]
    /// phases; [`extremes`] then searches inside every interval whose end
    /// slopes show an interior extreme.
    #[allow(clippy::too_many_arguments)]
    fn physical_envelope(
        &self,
        p: &PhysicalCamera,
        state: ExposureState,
        pwm: &PwmDrive,
        roi: &Roi,
        background: f64,
        led: f64,
    ) -> (f64, f64) {
        let f = pwm.frequency_hz();
        let d = pwm.duty();
        let offset0 = self.capture_offset_s(p, state.exposure_s, roi.y_px, 0);
        let luma = |phi: f64| {
            // Phase of the ROI's first row; `roi_luma_at_phase` measures from row 0.
            let phi0 = wrap_unit(phi - offset0 * f);
            self.roi_luma_at_phase(p, state, pwm, phi0, roi, background, led)
        };
        if led == 0.0 {
            // No LED in this ROI: nothing depends on the phase.
            let v = luma(0.0);
            return (v, v);
        }
        // (phase offset o, width w in cycles, capture) of every row's captures.
        let windows: Vec<(f64, f64, usize)> = roi
            .rows()
            .flat_map(|r| {
                (0..p.captures.len()).map(move |c| {
                    let o = (self.capture_offset_s(p, state.exposure_s, r, c) - offset0) * f;
                    (o, p.captures[c].exposure_s(state.exposure_s) * f, c)
                })
            })
            .collect();
        let mut corners: Vec<f64> = windows
            .iter()
            .flat_map(|&(o, w, _)| [0.0, d, -w, d - w].map(|k| wrap_unit(k - o)))
            .collect();
        corners.extend((0..PHASE_GRID).map(|i| i as f64 / PHASE_GRID as f64));
        corners.sort_by(f64::total_cmp);
        corners.dedup();
        let crossings = self.saturation_crossings(p, state, &windows, &corners, d, background, led);
        corners.extend(crossings);
        extremes(corners, luma)
    }

    /// Phases (just either side) where some capture's electrons cross its
    /// saturation level or the weighted merge's knee: each capture's
    /// electrons are linear in phase between consecutive `corners`.
    #[allow(clippy::too_many_arguments)]
    fn saturation_crossings(
        &self,
        p: &PhysicalCamera,
        state: ExposureState,
        windows: &[(f64, f64, usize)],
        corners: &[f64],
        d: f64,
        background: f64,
        led: f64,
    ) -> Vec<f64> {
        let s = &p.sensor;
        let adc_e = s.dn_max() * s.e_per_dn / state.analog_gain;
        let mut levels = vec![s.full_well_e.min(adc_e)];
        if p.merge == ledflicker_physics::hdr::MergeRule::Weighted {
            levels.push(0.8 * adc_e);
        }
        let mut out = Vec::new();
        for &(o, w, c) in windows {
            let cap = &p.captures[c];
            let t_c = cap.exposure_s(state.exposure_s);
            let e = |phi: f64| {
                s.sensitivity_e_per_cd_m2_s
                    * cap.sensitivity_ratio
                    * (background * t_c + led * t_c * on_fraction(wrap_unit(phi + o), w, d))
            };
            let values: Vec<f64> = corners.iter().map(|&phi| e(phi)).collect();
            for (ph, v) in corners.windows(2).zip(values.windows(2)) {
                for &level in &levels {
                    if (v[0] - level) * (v[1] - level) < 0.0 {
                        let x = ph[0] + (ph[1] - ph[0]) * (level - v[0]) / (v[1] - v[0]);
                        out.extend([x - CROSSING_SIDE, x, x + CROSSING_SIDE]);
                    }
                }
            }
        }
        out
    }

    fn acquire_physical(&self, case: &TestCase, pwm: &PwmDrive, p: &PhysicalCamera) -> Acquisition {
        self.run_physical(case, pwm, p).0
    }

    /// The physical camera through the sequence; also returns the exposure
    /// settings auto exposure chose for each frame.
    fn run_physical(
        &self,
        case: &TestCase,
        pwm: &PwmDrive,
        p: &PhysicalCamera,
    ) -> (Acquisition, Vec<ExposureState>) {
        let frames = self.frames();
        let background = self.scene.background_luminance_cd_m2(case.light_lux);
        let led = self.scene.led_fill * self.scene.led_luminance_cd_m2;
        let noisy = p.sensor.shot_noise || p.sensor.read_noise_e > 0.0;
        let mut rng = Rng::new(case.seed);
        let a = self.scene.led_frame_fraction;
        let metering_led_roi = self.rois.iter().find(|r| r.kind == RoiKind::Led);

        // The metered level: the background and, for the lamp's share of the
        // frame, the LED region, as a fraction of white.
        let meter =
            |state: ExposureState, light: Light<'_>, frame: u64, led_linear: Option<f64>| -> f64 {
                let bg = self
                    .row(
                        p,
                        state,
                        Light::Steady(0.0),
                        frame,
                        0,
                        background,
                        0.0,
                        None,
                    )
                    .linear;
                let lamp = led_linear.unwrap_or_else(|| {
                    self.row(p, state, light, frame, 0, background, led, None)
                        .linear
                });
                ((1.0 - a) * bg + a * lamp) / p.tone.white
            };

        let mut state = match &p.auto_exposure {
            Some(ae) => {
                // The camera has been running with the light steady ON before
                // the test starts: settle auto exposure on that scene.
                let mut s = ae.split(self.camera.exposure_s);
                for _ in 0..500 {
                    let next = ae.update(s, meter(s, Light::Steady(case.duty), 0, None));
                    if next == s {
                        break;
                    }
                    s = next;
                }
                s
            }
            None => ExposureState {
                exposure_s: self.camera.exposure_s,
                analog_gain: p.analog_gain,
                digital_gain: p.digital_gain,
            },
        };

        let mut luma: Vec<Vec<f64>> = vec![Vec::with_capacity(frames.len()); self.rois.len()];
        let mut states = Vec::with_capacity(frames.len());
        for f in &frames {
            states.push(state);
            let light = match f.segment {
                Segment::On => Light::Steady(case.duty),
                Segment::Off => Light::Steady(0.0),
                Segment::Pwm => Light::Pwm(pwm),
            };
            let mut led_linear = None;
            for (i, roi) in self.rois.iter().enumerate() {
                let led_here = if roi.kind == RoiKind::Led { led } else { 0.0 };
                let mut sum_luma = 0.0;
                let mut sum_lin = 0.0;
                for r in roi.rows() {
                    let noise = noisy.then_some((&mut rng, roi.width_px));
                    let out = self.row(p, state, light, f.index, r, background, led_here, noise);
                    sum_luma += out.luma;
                    sum_lin += out.linear;
                }
                let n = roi.height_px as f64;
                luma[i].push(sum_luma / n);
                if metering_led_roi.is_some_and(|m| m.name == roi.name) {
                    led_linear = Some(sum_lin / n);
                }
            }
            if let Some(ae) = &p.auto_exposure {
                state = ae.update(state, meter(state, light, f.index, led_linear));
            }
        }

        let rois = self
            .rois
            .iter()
            .zip(luma)
            .map(|(roi, luma)| {
                let led_here = if roi.kind == RoiKind::Led { led } else { 0.0 };
                RoiTrace {
                    name: roi.name.clone(),
                    luma,
                    phase_envelope: Some(
                        self.physical_envelope(p, state, pwm, roi, background, led_here),
                    ),
                    rgb: None,
                }
            })
            .collect();
        (
            Acquisition {
                capture: None,
                frames,
                rois,
                saturation_dn: self.camera.saturation_dn,
            },
            states,
        )
    }

    /// The lamp's rectangle in a rendered frame: centred on the first LED
    /// ROI, three ROI widths wide and 60 % of the sensor high (the paper's
    /// source fills 10-100 % of the vertical field of view).
    fn lamp_rect(&self) -> (std::ops::Range<u32>, std::ops::Range<u32>) {
        let cam = &self.camera;
        let roi = self.rois.iter().find(|r| r.kind == RoiKind::Led);
        let (cx, cy, w) = roi.map_or((cam.sensor_columns / 2, cam.sensor_rows / 2, 100), |r| {
            (
                r.x_px + r.width_px / 2,
                r.y_px + r.height_px / 2,
                r.width_px,
            )
        });
        let half_w = (3 * w / 2).max(1);
        let half_h = (cam.sensor_rows * 3 / 10).max(1);
        let cols = cx.saturating_sub(half_w)..(cx + half_w).min(cam.sensor_columns);
        let rows = cy.saturating_sub(half_h)..(cy + half_h).min(cam.sensor_rows);
        (cols, rows)
    }

    fn render(&self, case: &TestCase, frame: u64) -> Result<RenderedFrame, BackendError> {
        let cam = &self.camera;
        let pwm = self.pwm_for(case)?;
        let segments = SegmentFrames::new(&self.sequence, cam.fps);
        let segment = segments.segment(frame);
        let background = self.scene.background_luminance_cd_m2(case.light_lux);
        let led = self.scene.led_fill * self.scene.led_luminance_cd_m2;
        let (lamp_cols, lamp_rows) = self.lamp_rect();
        // Each row has two values: lamp and background.
        let per_row: Vec<(f64, f64)> = match &cam.physical {
            None => {
                let shutter = self.shutter();
                let k = cam.response_dn_per_cd_m2_s * cam.exposure_s;
                let out = |s: f64, l: f64| {
                    (cam.black_level_dn + k * (background + l * s)).min(cam.full_scale_dn)
                };
                let emitters = dies::emitters(self.colour.as_deref(), &pwm);
                (0..cam.sensor_rows)
                    .map(|r| {
                        let s = match segment {
                            Segment::On => steady_fraction(&emitters),
                            Segment::Off => 0.0,
                            Segment::Pwm => emitters.iter().fold(0.0, |sum, e| {
                                sum + e.share * shutter.frame_on_fraction(&e.drive, frame, r..r + 1)
                            }),
                        };
                        (out(s, led), out(0.0, 0.0))
                    })
                    .collect()
            }
            Some(p) => {
                let (_, states) = self.run_physical(case, &pwm, p);
                let state = states
                    .get(frame as usize)
                    .copied()
                    .unwrap_or(ExposureState {
                        exposure_s: cam.exposure_s,
                        analog_gain: p.analog_gain,
                        digital_gain: p.digital_gain,
                    });
                let light = match segment {
                    Segment::On => Light::Steady(case.duty),
                    Segment::Off => Light::Steady(0.0),
                    Segment::Pwm => Light::Pwm(&pwm),
                };
                (0..cam.sensor_rows)
                    .map(|r| {
                        let lamp = self
                            .row(p, state, light, frame, r, background, led, None)
                            .luma;
                        let bg = self
                            .row(p, state, light, frame, r, background, 0.0, None)
                            .luma;
                        (lamp, bg)
                    })
                    .collect()
            }
        };
        // Each row as runs: background, the lamp's columns, background.
        let width = cam.sensor_columns;
        let (c0, c1) = (lamp_cols.start.min(width), lamp_cols.end.min(width));
        let rows = per_row
            .iter()
            .enumerate()
            .map(|(r, &(lamp, bg))| {
                let run = |len: u32, value: f64| Run { len, value };
                let runs = if lamp_rows.contains(&(r as u32)) && c1 > c0 {
                    vec![run(c0, bg), run(c1 - c0, lamp), run(width - c1, bg)]
                } else {
                    vec![run(width, bg)]
                };
                runs.into_iter().filter(|r| r.len > 0).collect()
            })
            .collect();
        Ok(RenderedFrame::from_runs(
            frame,
            width,
            cam.full_scale_dn,
            rows,
        ))
    }
}

impl Backend for Simulator {
    fn id(&self) -> &str {
        if self.camera.physical.is_some() {
            "sim-physical"
        } else {
            "sim-ideal"
        }
    }

    fn acquire(&self, case: &TestCase) -> Result<Acquisition, BackendError> {
        let pwm = self.pwm_for(case)?;
        Ok(match &self.camera.physical {
            None => self.acquire_ideal(case, &pwm),
            Some(p) => self.acquire_physical(case, &pwm, p),
        })
    }

    fn render_frame(
        &self,
        case: &TestCase,
        frame: u64,
    ) -> Option<Result<RenderedFrame, BackendError>> {
        Some(self.render(case, frame))
    }
}

/// The frame indices of the PWM segment, which is one contiguous run (the
/// sequence is ON, OFF, PWM); empty when the sequence has no PWM frames.
fn pwm_frame_range(frames: &[FrameInfo]) -> std::ops::Range<u64> {
    let mut pwm = frames.iter().filter(|f| f.segment == Segment::Pwm);
    match (pwm.next(), pwm.next_back()) {
        (Some(first), Some(last)) => first.index..last.index + 1,
        (Some(first), None) => first.index..first.index + 1,
        _ => 0..0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plan of `profile` (a shipped camera file, noise off) with a lamp of
    /// `led` cd/m^2, in a fresh directory.
    fn plan_of(profile: &str, led: f64) -> Plan {
        let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
        let text = std::fs::read_to_string(root.join("reference-data/cameras").join(profile))
            .unwrap()
            .replace("shot-noise = true", "shot-noise = false");
        let dir = std::env::temp_dir().join(format!(
            "ledflicker-envelope-{}-{profile}-{led}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("camera.toml"), text).unwrap();
        let plan = format!(
            "format-version = 2\n[plan]\nid = \"e\"\ntitle = \"e\"\n[sequence]\non-s = 0.3\noff-s = 0.3\npwm-s = 0.5\n[light]\nlevels-lux = [40.0, 2000.0]\n[grid]\nfrequencies-hz = [90.0, 151.3, 397.7]\nduty-cycles = [0.1, 0.5]\n[[roi]]\nname = \"led\"\nx-px = 910\ny-px = 539\nwidth-px = 100\nheight-px = 2\n[dut]\ncamera-profile = \"camera.toml\"\n[scene]\nled-luminance-cd-m2 = {led}\nled-frame-fraction = 0.005\n"
        );
        std::fs::write(dir.join("plan.toml"), plan).unwrap();
        ledflicker_plan::plan::load(&dir.join("plan.toml")).unwrap()
    }

    /// The envelope is never narrower than a brute-force search over 16 384
    /// phases; the old search (corners and 1 024 phases only) could be.
    /// Prints the largest shortfall of the old search in Percent Flicker
    /// points (`--nocapture`).
    #[test]
    fn physical_envelope_is_never_narrower_than_a_dense_search() {
        let pf = |(lo, hi): (f64, f64)| 100.0 * (hi - lo) / (hi + lo);
        let mut old_short: f64 = 0.0;
        let mut short: f64 = f64::NEG_INFINITY;
        for profile in ["split-pixel-lfm.toml", "deegan2018-hdr3.toml"] {
            for led in [1000.0, 200_000.0] {
                let plan = plan_of(profile, led);
                let sim = Simulator::new(&plan);
                let p = plan.dut.camera.physical.as_ref().unwrap();
                let roi = &plan.rois[0];
                for case in ledflicker_plan::plan::expand_cases(&plan) {
                    let pwm = sim.pwm_for(&case).unwrap();
                    let (_, states) = sim.run_physical(&case, &pwm, p);
                    let state = *states.last().unwrap();
                    let bg = plan.scene.background_luminance_cd_m2(case.light_lux);
                    let lum = plan.scene.led_fill * led;
                    let env = sim.physical_envelope(p, state, &pwm, roi, bg, lum);
                    let at = |i: usize, n: usize| {
                        sim.roi_luma_at_phase(p, state, &pwm, i as f64 / n as f64, roi, bg, lum)
                    };
                    let dense = (0..16_384)
                        .map(|i| at(i, 16_384))
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                            (a.min(v), b.max(v))
                        });
                    let tol = 1e-9 * p.tone.output_max;
                    assert!(
                        env.0 <= dense.0 + tol && env.1 >= dense.1 - tol,
                        "{profile} {} {led}: envelope {env:?}, dense {dense:?}",
                        case.id
                    );
                    let grid = (0..PHASE_GRID)
                        .map(|i| at(i, PHASE_GRID))
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                            (a.min(v), b.max(v))
                        });
                    old_short = old_short.max(pf(dense) - pf(grid));
                    short = short.max(pf(dense) - pf(env));
                }
            }
        }
        println!(
            "largest Percent Flicker shortfall against 16 384 phases: envelope {short:.6} points, a 1024-phase grid alone {old_short:.5} points"
        );
    }
}
