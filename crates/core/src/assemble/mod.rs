//! The analysis stage: from the run's case results to the results model.
//! Apparent frequency, hazard class, banding, phase folds, fine maps,
//! advice and the sample frames' row analysis run here, once, in parallel
//! per case; the report only reads what this stage wrote.

use std::collections::BTreeMap;

pub mod conditions;
pub mod frame;
pub mod method;

use crate::analysis;
use crate::metrics::verdict::{effective_basis, in_mitigation_range, overall};
use crate::model::*;
use crate::plan::{BackendKind, Plan, Sequence, ShutterKind};
use crate::runner::{CaseReadError, CaseSource};

/// Grid of the report's advice: coarser than `ledflicker advise`'s default
/// so that a report stays quick to build.
const ADVICE_STEP_HZ: f64 = 5.0;
const ADVICE_STEP_DUTY: f64 = 0.01;
/// Most frequency steps of the report's advice grid: a wider range than
/// 10 kHz takes coarser steps, so that its memory and time stay those of
/// a 10 kHz range.
const ADVICE_FREQUENCY_STEPS_MAX: f64 = 2000.0;

fn plan_advice(plan: &Plan) -> Option<PlanAdvice> {
    let fold = |xs: &[f64]| {
        xs.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let (f0, f1) = fold(&plan.frequencies_hz);
    let f0 = f0.max(plan.thresholds.mitigation_min_hz);
    let f1 = plan.thresholds.mitigation_max_hz.map_or(f1, |m| f1.min(m));
    let duty = fold(&plan.duty_cycles);
    let req = crate::advise::AdviseRequest {
        frequency_hz: (f0, f1),
        duty,
        frequency_step_hz: ADVICE_STEP_HZ.max((f1 - f0) / ADVICE_FREQUENCY_STEPS_MAX),
        duty_step: ADVICE_STEP_DUTY,
        speed_px_per_s: None,
        hdr_ratios: Vec::new(),
        frame: Some(frame_bound(plan)),
    };
    let advice = crate::advise::advise(&req).ok()?;
    let curve = crate::advise::curve(&req, 33).ok()?;
    Some(PlanAdvice {
        frequency_hz: (f0, f1),
        duty,
        advice,
        curve,
    })
}

/// What bounds the plan camera's (long) exposure: its frame time, less its
/// other captures when they run one after the other.
fn frame_bound(plan: &Plan) -> crate::advise::FrameBound {
    let cam = &plan.dut.camera;
    match &cam.physical {
        Some(p) => crate::advise::FrameBound::of_captures(cam.fps, &p.captures, p.hdr_mode),
        None => crate::advise::FrameBound::frame_time(cam.fps),
    }
}

fn insert(roi: &mut RoiInfo, name: &str, m: &Metric) {
    roi.metrics.insert(name.to_string(), m.value);
    if let Some(r) = &m.reason {
        roi.reasons.insert(name.to_string(), r.clone());
    }
    roi.contrast_unbounded |= m.unbounded;
}

/// The visibility figures of an ROI, under the names of results.json.
fn insert_visibility(roi: &mut RoiInfo, v: &crate::metrics::visibility::Visibility) {
    insert(roi, "visibility", &v.metric());
    let figures = [
        ("visibility_peak_hz", v.peak_frequency_hz),
        ("display_luminance_cd_m2", Some(v.mean_luminance_cd_m2)),
        ("visual_radius_deg", Some(v.radius_deg)),
    ];
    for (name, value) in figures {
        roi.metrics.insert(name.to_string(), value);
    }
}

/// The colour figures of an LED ROI, under the names of results.json.
fn insert_colour(roi: &mut RoiInfo, c: &crate::metrics::chromaticity::ColourFigures) {
    use crate::metrics::chromaticity::PLANE_SUFFIXES;
    insert(roi, "delta_uv", &c.delta_uv_metric());
    if let Some(n) = c.frames_outside {
        roi.metrics
            .insert("frames_outside_signal_colour".to_string(), Some(n as f64));
    }
    for (p, suffix) in c.planes.iter().zip(PLANE_SUFFIXES) {
        insert(roi, &format!("fmi_{suffix}"), &p.fmi);
        insert(roi, &format!("fdi_p2020_{suffix}"), &p.fdi);
        insert(roi, &format!("mmp_{suffix}"), &p.mmp);
    }
}

/// The model of the run's cases, analyses, fine maps and advice. The
/// cases are read from `source` a chunk at a time, each analysed in
/// parallel, so that only the model's own row of each case is kept.
fn build(
    plan: &Plan,
    backend_id: &str,
    source: &dyn CaseSource,
    detail: Detail,
) -> Result<Results, CaseReadError> {
    let mut counts = Counts {
        total: source.len(),
        ..Counts::default()
    };
    // The case analyses, the fine maps and the exposure advice are
    // independent: all in parallel, the cases collected in order.
    let depth = crate::timings::depth();
    let (cases, (fine_maps, advice)) = rayon::join(
        || {
            use rayon::prelude::*;
            let _t = crate::timings::span_at("analyses: cases and sample frames", depth);
            // The report maps the ROIs on a frame of each capture, or on
            // one simulated frame.
            let every_framed = plan.dut.backend == BackendKind::Captured;
            let mut cases =
                CasesBuilder::new(source.len(), detail, every_framed).map_err(spill_error)?;
            // A spilled run's sample frames are described once the cases
            // kept in memory, the only ones written whole, are known.
            let spills = cases.spills();
            let counts = &mut counts;
            crate::runner::for_each_chunk(source, |_, chunk| {
                let infos: Vec<CaseInfo> = chunk
                    .par_iter()
                    .map(|r| analysed_case(plan, r, !spills))
                    .collect();
                for c in &infos {
                    match c.verdict {
                        Verdict::Pass => counts.pass += 1,
                        Verdict::Fail => counts.fail += 1,
                        Verdict::Info => counts.info += 1,
                    }
                }
                cases.extend(infos).map_err(spill_error)
            })?;
            let mut cases = cases.finish().map_err(spill_error)?;
            // Banding KPIs are read only from the cases a report details,
            // which are all among those held in memory.
            let held: Vec<&mut CaseInfo> = cases.resident_mut().collect();
            held.into_par_iter().for_each(|c| {
                c.banding = analysis::case_banding(plan, c.frequency_hz, c.duty);
            });
            if spills {
                describe_held_sample_frames(plan, source, &mut cases)?;
            }
            Ok::<_, CaseReadError>(cases)
        },
        || {
            rayon::join(
                || {
                    let _t = crate::timings::span_at("analyses: fine maps", depth);
                    analysis::fine_maps(plan)
                },
                || {
                    let _t = crate::timings::span_at("analyses: exposure advice", depth);
                    plan_advice(plan)
                },
            )
        },
    );
    let cases = cases?;
    let Sequence { on_s, off_s, pwm_s } = plan.sequence;
    let mut thresholds = plan.thresholds.clone();
    thresholds.basis = effective_basis(plan.dut.backend, &plan.thresholds);
    let model = Results {
        schema: RESULTS_SCHEMA.to_string(),
        tool: Tool {
            name: "ledflicker".to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
        },
        plan: PlanInfo {
            id: plan.id.clone(),
            title: plan.title.clone(),
            path: plan.path.display().to_string(),
            sha256: plan.sha256.clone(),
            standard: plan.standard.clone(),
            description: plan.description.clone(),
            lab: plan.lab.clone(),
            seed: plan.seed,
        },
        dut: dut_info(plan, backend_id),
        sequence: SequenceInfo { on_s, off_s, pwm_s },
        conditions: Default::default(),
        thresholds,
        method: method::method(plan),
        p2020: plan.p2020,
        display: plan.display,
        verdict: overall(counts.verdicts()),
        counts,
        cases,
        fine_maps,
        fine_maps_note: analysis::fine_maps_note(plan),
        advice,
        report: None,
        notes: Vec::new(),
    };
    Ok(model)
}

/// A failure of the spill file of a large run's cases, as a read error of
/// the analysis stage.
fn spill_error(e: std::io::Error) -> CaseReadError {
    format!("the spill file of the run's cases (in the temporary directory): {e}").into()
}

/// The sample frames of a spilled run's cases kept in memory, described
/// whole ([`frame::sample_frame_info`]) from the frames read again from
/// `source`: the cases were analysed with a stand-in
/// ([`frame::sample_frame_pending`]).
fn describe_held_sample_frames(
    plan: &Plan,
    source: &dyn CaseSource,
    cases: &mut Cases,
) -> Result<(), CaseReadError> {
    use rayon::prelude::*;
    let held: Vec<(usize, &mut CaseInfo)> = cases
        .resident_at_mut()
        .filter(|(_, c)| c.sample_frame.is_some())
        .collect();
    held.into_par_iter().try_for_each(|(i, c)| {
        let read = source.read(i..i + 1)?;
        let r = read.first().filter(|r| r.case.id == c.id).ok_or_else(|| {
            format!(
                "case {} ({}) is not at its place when read again",
                i + 1,
                c.id
            )
        })?;
        c.sample_frame = r
            .sample_frame
            .as_ref()
            .map(|f| frame::sample_frame_info(&c.id, f, &plan.rois));
        Ok(())
    })
}

/// One case of the model: its analyses (and its sample frame's, beside
/// them, or a stand-in without `frame_info`), its ROIs, and for a captured
/// or rig case what was read.
fn analysed_case(plan: &Plan, r: &CaseResult, frame_info: bool) -> CaseInfo {
    let frame = || {
        r.sample_frame.as_ref().map(|f| {
            if frame_info {
                frame::sample_frame_info(&r.case.id, f, &plan.rois)
            } else {
                frame::sample_frame_pending(&r.case.id, f)
            }
        })
    };
    let (mut a, sample_frame) = rayon::join(|| analysis::analyse_case_deferred(plan, r), frame);
    let rois = roi_infos(plan, r, std::mem::take(&mut a.rois));
    let mut case = case_info(plan, r, a, sample_frame, rois);
    if let Some(s) = &r.acquisition.capture {
        if plan.dut.backend == BackendKind::Captured {
            case.source = Some(s.source.clone());
        }
        case.capture = Some(Box::new(s.clone()));
    }
    case.acquisition = method::case_acquisition(plan, &case);
    case
}

/// The results model of a finished run, as `plan` writes it and `merge`
/// rebuilds it, and the only way to build one: `build` (the cases), the capture
/// summaries of captured and rig runs (from each case's acquisition), then
/// the method section and the notes.
pub fn assemble(plan: &Plan, backend_id: &str, results: &[CaseResult]) -> Results {
    match assemble_from(plan, backend_id, &results, Detail::Full) {
        Ok(model) => model,
        // A slice reads every range asked of it.
        Err(e) => unreachable!("cases in memory: {e}"),
    }
}

/// [`assemble`] of the cases `source` reads back (the case store of a
/// run), which may fail where a read fails, for a report at `detail`: the
/// chart data of cases that report will not draw is dropped as the cases
/// are analysed ([`super::listing::ChartData`]).
pub fn assemble_from(
    plan: &Plan,
    backend_id: &str,
    source: &dyn CaseSource,
    detail: Detail,
) -> Result<Results, CaseReadError> {
    let mut model = build(plan, backend_id, source, detail)?;
    method::describe(&mut model, plan);
    model.notes = method::notes(&model, plan);
    Ok(model)
}

/// The ROIs of one case: the run's metrics, the analyses and the P2020
/// KPIs, by name.
fn roi_infos(plan: &Plan, r: &CaseResult, analyses: Vec<RoiAnalysis>) -> Vec<RoiInfo> {
    plan.rois
        .iter()
        .zip(&r.metrics)
        .zip(analyses)
        .enumerate()
        .map(|(i, ((roi, m), ra))| {
            let mut info = RoiInfo {
                name: roi.name.clone(),
                kind: roi.kind,
                metrics: BTreeMap::new(),
                reasons: BTreeMap::new(),
                levels: m.levels.clone(),
                saturated: m.saturated,
                contrast_unbounded: false,
                analysis: ra,
                signal_colour: m.colour.as_ref().and_then(|c| c.region.clone()),
                delta_uv_reference: m
                    .colour
                    .as_ref()
                    .filter(|c| c.mean_is_time_average)
                    .map(|_| "time-average".to_string()),
            };
            insert(&mut info, "fdi_2018", &m.fdi_2018);
            insert(&mut info, "percent_flicker", &m.percent_flicker);
            if let Some(x) = &m.fdi_2018_worst_phase {
                insert(&mut info, "fdi_2018_worst_phase", x);
            }
            if let Some(x) = &m.percent_flicker_worst_phase {
                insert(&mut info, "percent_flicker_worst_phase", x);
            }
            let spectrum = Metric {
                value: info.analysis.apparent_frequency_spectrum_hz,
                unbounded: false,
                reason: info.analysis.spectrum_reason.clone(),
            };
            insert(&mut info, "apparent_frequency_spectrum_hz", &spectrum);
            let coverage = info.analysis.phase_coverage.coverage;
            info.metrics
                .insert("phase_coverage".to_string(), Some(coverage));
            if let Some(w) = &info.analysis.phase_coverage.warning {
                info.reasons.insert("phase_coverage".to_string(), w.clone());
            }
            if let Some(v) = &m.visibility {
                insert_visibility(&mut info, v);
            }
            if let Some(c) = &m.colour {
                insert_colour(&mut info, c);
            }
            if let Some(p) = r.p2020.get(i) {
                insert(&mut info, "fmi", &p.fmi);
                insert(&mut info, "fdi_p2020", &p.fdi);
                insert(&mut info, "mmp", &p.mmp);
            }
            info
        })
        .collect()
}

/// One case of results.json from its run result and its analysis.
fn case_info(
    plan: &Plan,
    r: &CaseResult,
    a: analysis::CaseAnalysis,
    sample_frame: Option<SampleFrameInfo>,
    rois: Vec<RoiInfo>,
) -> CaseInfo {
    CaseInfo {
        id: r.case.id.clone(),
        light_lux: r.case.light_lux,
        frequency_hz: r.case.frequency_hz,
        duty: r.case.duty,
        source: None,
        capture: None,
        seed: r.case.seed,
        verdict: r.verdict,
        not_judged: r.not_judged.clone(),
        not_checked: r.not_checked.clone(),
        acquisition: String::new(),
        in_mitigation_range: r.case.frequency_hz > 0.0
            && in_mitigation_range(r.case.frequency_hz, &plan.thresholds),
        frames: r.acquisition.frames.len(),
        trace: trace_path(&r.case.id),
        sample_frame,
        rois,
        checks: r.checks.clone(),
        apparent_frequency_hz: a.beat.apparent_frequency_hz,
        hazard_class: a.hazard_class,
        beat: a.beat,
        drive: a.drive,
        banding: a.banding,
        frame_timing: a.timing.map(Box::new),
        worst_phase: a
            .worst_phase
            .map(|w| Box::new(frame::worst_phase_info(&r.case.id, w, &plan.rois))),
    }
}

/// The device under test; the camera only for the simulator.
fn dut_info(plan: &Plan, backend_id: &str) -> DutInfo {
    let cam = &plan.dut.camera;
    DutInfo {
        backend: backend_id.to_string(),
        supplier: plan.dut.supplier.clone(),
        model: plan.dut.model.clone(),
        serial: plan.dut.serial.clone(),
        firmware: plan.dut.firmware.clone(),
        camera: (plan.dut.backend == BackendKind::Simulator).then_some(CameraInfo {
            shutter: match cam.shutter {
                ShutterKind::Global => ShutterName::Global,
                ShutterKind::Rolling => ShutterName::Rolling,
            },
            sensor_rows: cam.sensor_rows,
            sensor_columns: cam.sensor_columns,
            line_time_us: cam.line_time_s * 1e6,
            exposure_ms: cam.exposure_s * 1e3,
            frame_rate_fps: cam.fps,
            pwm_delay_ms: cam.pwm_delay_s * 1e3,
        }),
    }
}
