//! What was really done, in words ([`Method`], each case's acquisition,
//! the report's notes), from the plan and the assembled model.

use crate::model::method::Method;
use crate::model::{BackendName, CaseInfo, Results, RoiKind, Verdict};
use crate::plan::SegmentFrames;
use crate::plan::{BackendKind, Limits, Plan, ShutterKind, Thresholds, VerdictBasis};

/// Limits in words, e.g. `FDI (2018) >= 0.1; FMI <= 0.1`.
pub fn limits_text(l: &Limits) -> String {
    let parts: Vec<String> = [
        ("FDI (2018) >=", l.fdi_2018_min, ""),
        ("Percent Flicker <=", l.percent_flicker_max, " %"),
        ("FMI <=", l.fmi_max, ""),
        ("FDI (P2020) >=", l.fdi_p2020_min, ""),
        ("MMP >=", l.mmp_min, ""),
        ("visibility on the monitor <=", l.visibility_max, ""),
        ("Δu′v′ <=", l.delta_uv_max, ""),
    ]
    .into_iter()
    .filter_map(|(name, v, unit)| v.map(|v| format!("{name} {v}{unit}")))
    .collect();
    if parts.is_empty() {
        "none".to_string()
    } else {
        parts.join("; ")
    }
}

fn limits_lines(t: &Thresholds) -> Vec<String> {
    let mut out = vec![limits_text(&t.global())];
    for l in &t.light_levels {
        out.push(format!(
            "at {} lux: {}",
            l.light_lux,
            limits_text(&l.limits.over(t.global()))
        ));
    }
    out
}

fn kind_name(kind: BackendKind) -> BackendName {
    match kind {
        BackendKind::Simulator => BackendName::Simulator,
        BackendKind::Captured => BackendName::Captured,
        BackendKind::Command => BackendName::Command,
    }
}

/// The simulated camera in a few words.
fn camera_words(plan: &Plan) -> String {
    let cam = &plan.dut.camera;
    let shutter = match cam.shutter {
        ShutterKind::Global => "global shutter".to_string(),
        ShutterKind::Rolling => format!("rolling shutter, {} us per line", cam.line_time_s * 1e6),
    };
    match &cam.physical {
        None => format!(
            "the ideal camera simulator (linear, noiseless, fixed exposure {} ms, {shutter}, {} fps)",
            cam.exposure_s * 1e3,
            cam.fps
        ),
        Some(p) => {
            let ae = match &p.auto_exposure {
                Some(_) => format!("auto exposure starting at {} ms", cam.exposure_s * 1e3),
                None => format!("fixed exposure {} ms", cam.exposure_s * 1e3),
            };
            format!(
                "the physical camera simulator, camera `{}` ({} capture(s), photo-electrons with shot and read noise, ADC, HDR merge, tone curve, {ae}; {shutter}, {} fps)",
                cam.name,
                p.captures.len(),
                cam.fps
            )
        }
    }
}

/// The method of the whole run.
pub fn method(plan: &Plan) -> Method {
    let basis = crate::metrics::verdict::effective_basis(plan.dut.backend, &plan.thresholds);
    let s = &plan.sequence;
    let acquisition = match plan.dut.backend {
        BackendKind::Simulator => format!(
            "Frames come from {}, not from a device: for each case it simulates {} s of steady light at the PWM average, {} s with the LED off, then {} s of PWM (Deegan 2018, section 3), integrating the PWM square wave exactly over each ROI row's exposure.",
            camera_words(plan),
            s.on_s,
            s.off_s,
            s.pwm_s
        ),
        BackendKind::Captured => "Frames are read from the capture files named per case (no simulation). Each case's text gives the file, how it was decoded, the segments (given in the plan or detected from the luma) and the frames used and left out.".to_string(),
        BackendKind::Command => {
            let argv = plan
                .capture
                .as_ref()
                .and_then(|c| c.command.as_ref())
                .map(|c| c.argv.join(" "))
                .unwrap_or_default();
            format!(
                "Frames come from the lab rig: for each case ledflicker runs `{argv}` with the case's light level, PWM frequency and duty cycle, then reads the frames it leaves. Each case's text gives the segments and the frames used."
            )
        }
    };
    let verdict_basis = match basis {
        VerdictBasis::WorstPhase => worst_phase_basis(plan),
        VerdictBasis::AsCaptured if plan.dut.backend == BackendKind::Simulator => "Verdicts use the trace as simulated, at the plan's PWM phase (basis = \"as-captured\"); the worst case over phase is reported but not judged.".to_string(),
        VerdictBasis::AsCaptured => "Verdicts use the trace as captured: a recording shows only the PWM phases it caught, so there is no worst case over phase.".to_string(),
    };
    Method {
        backend: kind_name(plan.dut.backend),
        acquisition,
        verdict_basis,
        limits: limits_lines(&plan.thresholds),
    }
}

/// The basis sentence of a simulated run judged on the worst case over
/// phase: it names only the metrics that some limit of the plan judges, so
/// that a plan judged on visibility does not read as judged on Percent
/// Flicker.
fn worst_phase_basis(plan: &Plan) -> String {
    let t = &plan.thresholds;
    let every = std::iter::once(t.global())
        .chain(t.light_levels.iter().map(|l| l.limits.over(t.global())))
        .collect::<Vec<Limits>>();
    let limited = |f: fn(&Limits) -> bool| every.iter().any(f);
    // Both FDIs compare with the OFF segment: without one they are not
    // checked, whatever their limits.
    let off = plan.sequence.off_s > 0.0;
    let named = |list: &[(bool, &'static str)]| -> Vec<&'static str> {
        list.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect()
    };
    let phase = named(&[
        (off && limited(|l| l.fdi_2018_min.is_some()), "FDI (2018)"),
        (
            limited(|l| l.percent_flicker_max.is_some()),
            "Percent Flicker",
        ),
    ]);
    let how = physical_worst_case_words(plan);
    let mut out = if phase.is_empty() {
        format!(
            "The worst case over PWM phase of FDI (2018) and Percent Flicker is computed by the simulator{how} and reported, not judged"
        )
    } else {
        format!(
            "Verdicts on {} use the worst case over PWM phase, computed by the simulator{how}",
            phase.join(" and ")
        )
    };
    let p2020 = named(&[
        (limited(|l| l.fmi_max.is_some()), "FMI"),
        (off && limited(|l| l.fdi_p2020_min.is_some()), "FDI"),
        (limited(|l| l.mmp_min.is_some()), "MMP"),
    ]);
    out += "; the IEEE P2020 KPIs (FMI, FDI, MMP) count frames and are ";
    out += &match p2020.as_slice() {
        [] => "reported on the trace as simulated".to_string(),
        [_, _, _] => "judged on the trace as simulated".to_string(),
        some => format!(
            "reported on the trace as simulated, {} judged",
            some.join(" and ")
        ),
    };
    if limited(|l| l.visibility_max.is_some()) {
        out += "; the visibility index is judged on the monitor's luminance of the trace as simulated, at the plan's PWM phase";
    }
    out + "."
}

/// How a physical camera's worst case over phase is found
/// (docs/camera-model.md, "Worst case over phase"); empty for the ideal
/// camera, whose worst case is exact from its corners.
fn physical_worst_case_words(plan: &Plan) -> &'static str {
    use crate::physics::hdr::{MergeRule, ToneCurve};
    let Some(p) = &plan.dut.camera.physical else {
        return "";
    };
    let concave = !matches!(p.tone.curve, ToneCurve::Gamma(g) if g < 1.0);
    match p.merge {
        MergeRule::LongestUnsaturated if concave => {
            " (auto exposure held at its final setting, noise off; searched between the phases where a capture edge meets a PWM edge or a capture starts or stops saturating, exact to 1e-10 of a PWM cycle for this merge and tone curve)"
        }
        _ => {
            " (auto exposure held at its final setting, noise off; searched between the phases where a capture edge meets a PWM edge or a capture crosses saturation or its merge weight's knee, plus 1 024 even phases, with a golden-section search where an interval's end slopes show an interior extreme: for this merge and tone curve that search is not proven exact, and is checked against a 16 384-phase brute force on the shipped profiles)"
        }
    }
}

/// What was done for one case: the simulated sequence, or the capture
/// file, its segments and the frames used and left out.
pub fn case_acquisition(plan: &Plan, case: &CaseInfo) -> String {
    if let Some(cap) = &case.capture {
        let seg = &cap.segments;
        let len = |s: Option<(u64, u64)>| s.map_or(0, |(a, b)| b.saturating_sub(a));
        let used = len(seg.off) + len(seg.on) + len(Some(seg.pwm));
        let origin = if plan.dut.backend == BackendKind::Command {
            "Rig output".to_string()
        } else {
            format!("Capture `{}`", cap.source)
        };
        // The segment sentence comes from the capture stage: how
        // they were found, their frames, seconds and levels, and the settle time.
        let time_base = cap
            .time_base_s
            .map_or(String::new(), |tb| format!(", time base {tb} s"));
        let stated = cap
            .stated_frame_rate_fps
            .map_or(String::new(), |r| format!(", stated rate {r} fps"));
        return format!(
            "{origin} ({}; frame times from {}{time_base}{stated}); segments {}; {used} of {} frames used, {} left out (outside every segment or settling).",
            cap.format,
            cap.timestamps,
            seg.text,
            seg.capture_frames,
            seg.capture_frames.saturating_sub(used)
        );
    }
    match plan.dut.backend {
        BackendKind::Simulator => {
            let n = SegmentFrames::new(&plan.sequence, plan.dut.camera.fps);
            format!(
                "Simulated with {}: {} frames steady ON, {} OFF, {} PWM; every frame used.",
                camera_words(plan),
                n.on,
                n.off,
                n.pwm
            )
        }
        _ => format!("{} frames acquired.", case.frames),
    }
}

/// Fills `method` and the conditions (each case's `acquisition` is
/// filled as the case is analysed).
pub fn describe(model: &mut Results, plan: &Plan) {
    model.method = method(plan);
    model.conditions = super::conditions::conditions(model, plan);
}

/// Deviations from the method of Deegan 2018 (IS&T EI AVM-146) and notes a
/// reader of the report must see, one sentence each: the sequence and light
/// levels when they differ from the paper's, the simulated camera, saturated
/// ROIs, undefined metrics, cases not judged, and the plan's description.
/// `model` is the assembled model of `plan`'s run.
pub fn notes(model: &Results, plan: &Plan) -> Vec<String> {
    let mut out = Vec::new();
    // Deegan 2018, section 3: 2 s ON, 2 s OFF, 60 s PWM, at 40 and 2000 lux.
    if let Some(used) = super::conditions::sequence_deviation(&model.conditions) {
        out.push(format!(
            "Sequence: {used}; Deegan 2018 uses 2 s, 2 s and 60 s."
        ));
    }
    let odd: Vec<String> = model
        .light_levels()
        .into_iter()
        .filter(|lux| *lux != 40.0 && *lux != 2000.0)
        .map(|lux| format!("{lux} lux"))
        .collect();
    if !odd.is_empty() {
        out.push(format!(
            "Light levels {} differ from the 40 lux and 2000 lux of Deegan 2018.",
            odd.join(", ")
        ));
    }
    if model.method.backend == BackendName::Simulator {
        let which = if plan.dut.camera.physical.is_some() {
            "physical"
        } else {
            "ideal"
        };
        out.push(format!(
            "Frames come from the {which} camera simulator, not from a captured device; \
             the DUT fields name the camera being modelled."
        ));
    }
    // Saturated ROIs and undefined metrics in one pass over the cases.
    let (mut saturated, mut saturated_example) = (0, None);
    let mut undefined = 0;
    let mut example = None;
    for c in &model.cases {
        if c.rois.iter().any(|r| r.saturated) {
            saturated += 1;
            saturated_example.get_or_insert_with(|| c.id.clone());
        }
        // A background ROI is flat by design: its undefined spectrum and
        // contrast are expected, not a caveat on the result.
        for r in c.rois.iter().filter(|r| r.kind == RoiKind::Led) {
            for (metric, reason) in &r.reasons {
                undefined += 1;
                example.get_or_insert_with(|| {
                    format!(
                        "{} / {} / {}: {reason}",
                        c.id,
                        r.name,
                        crate::metrics::human_name(metric)
                    )
                });
            }
        }
    }
    if let Some(example) = saturated_example {
        out.push(format!(
            "{saturated} case(s) have a saturated ROI (e.g. {example}: its luma or a colour plane reached the saturation level): the metrics of what clipped understate the modulation."
        ));
    }
    if let Some(example) = example {
        out.push(format!(
            "{undefined} metric value(s) of LED ROIs are undefined or carry a caveat, e.g. {example}."
        ));
    }
    if model.counts.info > 0 {
        out.push(format!(
            "{} case(s) were not judged (outside the claimed mitigation range, marked informative, or no limit applies): measured and reported, never failing.",
            model.counts.info
        ));
    }
    if model.verdict == Verdict::Info {
        out.push("No case was judged: the run shows no pass.".to_string());
    }
    if !model.plan.description.trim().is_empty() {
        out.push(format!(
            "Plan description: {}",
            model.plan.description.trim()
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_name_the_simulated_camera_only_for_the_simulator_backend() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .join("tests/fixtures/plans/base.toml");
        let plan = crate::plan::load(&path).unwrap();
        let cases = crate::plan::expand_cases(&plan);
        let backend = crate::backend::sim::Simulator::new(&plan);
        let results = crate::runner::run(&plan, &cases, &backend, Some(2), &|_| {}).unwrap();
        let mut model = crate::model::assemble(&plan, "sim-ideal", &results);
        assert_eq!(model.notes, notes(&model, &plan));
        // The fixture's sequence (0.5 s, 0.5 s, 4 s) is not the paper's.
        assert!(
            model.notes[0].starts_with("Sequence: 0.5 s ON"),
            "{:?}",
            model.notes
        );
        let simulated = |n: &[String]| n.iter().any(|n| n.contains("camera simulator"));
        assert!(
            model
                .notes
                .iter()
                .any(|n| n.contains("the ideal camera simulator, not from a captured device")),
            "{:?}",
            model.notes
        );
        model.method.backend = BackendName::Captured;
        assert!(!simulated(&notes(&model, &plan)));
    }
}
