//! A small recording generator for the segment-detection tests, independent
//! of the simulator: an ideal global-shutter camera at 29.97 fps records
//! the paper's sequence (dark lead-in, ON, OFF, PWM, dark lead-out). Each
//! frame collects the exact on-time integral of an ideal PWM over its
//! exposure, `F(t) = floor(t/P) D P + min(t mod P, D P)`
//! (docs/camera-model.md, "3. Light on the row"), with an auto-exposure overshoot (30 % in the tests) after every
//! step that decays linearly to zero in 0.15 s. Writes CSV traces (noise-free) and
//! H.264 video (limited-range Y', Gaussian noise) through `ffmpeg`.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// 30000/1001 frames per second.
pub const FPS: f64 = 30000.0 / 1001.0;
/// The sequence the recordings follow, seconds.
pub const ON_S: f64 = 2.0;
pub const OFF_S: f64 = 2.0;
pub const PWM_S: f64 = 9.0;
/// The plan's settle time, seconds.
pub const SETTLE_S: f64 = 0.5;
/// LED-ROI luma with the LED off, and what steady ON adds, DN (full range).
pub const OFF_DN: f64 = 20.0;
pub const RISE_DN: f64 = 40.0;
/// Background-ROI luma, DN: it must not steer detection.
pub const BG_DN: f64 = 150.0;
/// The AE overshoot after each step decays to zero in this time, seconds.
const OVERSHOOT_S: f64 = 0.15;

/// One recording to make.
#[derive(Debug, Clone)]
pub struct Recording {
    pub name: &'static str,
    /// Dark time before the ON step, seconds; 0: the capture starts in ON.
    pub lead_in_s: f64,
    /// With no lead-in: how much of the ON segment is recorded, seconds.
    pub on_seen_s: f64,
    /// Dark time after the PWM segment, seconds.
    pub lead_out_s: f64,
    pub frequency_hz: f64,
    pub exposure_s: f64,
    pub duty: f64,
    /// Where the first settled PWM frame's exposure starts in the PWM
    /// period, as a fraction of the period.
    pub phase: f64,
    /// A frame left out of the capture (its time stays a gap).
    pub dropped: Option<usize>,
    /// Auto-exposure overshoot just after each step, fraction (0.3: 30 %).
    pub overshoot: f64,
}

/// Truth spans in frame indices of the recorded (post-drop) frames, start
/// inclusive, end exclusive: frames whose whole exposure lies in the
/// segment, after the settle time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    pub on: (u64, u64),
    pub off: (u64, u64),
    pub pwm: (u64, u64),
    /// Exact FDI (2018) and Percent Flicker over the truth spans, noise-free.
    pub fdi: f64,
    pub pf: f64,
}

/// The frames of a recording: time, LED-ROI luma and background luma (DN).
pub struct Frames {
    pub time_s: Vec<f64>,
    pub led: Vec<f64>,
    pub bg: Vec<f64>,
    pub truth: Truth,
}

/// Integral of an ideal PWM (ON first at u = 0) from 0 to `u`, seconds.
fn on_time(u: f64, period: f64, duty: f64) -> f64 {
    (u / period).floor() * duty * period + u.rem_euclid(period).min(duty * period)
}

impl Recording {
    fn steps(&self) -> (f64, f64, f64, f64) {
        let t_on = if self.lead_in_s > 0.0 {
            self.lead_in_s
        } else {
            self.on_seen_s - ON_S
        };
        let t_off = t_on + ON_S;
        let t_pwm = t_off + OFF_S;
        (t_on, t_off, t_pwm, t_pwm + PWM_S)
    }

    /// Makes the frames.
    pub fn frames(&self) -> Frames {
        let (t_on, t_off, t_pwm, t_end) = self.steps();
        let period = 1.0 / self.frequency_hz;
        let (d, texp) = (self.duty, self.exposure_s);
        let capture_end = t_end + self.lead_out_s;
        let n_all = ((capture_end - texp) * FPS).floor() as usize;
        // PWM start delay: the first settled PWM frame sits at `phase`.
        let k_first = ((t_pwm + SETTLE_S) * FPS).ceil();
        let delay = (k_first / FPS - t_pwm - self.phase * period).rem_euclid(period);
        let pwm_integral = |a: f64, b: f64| {
            let (a, b) = (a.clamp(t_pwm, t_end), b.clamp(t_pwm, t_end));
            on_time(b - t_pwm - delay, period, d) - on_time(a - t_pwm - delay, period, d)
        };
        let on_integral = |a: f64, b: f64| d * (b.min(t_off) - a.max(t_on)).max(0.0);
        let mut steps = vec![(t_off, -1.0), (t_pwm, 1.0)];
        if t_on > 0.0 {
            steps.push((t_on, 1.0));
        }
        if self.lead_out_s > 0.0 {
            steps.push((t_end, -1.0));
        }
        let gain = |t: f64| {
            steps.iter().fold(1.0, |g, &(s, sign)| {
                let dt = t - s;
                if (0.0..OVERSHOOT_S).contains(&dt) {
                    g + sign * self.overshoot * (1.0 - dt / OVERSHOOT_S)
                } else {
                    g
                }
            })
        };
        let (mut time_s, mut led, mut bg, mut ideal) = (vec![], vec![], vec![], vec![]);
        for k in (0..n_all).filter(|&k| Some(k) != self.dropped) {
            let t = k as f64 / FPS;
            let collected = on_integral(t, t + texp) + pwm_integral(t, t + texp);
            let luma = OFF_DN + RISE_DN * collected / (d * texp);
            time_s.push(t);
            ideal.push(luma);
            led.push(luma * gain(t));
            bg.push(BG_DN * gain(t));
        }
        let span = |from: f64, to: f64| {
            let a = time_s.partition_point(|&t| t < from - 1e-9) as u64;
            let b = time_s.partition_point(|&t| t + texp <= to + 1e-9) as u64;
            (a, b)
        };
        let on_from = if t_on > 0.0 { t_on + SETTLE_S } else { 0.0 };
        let on = span(on_from, t_off);
        let off = span(t_off + SETTLE_S, t_pwm);
        let pwm = span(t_pwm + SETTLE_S, t_end);
        let seg = |(a, b): (u64, u64)| &ideal[a as usize..b as usize];
        let l_off = seg(off).iter().sum::<f64>() / seg(off).len() as f64;
        let min = seg(pwm).iter().copied().fold(f64::INFINITY, f64::min);
        let max = seg(pwm).iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let truth = Truth {
            on,
            off,
            pwm,
            fdi: (min - l_off) / l_off,
            pf: 100.0 * (max - min) / (max + min),
        };
        Frames {
            time_s,
            led,
            bg,
            truth,
        }
    }
}

/// Writes `frame,time_s,led,bg` rows.
pub fn write_csv(path: &Path, f: &Frames) {
    let mut text = String::from("frame,time_s,led,bg\n");
    for k in 0..f.time_s.len() {
        text += &format!("{k},{},{},{}\n", f.time_s[k], f.led[k], f.bg[k]);
    }
    std::fs::write(path, text).unwrap();
}

/// Frame size of the videos and the ROIs in them: LED on the left half,
/// background on the right, each 12 x 2 pixels.
pub const WIDTH: usize = 32;
pub const HEIGHT: usize = 16;
pub const LED_ROI: (u32, u32, u32, u32) = (2, 7, 12, 2);
pub const BG_ROI: (u32, u32, u32, u32) = (18, 7, 12, 2);

/// xorshift64* and Box-Muller: deterministic Gaussian noise.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gaussian(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Writes an H.264 MP4: Y' = 16 + 219/255 x luma plus Gaussian noise of
/// `sigma` codes per pixel, limited range, 4:2:0 with neutral chroma. The
/// container keeps the frame times, so a dropped frame is a gap.
pub fn write_video(path: &Path, f: &Frames, sigma: f64, seed: u64) {
    let mut noise = Noise(seed | 1);
    let mut raw = Vec::with_capacity(f.time_s.len() * WIDTH * HEIGHT * 3 / 2);
    for k in 0..f.time_s.len() {
        for _y in 0..HEIGHT {
            for x in 0..WIDTH {
                let v = if x < WIDTH / 2 { f.led[k] } else { f.bg[k] };
                let code = 16.0 + v * 219.0 / 255.0 + sigma * noise.gaussian();
                raw.push(code.round().clamp(0.0, 255.0) as u8);
            }
        }
        raw.extend(std::iter::repeat_n(128u8, WIDTH * HEIGHT / 2));
    }
    // Frame numbers on the 1001/30000 s time base, gaps kept.
    let pts: Vec<u64> = f.time_s.iter().map(|t| (t * FPS).round() as u64).collect();
    let expr = pts
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] > w[0] + 1)
        .fold("N".to_string(), |e, (i, w)| {
            format!("{e}+{}*gte(N\\,{})", w[1] - w[0] - 1, i + 1)
        });
    let mut child = Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "yuv420p"])
        .args([
            "-s",
            &format!("{WIDTH}x{HEIGHT}"),
            "-framerate",
            "30000/1001",
        ])
        .args(["-i", "-", "-vf", &format!("setpts={expr}")])
        .args([
            "-fps_mode",
            "passthrough",
            "-c:v",
            "libx264",
            "-preset",
            "ultrafast",
        ])
        .args(["-crf", "12", "-color_range", "tv", "-pix_fmt", "yuv420p"])
        .arg(path)
        .stdin(Stdio::piped())
        .spawn()
        .expect("ffmpeg runs (scripts/test.sh installs it)");
    child.stdin.take().unwrap().write_all(&raw).unwrap();
    assert!(child.wait().unwrap().success(), "ffmpeg failed on {path:?}");
}
