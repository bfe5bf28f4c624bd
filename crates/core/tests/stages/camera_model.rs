//! docs/camera-model.md re-implemented from its equations alone:
//! timing, ON time, electrons, clipping, ADC, saturation tests, merge, white
//! point, tone curve and auto exposure, written here without calling the
//! simulator's physics, and compared frame by frame with the simulator on
//! every shipped HDR profile with noise off.

use ledflicker_core::backend::Backend;
use ledflicker_core::backend::sim::Simulator;
use ledflicker_core::physics::hdr::{CaptureExposure, HdrMode, MergeRule, ToneCurve};
use ledflicker_core::plan::{self, Plan, ShutterKind, TestCase};

use crate::{root, scratch};

/// Exposure state `(T, G_a, G_d)` (section 1).
type State = (f64, f64, f64);

/// The documented model of one plan; every number comes from the plan's
/// keys, every rule from the document.
struct Doc<'a> {
    plan: &'a Plan,
    white: f64,
    target: f64,
}

impl Doc<'_> {
    fn p(&self) -> &ledflicker_core::plan::PhysicalCamera {
        self.plan.dut.camera.physical.as_ref().unwrap()
    }

    /// Section 2: `T_c`.
    fn t_c(&self, t: f64, c: usize) -> f64 {
        match self.p().captures[c].exposure {
            CaptureExposure::Ratio(r) => r * t,
            CaptureExposure::Fixed(s) => s,
        }
    }

    /// Sections 2-7 for one row of frame `k`: (`out`, `lin`). `light`:
    /// `Some(s)` steady at `s` (ON segment duty, OFF 0), `None` PWM.
    fn row(
        &self,
        case: &TestCase,
        st: State,
        k: u64,
        r: u32,
        light: Option<f64>,
        led: f64,
    ) -> (f64, f64) {
        let (cam, p, sc) = (&self.plan.dut.camera, self.p(), &self.plan.scene);
        let rho = match cam.shutter {
            ShutterKind::Rolling => r as f64 * cam.line_time_s,
            ShutterKind::Global => 0.0,
        };
        let f = case.frequency_hz * (1.0 + sc.pwm_clock_offset_ppm * 1e-6);
        let g = |x: f64| x.floor() * case.duty + x.rem_euclid(1.0).min(case.duty);
        let l_bg = sc.background_reflectance * case.light_lux / std::f64::consts::PI;
        let n = p.captures.len();
        let k0 = self.t_c(st.0, 0) * p.captures[0].sensitivity_ratio;
        let dn_max = 2f64.powi(p.sensor.adc_bits as i32) - 1.0;
        let mut caps = Vec::new(); // (dn, saturated, k_c)
        let mut s = k as f64 / cam.fps + rho;
        for c in 0..n {
            let t_c = self.t_c(st.0, c);
            if p.hdr_mode == HdrMode::SplitPixel {
                s = k as f64 / cam.fps + rho;
            }
            let x0 = (s - cam.pwm_delay_s) * f;
            let t_on = light.map_or((g(x0 + t_c * f) - g(x0)) / f, |d| d * t_c);
            let e = p.sensor.sensitivity_e_per_cd_m2_s
                * p.captures[c].sensitivity_ratio
                * (l_bg * t_c + led * t_on);
            let dn = e.clamp(0.0, p.sensor.full_well_e) * st.1 / p.sensor.e_per_dn;
            let sat = e >= p.sensor.full_well_e || dn >= dn_max;
            caps.push((
                dn.min(dn_max),
                sat,
                t_c * p.captures[c].sensitivity_ratio / k0,
            ));
            s += t_c;
        }
        let least = caps
            .iter()
            .fold(caps[0], |a, &b| if b.2 < a.2 { b } else { a });
        let merged = match p.merge {
            MergeRule::LongestUnsaturated => {
                let best = caps
                    .iter()
                    .filter(|c| !c.1)
                    .fold(None::<(f64, bool, f64)>, |a, &b| {
                        if a.is_none_or(|a| b.2 > a.2) {
                            Some(b)
                        } else {
                            a
                        }
                    });
                best.map_or(least.0 / least.2, |b| b.0 / b.2)
            }
            MergeRule::Weighted => {
                let w = |c: &(f64, bool, f64)| {
                    if c.1 {
                        0.0
                    } else {
                        c.2 * ((1.0 - c.0 / dn_max) / 0.2).clamp(0.0, 1.0)
                    }
                };
                let den: f64 = caps.iter().map(w).sum();
                let num: f64 = caps.iter().map(|c| w(c) * c.0 / c.2).sum();
                if den > 0.0 {
                    num / den
                } else {
                    least.0 / least.2
                }
            }
        };
        let lin = merged * st.2;
        let u = (lin / self.white).clamp(0.0, 1.0);
        let y = match p.tone.curve {
            ToneCurve::Linear => u,
            ToneCurve::Gamma(gm) => u.powf(1.0 / gm),
            ToneCurve::Log(a) => (1.0 + a * u).ln() / (1.0 + a).ln(),
        };
        let out = (cam.black_level_dn + y * p.tone.output_max).min(cam.full_scale_dn);
        (out, lin)
    }

    /// Section 8: split and update.
    fn split(&self, b: f64) -> State {
        let ae = self.p().auto_exposure.unwrap();
        let t = b.clamp(ae.min_exposure_s, ae.max_exposure_s);
        let ga = (b / t).clamp(1.0, ae.max_analog_gain);
        (
            t,
            ga,
            (b / t / ga).clamp(ae.min_digital_gain, ae.max_digital_gain),
        )
    }

    fn update(&self, st: State, m: f64) -> State {
        let ae = self.p().auto_exposure.unwrap();
        let ratio = self.target / m.max(1e-9);
        if ratio.ln().abs() <= (1.0 + ae.deadband).ln() {
            return st;
        }
        self.split(st.0 * st.1 * st.2 * ratio.powf(ae.damping))
    }

    /// Every frame's luma of every ROI.
    fn run(&self, case: &TestCase) -> Vec<Vec<f64>> {
        let (cam, sc, seq) = (&self.plan.dut.camera, &self.plan.scene, &self.plan.sequence);
        let led = sc.led_fill * sc.led_luminance_cd_m2;
        let a = sc.led_frame_fraction;
        let meter = |st: State, k: u64, lamp: f64| {
            ((1.0 - a) * self.row(case, st, k, 0, Some(0.0), 0.0).1 + a * lamp) / self.white
        };
        let p = self.p();
        let mut st = match p.auto_exposure {
            None => (cam.exposure_s, p.analog_gain, p.digital_gain),
            Some(_) => {
                let mut s = self.split(cam.exposure_s);
                for _ in 0..500 {
                    let lamp = self.row(case, s, 0, 0, Some(case.duty), led).1;
                    let next = self.update(s, meter(s, 0, lamp));
                    if next == s {
                        break;
                    }
                    s = next;
                }
                s
            }
        };
        let frames = |x: f64| (x * cam.fps).round() as u64;
        let (on, off, pwm) = (frames(seq.on_s), frames(seq.off_s), frames(seq.pwm_s));
        let mut out = vec![Vec::new(); self.plan.rois.len()];
        for k in 0..on + off + pwm {
            let light = if k < on {
                Some(case.duty)
            } else if k < on + off {
                Some(0.0)
            } else {
                None
            };
            let mut lamp = None;
            for (i, roi) in self.plan.rois.iter().enumerate() {
                let l = if roi.kind == plan::RoiKind::Led {
                    led
                } else {
                    0.0
                };
                let rows: Vec<(f64, f64)> = roi
                    .rows()
                    .map(|r| self.row(case, st, k, r, light, l))
                    .collect();
                let n = rows.len() as f64;
                out[i].push(rows.iter().map(|x| x.0).sum::<f64>() / n);
                if lamp.is_none() && roi.kind == plan::RoiKind::Led {
                    lamp = Some(rows.iter().map(|x| x.1).sum::<f64>() / n);
                }
            }
            if p.auto_exposure.is_some() {
                let lamp = lamp.unwrap_or_else(|| self.row(case, st, k, 0, light, led).1);
                st = self.update(st, meter(st, k, lamp));
            }
        }
        out
    }
}

/// The document's default white point and auto-exposure target, from the
/// profile's keys (`toml`: the camera table as written).
fn documented(plan: &Plan, cam: &toml::Value) -> (f64, f64) {
    let p = plan.dut.camera.physical.as_ref().unwrap();
    let dn_max = 2f64.powi(p.sensor.adc_bits as i32) - 1.0;
    let t = plan.dut.camera.exposure_s;
    let t_c = |c: &ledflicker_core::physics::hdr::Capture| match c.exposure {
        CaptureExposure::Ratio(r) => r * t,
        CaptureExposure::Fixed(s) => s,
    };
    let k_min = p
        .captures
        .iter()
        .map(|c| {
            t_c(c) * c.sensitivity_ratio / (t_c(&p.captures[0]) * p.captures[0].sensitivity_ratio)
        })
        .fold(f64::INFINITY, f64::min);
    let white = cam
        .get("hdr")
        .and_then(|h| h.get("white-dn"))
        .and_then(toml::Value::as_float)
        .unwrap_or(dn_max / k_min.min(1.0));
    let ae = &cam["auto-exposure"];
    let target = match (
        ae.get("target").and_then(toml::Value::as_float),
        ae.get("target-luma"),
    ) {
        (Some(t), _) => t,
        (None, y) => {
            let y = y.and_then(toml::Value::as_float).unwrap_or(0.46);
            match p.tone.curve {
                ToneCurve::Linear => y,
                ToneCurve::Gamma(g) => y.powf(g),
                ToneCurve::Log(a) => ((1.0 + a).powf(y) - 1.0) / a,
            }
        }
    };
    (white, target)
}

/// Noise off: `shot-noise = false`, `read-noise-e = 0`.
fn noiseless(text: &str) -> String {
    text.lines()
        .map(|l| {
            if l.trim_start().starts_with("read-noise-e") {
                "read-noise-e = 0.0"
            } else if l.trim_start().starts_with("shot-noise") {
                "shot-noise = false"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

const SCENE: &str = "format-version = 2\n[plan]\nid = \"cm\"\ntitle = \"camera model\"\n[sequence]\non-s = 0.5\noff-s = 0.5\npwm-s = 1.5\n[light]\nlevels-lux = [40.0, 2000.0]\n[grid]\nfrequencies-hz = [90.0, 151.3]\nduty-cycles = [0.1, 0.5]\n[[roi]]\nname = \"led\"\nx-px = 910\ny-px = 539\nwidth-px = 100\nheight-px = 2\n[[roi]]\nname = \"background\"\nkind = \"background\"\nx-px = 100\ny-px = 100\n[dut]\ncamera-profile = \"camera.toml\"\n[thresholds]\nfdi-2018-min = 0.1\n";

/// Compares the document with the simulator on every case of `plan`.
fn compare(name: &str, plan: &Plan, cam: &toml::Value) -> usize {
    let (white, target) = documented(plan, cam);
    let p = plan.dut.camera.physical.as_ref().unwrap();
    assert!((white / p.tone.white - 1.0).abs() < 1e-12, "{name}: white");
    let ae = p
        .auto_exposure
        .expect("the shipped HDR profiles run auto exposure");
    assert!((target / ae.target - 1.0).abs() < 1e-12, "{name}: target");
    let doc = Doc {
        plan,
        white,
        target,
    };
    let sim = Simulator::new(plan);
    let mut frames = 0;
    for case in plan::expand_cases(plan) {
        let acq = sim.acquire(&case).unwrap();
        let want = doc.run(&case);
        for (trace, want) in acq.rois.iter().zip(&want) {
            assert_eq!(trace.luma.len(), want.len(), "{name} {}", case.id);
            for (k, (got, w)) in trace.luma.iter().zip(want).enumerate() {
                assert!(
                    (got - w).abs() <= 1e-9 * p.tone.output_max,
                    "{name} {} {} frame {k}: simulator {got}, document {w}",
                    case.id,
                    trace.name
                );
            }
            frames += want.len();
        }
    }
    frames
}

#[test]
fn the_documented_model_matches_the_simulator_on_every_shipped_hdr_profile() {
    let mut checked = Vec::new();
    for profile in ["deegan2018-hdr3.toml", "split-pixel-lfm.toml"] {
        let text =
            std::fs::read_to_string(root().join("reference-data/cameras").join(profile)).unwrap();
        let cam: toml::Value = toml::from_str::<toml::Value>(&text).unwrap()["camera"].clone();
        // A dim lamp, a bright one that clips every capture, and a clock
        // offset with a PWM delay.
        for (led, extra) in [(1000.0, ""), (3.0e6, "pwm-clock-offset-ppm = 40.0\n")] {
            let dir = scratch(&format!("camera-model-{profile}-{led}"));
            std::fs::write(dir.join("camera.toml"), noiseless(&text)).unwrap();
            let plan_text = format!(
                "{SCENE}[scene]\nled-luminance-cd-m2 = {led}\nled-frame-fraction = 0.005\n{extra}"
            );
            std::fs::write(dir.join("plan.toml"), plan_text).unwrap();
            let plan = plan::load(&dir.join("plan.toml")).unwrap_or_else(|e| panic!("{e}"));
            checked.push((profile, compare(profile, &plan, &cam)));
        }
    }
    // The example plan writes its HDR camera out in [dut.camera].
    let text = std::fs::read_to_string(root().join("test-plans/hdr-example.toml")).unwrap();
    let text = noiseless(&text) + "\n[sequence]\non-s = 0.5\noff-s = 0.5\npwm-s = 1.5\n";
    let dir = scratch("camera-model-hdr-example");
    std::fs::write(dir.join("plan.toml"), &text).unwrap();
    let plan = plan::load(&dir.join("plan.toml")).unwrap_or_else(|e| panic!("{e}"));
    let cam = toml::from_str::<toml::Value>(&text).unwrap()["dut"]["camera"].clone();
    checked.push(("hdr-example", compare("hdr-example", &plan, &cam)));
    assert!(checked.iter().all(|c| c.1 > 100), "{checked:?}");
}
