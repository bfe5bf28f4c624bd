//! Builds the conditions a report states ([`Conditions`]) from the run
//! and its plan: the segments actually used, the frame rate, exposure,
//! light levels, PWM grid and clock, the scene and the ROIs, and the
//! sentences that state them.

use crate::model::conditions::*;
use crate::model::{BackendName, Results, Segment, SegmentMethod};
use crate::plan::{Plan, SegmentFrames};
use crate::util::fixed;

fn stated(label: &str, text: String) -> Stated {
    Stated {
        label: label.to_string(),
        text,
    }
}

/// The distinct values of `xs` (> 0), rising.
/// Of every case, what [`conditions`] states.
#[derive(Default)]
struct Seen {
    light_lux: Vec<f64>,
    frequencies_hz: Vec<f64>,
    duty_cycles: Vec<f64>,
    /// The fitted frame rates of the cases that have one.
    rates: Vec<f64>,
    segments_given: usize,
    segments_detected: usize,
}

impl Seen {
    /// What the conditions need of each case, and each segment's spans, in
    /// one pass: a large run's cases are read back from disk for each pass.
    fn gather(model: &Results, plan: &Plan, simulated: bool) -> (Seen, [Vec<Found>; 3]) {
        let mut seen = Seen::default();
        let mut per: [Vec<Found>; 3] = Default::default();
        for c in &model.cases {
            if let Some(cap) = &c.capture {
                let s = &cap.segments;
                let mut add = |i: usize, f: Option<(u64, u64)>, t: Option<(f64, f64)>| {
                    if let (Some((a, b)), Some((ta, tb))) = (f, t) {
                        per[i].push((a, b, ta, tb));
                    }
                };
                add(0, s.on, s.on_time_s);
                add(1, s.off, s.off_time_s);
                add(2, Some(s.pwm), Some(s.pwm_time_s));
            } else if simulated {
                let fps = plan.dut.camera.fps;
                let n = SegmentFrames::new(&plan.sequence, fps);
                let mut start = 0;
                for (i, count) in [n.on, n.off, n.pwm].into_iter().enumerate() {
                    if count > 0 {
                        let end = start + count;
                        per[i].push((start, end, start as f64 / fps, end as f64 / fps));
                    }
                    start += count;
                }
            }
            seen.light_lux.push(c.light_lux);
            seen.frequencies_hz.push(c.frequency_hz);
            seen.duty_cycles.push(c.duty);
            seen.rates.extend(c.frame_timing.as_ref().map(|t| t.fps));
            match c.capture.as_ref().map(|k| k.segments.method) {
                Some(SegmentMethod::Plan) => seen.segments_given += 1,
                Some(SegmentMethod::Detected) => seen.segments_detected += 1,
                _ => {}
            }
        }
        (seen, per)
    }
}

fn distinct(xs: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut out: Vec<f64> = xs.filter(|x| *x > 0.0).collect();
    out.sort_by(f64::total_cmp);
    out.dedup();
    out
}

/// A segment's frames and seconds in one case: first frame, end frame,
/// start and end time.
type Found = (u64, u64, f64, f64);

/// The ON, OFF and PWM segments over every case, from each case's spans
/// ([`conditions`] gathers them: the simulator's from the plan's sequence
/// at the camera's rate, ON, OFF, PWM back to back from frame 0; a
/// capture's or a rig's as found in it).
fn segments(per: [Vec<Found>; 3]) -> Vec<SegmentSpan> {
    [Segment::On, Segment::Off, Segment::Pwm]
        .into_iter()
        .zip(per)
        .filter(|(_, found)| !found.is_empty())
        .map(|(segment, found)| {
            let first = (found[0].0, found[0].1);
            let same = found.iter().all(|f| (f.0, f.1) == first);
            SegmentSpan {
                segment,
                cases: found.len(),
                frames: same.then_some(first),
                first_frame: Span::of(found.iter().map(|f| f.0 as f64))
                    .unwrap_or(Span { min: 0.0, max: 0.0 }),
                frame_count: Span::of(found.iter().map(|f| (f.1 - f.0) as f64))
                    .unwrap_or(Span { min: 0.0, max: 0.0 }),
                start_s: Span::of(found.iter().map(|f| f.2)).unwrap_or(Span { min: 0.0, max: 0.0 }),
                duration_s: Span::of(found.iter().map(|f| f.3 - f.2))
                    .unwrap_or(Span { min: 0.0, max: 0.0 }),
            }
        })
        .collect()
}

fn segment_name(s: Segment) -> &'static str {
    match s {
        Segment::On => "steady ON",
        Segment::Off => "OFF",
        Segment::Pwm => "PWM",
    }
}

/// Whether some case's segments were given in the plan, and whether some
/// were detected.
#[derive(Debug, Clone, Copy)]
struct SegmentMethods {
    plan: bool,
    detected: bool,
}

/// The sequence sentence: each segment's frames and seconds, as used.
fn sequence_text(
    spans: &[SegmentSpan],
    methods: SegmentMethods,
    total: usize,
    backend: BackendName,
) -> String {
    if spans.is_empty() {
        return "no segment was used".to_string();
    }
    let mut parts: Vec<String> = spans
        .iter()
        .map(|s| {
            let name = segment_name(s.segment);
            let single = |x: &Span| fixed(x.min, 3) == fixed(x.max, 3);
            let seconds = if single(&s.start_s) && single(&s.duration_s) {
                let end = s.start_s.min + s.duration_s.min;
                format!("{}-{} s", fixed(s.start_s.min, 3), fixed(end, 3))
            } else {
                format!(
                    "from {}, {} long",
                    s.start_s.text(3, "s"),
                    s.duration_s.text(3, "s")
                )
            };
            let mut t = match s.frames {
                // Frame numbers as a reader counts them: first and last, inclusive.
                Some((a, b)) => format!("{name} frames {a}-{} ({seconds})", b.max(a + 1) - 1),
                None => format!(
                    "{name} {} frames from frame {} ({seconds}; each case's page gives its own)",
                    s.frame_count.text(0, "").trim_end(),
                    s.first_frame.text(0, "").trim_end(),
                ),
            };
            if s.cases < total {
                t += &format!(" in {} of {total} cases", s.cases);
            }
            t
        })
        .collect();
    if !spans.iter().any(|s| s.segment == Segment::On) {
        parts.push("no steady ON segment".to_string());
    }
    let found = match (methods.plan, methods.detected) {
        (true, false) => "given in the plan",
        (false, true) => "detected per case from the LED-ROI luma",
        _ => "given in the plan or detected per case",
    };
    let how = match backend {
        BackendName::Simulator => "simulated for every case, ON at the PWM average".to_string(),
        BackendName::Captured => format!("as used in the captures, {found}"),
        BackendName::Command => format!("as used in the rig's frames, {found}"),
    };
    format!("{}; {how}", parts.join(", "))
}

/// The PWM clock of the simulator: its offset, and what it does to the
/// frequencies that are whole multiples of the frame rate.
fn pwm_clock(plan: &Plan, frequencies: &[f64]) -> PwmClock {
    let fps = plan.dut.camera.fps;
    let ppm = plan.scene.pwm_clock_offset_ppm;
    let multiples_hz: Vec<f64> = frequencies
        .iter()
        .copied()
        .filter(|&f| crate::analysis::apparent::apparent_frequency_hz(f, fps) == 0.0)
        .collect();
    let drift_period_s = if ppm == 0.0 {
        Vec::new()
    } else {
        multiples_hz
            .iter()
            .map(|f| Some(1.0 / (f * ppm.abs() * 1e-6)).filter(|p| p.is_finite()))
            .collect()
    };
    PwmClock {
        offset_ppm: ppm,
        delay_ms: plan.dut.camera.pwm_delay_s * 1e3,
        multiples_hz,
        drift_period_s,
    }
}

fn pwm_clock_text(c: &PwmClock, fps: f64) -> String {
    let edge = format!("first rising edge {} ms after frame 0 starts", c.delay_ms);
    let list = |xs: &[f64]| {
        range_text(xs, 1.0, " Hz").unwrap_or_else(|| {
            xs.iter()
                .map(|f| format!("{f} Hz"))
                .collect::<Vec<_>>()
                .join(", ")
        })
    };
    if c.offset_ppm == 0.0 {
        let locked = if c.multiples_hz.is_empty() {
            String::new()
        } else {
            format!(
                "; {} {} whole multiples of {fps} fps, so phase locked: every frame sees the same PWM phase",
                list(&c.multiples_hz),
                if c.multiples_hz.len() == 1 {
                    "is a"
                } else {
                    "are"
                }
            )
        };
        return format!("locked to the camera clock (offset 0 ppm), {edge}{locked}");
    }
    let drifts: Vec<String> = c
        .multiples_hz
        .iter()
        .zip(&c.drift_period_s)
        .map(|(f, p)| match p {
            Some(p) => format!("{f} Hz once every {} s", fixed(*p, 1)),
            None => format!("{f} Hz more slowly than any stated time"),
        })
        .collect();
    let drift = if drifts.is_empty() {
        String::new()
    } else {
        format!(
            "; not phase locked at the multiples of {fps} fps: the PWM phase drifts once round at {}",
            drifts.join(", ")
        )
    };
    format!(
        "offset {} ppm from the camera clock (the LED runs at f (1 + {} x 1e-6)), {edge}{drift}",
        c.offset_ppm, c.offset_ppm
    )
}

/// `x` with at most 3 decimals, trailing zeros dropped: 0.05 x 100 prints
/// as 5, not 5.000000000000001.
fn short(x: f64) -> String {
    let s = fixed(x, 3);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn list_text(xs: &[f64], scale: f64, unit: &str) -> String {
    if let Some(range) = range_text(xs, scale, unit) {
        return range;
    }
    xs.iter()
        .map(|x| short(x * scale))
        .collect::<Vec<_>>()
        .join(", ")
        + unit
}

/// Most values a condition lists one by one; a longer list in equal steps
/// (a sweep's grid) is stated as its range and step.
const LISTED_VALUES_MAX: usize = 20;

/// `50 to 2045 Hz in steps of 5 Hz (400 values)` for more than
/// [`LISTED_VALUES_MAX`] values in equal steps (within 1e-9 of the step),
/// else `None`.
fn range_text(xs: &[f64], scale: f64, unit: &str) -> Option<String> {
    if xs.len() <= LISTED_VALUES_MAX {
        return None;
    }
    let step = xs[1] - xs[0];
    let even = step > 0.0
        && xs
            .windows(2)
            .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step.abs().max(1.0));
    even.then(|| {
        format!(
            "{} to {}{unit} in steps of {}{unit} ({} values)",
            short(xs[0] * scale),
            short(xs[xs.len() - 1] * scale),
            short(step * scale),
            xs.len()
        )
    })
}

/// The conditions of `model`'s run of `plan` (captures' summaries already
/// attached to the cases).
pub fn conditions(model: &Results, plan: &Plan) -> Conditions {
    let backend = model.method.backend;
    let simulated = backend == BackendName::Simulator;
    let total = model.cases.len();
    let (seen, per) = Seen::gather(model, plan, simulated);
    let cam = &plan.dut.camera;
    let (frame_rate_fps, frame_rate_unknown_cases) = if simulated {
        (
            Some(Span {
                min: cam.fps,
                max: cam.fps,
            }),
            0,
        )
    } else {
        let rates = &seen.rates;
        (Span::of(rates.iter().copied()), total - rates.len())
    };
    let (exposure_ms, auto_exposure) = if simulated {
        match &cam.physical {
            Some(p) => (
                p.captures
                    .iter()
                    .map(|c| c.exposure_s(cam.exposure_s) * 1e3)
                    .collect(),
                p.auto_exposure.is_some(),
            ),
            None => (vec![cam.exposure_s * 1e3], false),
        }
    } else {
        (Vec::new(), false)
    };
    let exposure_captures = match &cam.physical {
        Some(p) if simulated && p.captures.len() > 1 => {
            p.captures.iter().map(|c| c.name.clone()).collect()
        }
        _ => Vec::new(),
    };
    let light_unknown_cases = seen.light_lux.iter().filter(|&&lux| lux <= 0.0).count();
    let light_lux = distinct(seen.light_lux.into_iter());
    let frequencies_hz = distinct(seen.frequencies_hz.into_iter());
    let duty_cycles = distinct(seen.duty_cycles.into_iter());
    let pwm_clock = simulated.then(|| pwm_clock(plan, &frequencies_hz));
    let scene = simulated.then(|| SceneSetup {
        led_luminance_cd_m2: plan.scene.led_luminance_cd_m2,
        led_fill: plan.scene.led_fill,
        background_reflectance: plan.scene.background_reflectance,
        background_luminance_cd_m2: light_lux
            .iter()
            .map(|&lux| (lux, plan.scene.background_luminance_cd_m2(lux)))
            .collect(),
    });
    let rois = plan
        .rois
        .iter()
        .map(|r| RoiSetup {
            name: r.name.clone(),
            kind: r.kind,
            x_px: r.x_px,
            y_px: r.y_px,
            width_px: r.width_px,
            height_px: r.height_px,
            applies_to: match backend {
                BackendName::Captured => "every capture".to_string(),
                BackendName::Command => "every rig run".to_string(),
                BackendName::Simulator => "every simulated case".to_string(),
            },
        })
        .collect();
    let mut c = Conditions {
        sequence: segments(per),
        segments_given: seen.segments_given,
        segments_detected: seen.segments_detected,
        frame_rate_fps,
        frame_rate_unknown_cases,
        exposure_ms,
        exposure_captures,
        auto_exposure,
        light_lux,
        light_unknown_cases,
        frequencies_hz,
        duty_cycles,
        pwm_clock,
        unapplied_ppm: if simulated {
            0.0
        } else {
            plan.scene.pwm_clock_offset_ppm
        },
        scene,
        rois,
        stated: Vec::new(),
        setup: Vec::new(),
    };
    c.stated = summary_sentences(&c, total, backend, cam.fps);
    c.setup = setup_sentences(&c, backend);
    c
}

/// The executive summary's conditions, each from `c`.
fn summary_sentences(c: &Conditions, total: usize, backend: BackendName, fps: f64) -> Vec<Stated> {
    let methods = SegmentMethods {
        plan: c.segments_given > 0,
        detected: c.segments_detected > 0,
    };
    let mut out = vec![stated(
        "Sequence",
        sequence_text(&c.sequence, methods, total, backend),
    )];
    let unknown = |n: usize, what: &str| {
        if n == 0 {
            String::new()
        } else {
            format!("; {what} in {n} of {total} cases")
        }
    };
    let rate = match (&c.frame_rate_fps, backend) {
        (Some(r), BackendName::Simulator) => format!("{} (the simulated camera)", r.text(3, "fps")),
        (Some(r), _) => format!(
            "{}, fitted to each case's frame times{}",
            r.text(3, "fps"),
            unknown(c.frame_rate_unknown_cases, "unknown")
        ),
        (None, _) => "unknown: no case has frame times to fit".to_string(),
    };
    out.push(stated("Frame rate", rate));
    let exposure = match c.exposure_ms.as_slice() {
        [] if backend == BackendName::Command => {
            "set by the rig, not known to ledflicker".to_string()
        }
        [] => "not known to ledflicker: the captures do not record it".to_string(),
        xs => {
            let each = xs
                .iter()
                .enumerate()
                .map(|(i, x)| match c.exposure_captures.get(i) {
                    Some(name) => format!("{name} {} ms", fixed(*x, 3)),
                    None => format!("{} ms", fixed(*x, 3)),
                })
                .collect::<Vec<_>>()
                .join(", ");
            let captures = if xs.len() > 1 {
                " (one per capture of a frame)"
            } else {
                ""
            };
            if c.auto_exposure {
                format!("auto exposure starting at {each}{captures}")
            } else {
                format!("fixed, {each}{captures}")
            }
        }
    };
    out.push(stated("Exposure", exposure));
    let light = if c.light_lux.is_empty() {
        "not stated (captures without conditions)".to_string()
    } else {
        list_text(&c.light_lux, 1.0, " lux") + &unknown(c.light_unknown_cases, "not stated")
    };
    out.push(stated("Light levels", light));
    let pwm = if c.frequencies_hz.is_empty() {
        "not stated (captures without conditions)".to_string()
    } else {
        format!(
            "{}; duty {}",
            list_text(&c.frequencies_hz, 1.0, " Hz"),
            list_text(&c.duty_cycles, 100.0, " %")
        )
    };
    out.push(stated("PWM", pwm));
    if let Some(clock) = &c.pwm_clock {
        out.push(stated("PWM clock", pwm_clock_text(clock, fps)));
    } else if c.unapplied_ppm != 0.0 {
        out.push(stated(
            "PWM clock",
            format!(
                "the lamp's own, unknown to ledflicker: the plan's pwm-clock-offset-ppm = {} is a simulator setting and was not applied",
                c.unapplied_ppm
            ),
        ));
    }
    out
}

/// The method's set-up: what another lab needs to repeat the test.
fn setup_sentences(c: &Conditions, backend: BackendName) -> Vec<Stated> {
    let mut out = Vec::new();
    match &c.scene {
        Some(s) => {
            out.push(stated(
                "LED",
                format!(
                    "luminance {} cd/m² while ON, covering {} % of each LED ROI",
                    s.led_luminance_cd_m2,
                    short(s.led_fill * 100.0)
                ),
            ));
            let lum: Vec<String> = s
                .background_luminance_cd_m2
                .iter()
                .map(|(lux, l)| format!("{} cd/m² at {lux} lux", fixed(*l, 2)))
                .collect();
            out.push(stated(
                "Background",
                format!(
                    "grey, reflectance {} % (Lambertian: luminance = reflectance x illuminance / pi), {}",
                    short(s.background_reflectance * 100.0),
                    lum.join(", ")
                ),
            ));
        }
        None => {
            let what = if backend == BackendName::Command {
                "the rig"
            } else {
                "the captures"
            };
            out.push(stated(
                "Scene",
                format!("set up by {what}: the plan states no LED luminance or background, so the lab's own record of them belongs with this report"),
            ));
        }
    }
    out.push(stated(
        "ROIs",
        format!(
            "{} {}, placed as in the ROI table (pixels, 0-based from the frame's top-left corner)",
            c.rois.len(),
            if c.rois.len() == 1 { "ROI" } else { "ROIs" }
        ),
    ));
    out
}

/// The segments as used, in words (`0.5 s ON, 0.5 s OFF, 4 s PWM`), when
/// they depart from Deegan 2018's 2 s ON, 2 s OFF and 60 s PWM by more
/// than one frame (or a segment is missing); `None` when they match it.
pub fn sequence_deviation(c: &Conditions) -> Option<String> {
    let frame_s = c.frame_rate_fps.map_or(0.0, |r| 1.0 / r.min);
    let paper = [
        (Segment::On, 2.0),
        (Segment::Off, 2.0),
        (Segment::Pwm, 60.0),
    ];
    let mut differs = false;
    let parts: Vec<String> = paper
        .iter()
        .map(|&(seg, want)| {
            let name = match seg {
                Segment::On => "ON",
                Segment::Off => "OFF",
                Segment::Pwm => "PWM",
            };
            match c.sequence.iter().find(|s| s.segment == seg) {
                Some(s) => {
                    let d = s.duration_s;
                    differs |= (d.min - want).abs() > frame_s + 1e-9
                        || (d.max - want).abs() > frame_s + 1e-9;
                    let (a, b) = (short(d.min), short(d.max));
                    if a == b {
                        format!("{a} s {name}")
                    } else {
                        format!("{a}-{b} s {name}")
                    }
                }
                None => {
                    differs = true;
                    format!("no {name}")
                }
            }
        })
        .collect();
    differs.then(|| parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_list_in_equal_steps_is_stated_as_its_range() {
        let sweep: Vec<f64> = (0..400).map(|i| 50.0 + 5.0 * f64::from(i)).collect();
        assert_eq!(
            list_text(&sweep, 1.0, " Hz"),
            "50 to 2045 Hz in steps of 5 Hz (400 values)"
        );
        // Duty as computed, 0.05 steps that are not exact in binary.
        let duty: Vec<f64> = (1..=21).map(|i| f64::from(i) * 0.05).collect();
        assert_eq!(
            list_text(&duty, 100.0, " %"),
            "5 to 105 % in steps of 5 % (21 values)"
        );
        // Short lists and uneven ones are listed value by value.
        assert_eq!(list_text(&sweep[..3], 1.0, " Hz"), "50, 55, 60 Hz");
        let mut uneven = sweep.clone();
        uneven[200] += 1.0;
        assert!(list_text(&uneven, 1.0, " Hz").starts_with("50, 55, 60, "));
    }
}
