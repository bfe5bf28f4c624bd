//! The conditions a report states are those that were run: for every
//! shipped plan, each condition of results.json's `conditions` (the
//! executive summary's sentences and their figures) is recomputed from the
//! per-case data (each case's frames, frame rate, light level and beat)
//! and found in the rendered HTML and PDF summaries.

use std::collections::BTreeMap;
use std::path::Path;

use ledflicker::backend::factory;
use ledflicker::model::{self, Results};
use ledflicker::plan;
use ledflicker::report::document::Document;
use ledflicker::runner;
use ledflicker::util::fixed;

use crate::{ledflicker as run_binary, root, scratch, stderr};

/// One case's frames as (segment, frame number, start time in seconds).
type Frames = Vec<(String, u64, f64)>;

/// Runs `path` in-process on its first and last case (every case counts
/// the same way; two keep the test quick) and returns results.json read
/// back, with each case's frames.
fn run_in_process(path: &Path) -> (Results, BTreeMap<String, Frames>) {
    let p = plan::load(path).unwrap_or_else(|e| panic!("{e}"));
    let all = plan::expand_cases(&p);
    let mut cases = vec![all[0].clone()];
    if all.len() > 1 {
        cases.push(all[all.len() - 1].clone());
    }
    let backend = factory::for_plan(&p, Some(&cases)).unwrap_or_else(|e| panic!("{e}"));
    let results = runner::run(&p, &cases, &backend, Some(2), &|_| {}).unwrap();
    let model = model::assemble(&p, "test", &results);
    let json = serde_json::to_string(&model).unwrap();
    let frames = results
        .iter()
        .map(|r| {
            let f = r
                .acquisition
                .frames
                .iter()
                .map(|f| (f.segment.as_str().to_string(), f.index, f.time_s))
                .collect();
            (r.case.id.clone(), f)
        })
        .collect();
    (model::read_results(&json).unwrap(), frames)
}

/// Runs `path` with the binary (a rig plan runs `ledflicker render`) and
/// returns results.json read back, with each case's frames from its trace.
/// A plan with a light source (`[source]`) runs against the SCPI
/// instrument simulator and the simulated camera.
fn run_cli(path: &Path, name: &str, light_source: bool) -> (Results, BTreeMap<String, Frames>) {
    let dir = scratch(name);
    let out = dir.join("out");
    let args = [
        "plan",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ];
    let o = if light_source {
        crate::lab_bench::SimulatedBench::start(&dir).run(&args, root())
    } else {
        run_binary(&args)
    };
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let text = std::fs::read_to_string(out.join("results.json")).unwrap();
    let results = model::read_results(&text).unwrap();
    let frames = results
        .cases
        .iter()
        .map(|c| {
            let csv = std::fs::read_to_string(out.join(&c.trace)).unwrap();
            let f = csv
                .lines()
                .skip(1)
                .map(|l| {
                    let v: Vec<&str> = l.split(',').collect();
                    (
                        v[2].to_string(),
                        v[0].parse().unwrap(),
                        v[1].parse().unwrap(),
                    )
                })
                .collect();
            (c.id.clone(), f)
        })
        .collect();
    (results, frames)
}

/// Undoes the HTML escapes minijinja writes.
fn unescape(html: &str) -> String {
    html.replace("&#x27;", "'")
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&#x2f;", "/")
        .replace("&amp;", "&")
}

/// Checks every stated condition of `r` against its per-case data.
fn check(plan_name: &str, r: &Results, frames: &BTreeMap<String, Frames>) {
    let c = &r.conditions;
    let ctx = |what: &str| format!("{plan_name}: {what}: {:#?}", c.stated);
    let text = |label: &str| {
        c.stated
            .iter()
            .find(|s| s.label == label)
            .map(|s| s.text.clone())
            .unwrap_or_else(|| panic!("{}", ctx(&format!("no {label} stated"))))
    };
    let fps_of = |case: &model::CaseInfo| {
        case.frame_timing
            .as_ref()
            .map_or(case.beat.frame_rate_fps, |t| t.fps)
    };

    // Sequence: each segment's frames and seconds in each case.
    let sequence = text("Sequence");
    for seg in ["on", "off", "pwm"] {
        let mut spans = Vec::new();
        for case in &r.cases {
            let mine: Vec<&(String, u64, f64)> =
                frames[&case.id].iter().filter(|f| f.0 == seg).collect();
            let (Some(first), Some(last)) = (mine.first(), mine.last()) else {
                continue;
            };
            let period = 1.0 / fps_of(&case);
            spans.push((
                first.1,
                last.1 + 1,
                first.2,
                last.2 + period - first.2,
                period,
            ));
        }
        let stated = c.sequence.iter().find(|s| s.segment.as_str() == seg);
        let Some(stated) = stated else {
            assert!(
                spans.is_empty(),
                "{}",
                ctx(&format!("{seg} ran, not stated"))
            );
            continue;
        };
        assert_eq!(stated.cases, spans.len(), "{}", ctx(seg));
        match stated.frames {
            Some((a, b)) => {
                assert!(spans.iter().all(|s| (s.0, s.1) == (a, b)), "{}", ctx(seg));
                assert!(
                    // First to last frame, as a reader counts them.
                    sequence.contains(&format!("frames {a}-{}", b - 1)),
                    "{}",
                    ctx(seg)
                );
            }
            None => assert!(
                spans
                    .windows(2)
                    .any(|w| (w[0].0, w[0].1) != (w[1].0, w[1].1))
            ),
        }
        let count = |s: &(u64, u64, f64, f64, f64)| (s.1 - s.0) as f64;
        let min = spans.iter().map(count).fold(f64::INFINITY, f64::min);
        let max = spans.iter().map(count).fold(0.0, f64::max);
        assert_eq!(
            (stated.frame_count.min, stated.frame_count.max),
            (min, max),
            "{}",
            ctx(seg)
        );
        // A segment ends where the frame after its last starts: within half
        // a frame of the last frame's start plus one period.
        for (s, d) in spans.iter().map(|s| (s, s.3)) {
            assert!(
                d >= stated.duration_s.min - s.4 / 2.0 && d <= stated.duration_s.max + s.4 / 2.0,
                "{}",
                ctx(&format!("{seg} lasts {d} s"))
            );
            assert!(
                s.2 >= stated.start_s.min - 1e-9 && s.2 <= stated.start_s.max + 1e-9,
                "{}",
                ctx(seg)
            );
        }
        assert!(
            sequence.contains(&fixed(stated.duration_s.max, 3))
                || sequence.contains(&fixed(stated.start_s.min + stated.duration_s.max, 3)),
            "{}",
            ctx(seg)
        );
    }

    // Frame rate: the cases' own.
    let rates: Vec<f64> = r.cases.iter().map(|c| fps_of(&c)).collect();
    let rate = c.frame_rate_fps.expect("a frame rate");
    let lo = rates.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = rates.iter().copied().fold(0.0, f64::max);
    assert!(
        (rate.min - lo).abs() < 1e-9 && (rate.max - hi).abs() < 1e-9,
        "{}",
        ctx("fps")
    );
    if let Some(cam) = &r.dut.camera {
        assert_eq!(rate.min, cam.frame_rate_fps);
    }
    assert!(
        text("Frame rate").contains(&fixed(rate.min, 3)),
        "{}",
        ctx("fps")
    );

    // Light levels: the cases'.
    let mut lux: Vec<f64> = r
        .cases
        .iter()
        .map(|c| c.light_lux)
        .filter(|l| *l > 0.0)
        .collect();
    lux.sort_by(f64::total_cmp);
    lux.dedup();
    assert_eq!(c.light_lux, lux, "{}", ctx("light"));
    let light = text("Light levels");
    for l in &lux {
        assert!(light.contains(&format!("{l}")), "{}", ctx("light"));
    }
    if lux.is_empty() {
        assert!(light.contains("not stated"), "{}", ctx("light"));
    }

    // Exposure: the simulated camera's, or none claimed.
    let exposure = text("Exposure");
    match &r.dut.camera {
        Some(cam) => assert!(
            exposure.contains(&fixed(cam.exposure_ms, 3)),
            "{}",
            ctx("exp")
        ),
        None => assert!(exposure.contains("not known"), "{}", ctx("exp")),
    }

    // PWM clock: offset, delay, and each case's beat at a multiple of the
    // frame rate: locked at 0 ppm, else one drift period of 1 / (f ppm 1e-6).
    if let Some(clock) = &c.pwm_clock {
        let cam = r.dut.camera.as_ref().unwrap();
        assert_eq!(clock.delay_ms, cam.pwm_delay_ms);
        let said = text("PWM clock");
        assert!(
            said.contains(&format!("offset {} ppm", clock.offset_ppm)),
            "{}",
            ctx("ppm")
        );
        for case in &r.cases {
            let k = case.frequency_hz / cam.frame_rate_fps;
            let multiple = (k - k.round()).abs() < 1e-9;
            assert_eq!(multiple, clock.multiples_hz.contains(&case.frequency_hz));
            if !multiple {
                continue;
            }
            if clock.offset_ppm == 0.0 {
                assert_eq!(case.apparent_frequency_hz, 0.0);
                assert!(said.contains("phase locked"), "{}", ctx("ppm"));
            } else {
                let i = clock
                    .multiples_hz
                    .iter()
                    .position(|f| *f == case.frequency_hz);
                let p = clock.drift_period_s[i.unwrap()].expect("a finite drift period");
                let beat = case.beat.period_s.expect("a drift, not a lock");
                assert!((p - beat).abs() <= 1e-6 * beat, "{}", ctx("drift"));
                assert!(said.contains(&fixed(p, 1)) && !said.contains("so phase locked"));
                assert!(
                    !case.beat.note.starts_with("phase locked"),
                    "{}",
                    case.beat.note
                );
            }
        }
    } else {
        assert!(
            r.dut.camera.is_none(),
            "{}",
            ctx("a simulator states its PWM clock")
        );
    }

    // Both reports state every condition, and no other "Sequence".
    // Rendered without pictures: the fine maps' charts are not drawn, so
    // their section is left out.
    let mut bare = r.clone();
    bare.fine_maps.clear();
    let doc = Document::with_pictures(
        bare,
        "2026-01-01",
        Vec::new(),
        BTreeMap::new(),
        BTreeMap::new(),
    );
    let html = unescape(&ledflicker::report::html::render_document(&doc).unwrap());
    // The Typst markup of report.pdf; a build without PDFs has none.
    #[cfg(feature = "pdf")]
    let typ = ledflicker::report::pdf::render_markup(&doc).unwrap();
    #[cfg(not(feature = "pdf"))]
    let typ = String::new();
    let pdf = ledflicker::report::WRITES_PDF;
    for s in c.stated.iter().chain(&c.setup) {
        assert!(html.contains(&s.text), "{plan_name}: HTML lacks {s:?}");
        assert!(
            !pdf || typ.contains(&format!("{:?}", s.text)),
            "{plan_name}: PDF lacks {s:?}"
        );
    }
    // Each failing case's limits table lists its failing ROIs, worst first.
    for case in r.cases.iter().filter(|c| c.verdict == model::Verdict::Fail) {
        let t = case.limit_table();
        assert!(
            !t.rows.is_empty(),
            "{plan_name}: {} fails on no ROI",
            case.id
        );
        let start = html
            .find(&format!("<h4><a href=\"#{}\">", case.id))
            .unwrap();
        let mut at = start;
        for row in &t.rows {
            let cell = format!("<tr><td>{}</td>", row.roi);
            at += html[at..]
                .find(&cell)
                .unwrap_or_else(|| panic!("{plan_name}: no {cell}"));
        }
        assert!(
            !pdf || typ.contains(&format!("[#{:?}],", t.rows[0].roi)),
            "{plan_name}: PDF table"
        );
    }
    for roi in &c.rois {
        let row = format!(
            "<td>{}</td><td>{}</td><td class=\"num\">{}</td>",
            roi.name,
            serde_json::to_value(roi.kind).unwrap().as_str().unwrap(),
            roi.x_px
        );
        assert!(
            html.contains(&row),
            "{plan_name}: HTML ROI table lacks {row}"
        );
    }
}

#[test]
fn every_shipped_plan_states_the_conditions_it_ran() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them (apt-get install ffmpeg)"
    );
    let mut n = 0;
    let mut dir: Vec<_> = std::fs::read_dir(root().join("test-plans"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    dir.sort();
    for path in dir {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let (r, frames) = if text.contains("backend = \"command\"") {
            let light_source = text.contains("\n[source]\n");
            run_cli(&path, &format!("conditions-{name}"), light_source)
        } else {
            run_in_process(&path)
        };
        check(&name, &r, &frames);
        n += 1;
    }
    assert!(n >= 7, "{n} plans");
}

/// A simulated PWM clock 20 ppm off the camera's: at 150 Hz and 30 fps the
/// phase drifts once round in 1 / (150 x 20e-6) = 333.3 s; no page says
/// "phase locked".
#[test]
fn a_clock_offset_is_stated_as_a_drift_not_a_phase_lock() {
    let dir = scratch("conditions-ppm");
    let text = std::fs::read_to_string(root().join("test-plans/daylight.toml")).unwrap();
    let text = text
        .replace(
            "frequencies-hz = [50.0, 90.0, 100.0, 150.0, 200.0, 500.0, 1000.0]",
            "frequencies-hz = [150.0]",
        )
        .replace(
            "led-fill = 1.0",
            "led-fill = 1.0\npwm-clock-offset-ppm = 20.0",
        );
    assert!(text.contains("pwm-clock-offset-ppm = 20.0") && text.contains("[150.0]"));
    let path = dir.join("ppm.toml");
    std::fs::write(&path, text).unwrap();
    let (r, frames) = run_in_process(&path);
    check("ppm", &r, &frames);
    let clock = r.conditions.pwm_clock.as_ref().unwrap();
    assert_eq!(clock.multiples_hz, [150.0]);
    assert!((clock.drift_period_s[0].unwrap() - 1.0 / (150.0 * 20e-6)).abs() < 1e-6);
    let said = &r
        .conditions
        .stated
        .iter()
        .find(|s| s.label == "PWM clock")
        .unwrap()
        .text;
    assert!(said.contains("150 Hz once every 333.3 s"), "{said}");
}
