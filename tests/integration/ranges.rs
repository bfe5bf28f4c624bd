//! Every numeric plan key, fed boundary values (subnormal, smallest
//! positive, huge, the documented range's ends and just outside them):
//! what `validate` accepts runs on the simulator, with an exit code of 0,
//! 1 or 4 and no NaN or undocumented infinity in results.json,
//! summary.csv or junit.xml; what it refuses names the key and its line
//! (docs/plan-format.md, "Limits").

use std::path::Path;

use ledflicker::plan;
use ledflicker::report::export;

use crate::{ledflicker, scratch, stderr};

/// A plan as tables of `key = value` lines, so that one key can be set.
#[derive(Clone)]
struct PlanText {
    tables: Vec<(String, Vec<(String, String)>)>,
}

impl PlanText {
    fn parse(text: &str) -> PlanText {
        let mut tables: Vec<(String, Vec<(String, String)>)> = vec![(String::new(), Vec::new())];
        for line in text.lines().map(str::trim) {
            if line.starts_with('[') {
                tables.push((line.to_string(), Vec::new()));
            } else if let Some((k, v)) = line.split_once(" = ") {
                tables.last_mut().unwrap().1.push((k.into(), v.into()));
            }
        }
        PlanText { tables }
    }

    /// Sets `key` of the (first) table whose header is `table`, e.g.
    /// `[dut.camera]`; a grid key's value is the one-element list.
    fn set(&mut self, table: &str, key: &str, value: &str) -> &mut Self {
        let (_, keys) = self
            .tables
            .iter_mut()
            .find(|(h, _)| h == table)
            .unwrap_or_else(|| panic!("no table {table}"));
        let value = if matches!(key, "frequencies-hz" | "duty-cycles" | "levels-lux") {
            format!("[{value}]")
        } else {
            value.to_string()
        };
        match keys.iter_mut().find(|(k, _)| k == key) {
            Some((_, v)) => *v = value,
            None => keys.push((key.to_string(), value)),
        }
        self
    }

    fn render(&self) -> String {
        let mut out = String::new();
        for (header, keys) in &self.tables {
            if !header.is_empty() {
                out.push_str(header);
                out.push('\n');
            }
            for (k, v) in keys {
                out.push_str(&format!("{k} = {v}\n"));
            }
        }
        out
    }
}

/// The ideal camera: 2 light levels' worth of radiometry in one case of
/// 24 frames on a 16 x 16 sensor.
const IDEAL: &str = r#"
[plan]
id = "bounds"
title = "Boundary values"
[sequence]
on-s = 0.2
off-s = 0.2
pwm-s = 0.4
[light]
levels-lux = [2000.0]
[grid]
frequencies-hz = [150.0]
duty-cycles = [0.2]
[[roi]]
name = "led"
x-px = 4
y-px = 4
width-px = 8
height-px = 2
[dut]
backend = "simulator"
[dut.camera]
shutter = "rolling"
sensor-rows = 16
sensor-columns = 16
line-time-us = 10.0
exposure-ms = 5.0
frame-rate-fps = 30.0
pwm-delay-ms = 0.0
response-dn-per-cd-m2-s = 18.5
black-level-dn = 0.0
full-scale-dn = 255.0
saturation-dn = 240.0
[scene]
background-reflectance = 0.18
led-luminance-cd-m2 = 1000.0
led-fill = 1.0
pwm-clock-offset-ppm = 0.0
[thresholds]
fdi-2018-min = 0.1
percent-flicker-max = 15.0
fmi-max = 0.15
fdi-p2020-min = 0.95
mmp-min = 0.9
mitigation-min-hz = 90.0
mitigation-max-hz = 2000.0
[p2020]
contrast-threshold = 0.1
mmp-delta = 0.1
"#;

/// A physical HDR camera with auto exposure, on the same scene.
const PHYSICAL: &str = r#"
[plan]
id = "bounds"
title = "Boundary values"
[sequence]
on-s = 0.2
off-s = 0.2
pwm-s = 0.4
[light]
levels-lux = [2000.0]
[grid]
frequencies-hz = [150.0]
duty-cycles = [0.2]
[[roi]]
name = "led"
x-px = 4
y-px = 4
width-px = 8
height-px = 2
[dut]
backend = "simulator"
[dut.camera]
shutter = "rolling"
sensor-rows = 16
sensor-columns = 16
line-time-us = 10.0
exposure-ms = 5.0
frame-rate-fps = 30.0
analog-gain = 1.0
digital-gain = 1.0
[dut.camera.sensor]
sensitivity-e-per-cd-m2-s = 4000.0
full-well-e = 12000.0
read-noise-e = 2.5
e-per-dn = 3.0
[[dut.camera.capture]]
exposure-ratio = 1.0
sensitivity-ratio = 1.0
[[dut.camera.capture]]
exposure-ratio = 0.5
sensitivity-ratio = 0.0625
[dut.camera.hdr]
mode = "sequential"
white-dn = 60000.0
[dut.camera.tone]
curve = "log"
log-a = 1000.0
[dut.camera.auto-exposure]
target-luma = 0.46
damping = 0.3
deadband = 0.05
min-exposure-ms = 0.05
max-exposure-ms = 10.0
max-analog-gain = 8.0
min-digital-gain = 0.01
max-digital-gain = 4.0
"#;

/// Values every key is tried with, besides its own range's ends.
const EXTREMES: [f64; 10] = [
    5e-324,
    f64::MIN_POSITIVE,
    1e-300,
    1e-9,
    1e9,
    1e300,
    f64::MAX,
    0.0,
    -5e-324,
    -1.0,
];

/// A numeric key: its plan, table, name and documented range (`None`
/// when the key has no range of its own, only cross-checks).
type Key = (&'static str, &'static str, &'static str, Option<(f64, f64)>);

/// Every numeric key of the two plans.
fn keys() -> Vec<Key> {
    use plan::bounds::*;
    vec![
        (IDEAL, "[sequence]", "on-s", None),
        (IDEAL, "[sequence]", "off-s", None),
        (IDEAL, "[sequence]", "pwm-s", None),
        (
            IDEAL,
            "[light]",
            "levels-lux",
            Some((MIN_LIGHT_LUX, MAX_LIGHT_LUX)),
        ),
        (
            IDEAL,
            "[grid]",
            "frequencies-hz",
            Some((1.0 / 0.4, MAX_FREQUENCY_HZ)),
        ),
        (IDEAL, "[grid]", "duty-cycles", Some((MIN_DUTY, 1.0))),
        (IDEAL, "[dut.camera]", "line-time-us", None),
        (
            IDEAL,
            "[dut.camera]",
            "exposure-ms",
            Some((MIN_EXPOSURE_S * 1e3, 1e3 / 30.0)),
        ),
        (
            IDEAL,
            "[dut.camera]",
            "frame-rate-fps",
            Some((MIN_FPS, MAX_FPS)),
        ),
        (
            IDEAL,
            "[dut.camera]",
            "pwm-delay-ms",
            Some((-MAX_PWM_DELAY_S * 1e3, MAX_PWM_DELAY_S * 1e3)),
        ),
        (
            IDEAL,
            "[dut.camera]",
            "response-dn-per-cd-m2-s",
            Some(RESPONSE_RANGE),
        ),
        (IDEAL, "[dut.camera]", "black-level-dn", None),
        (
            IDEAL,
            "[dut.camera]",
            "full-scale-dn",
            Some(FULL_SCALE_DN_RANGE),
        ),
        (IDEAL, "[dut.camera]", "saturation-dn", None),
        (IDEAL, "[scene]", "background-reflectance", Some((0.0, 1.0))),
        (
            IDEAL,
            "[scene]",
            "led-luminance-cd-m2",
            Some((0.0, MAX_LUMINANCE_CD_M2)),
        ),
        (IDEAL, "[scene]", "led-fill", None),
        (IDEAL, "[scene]", "led-frame-fraction", None),
        (IDEAL, "[scene]", "pwm-clock-offset-ppm", None),
        (IDEAL, "[thresholds]", "fdi-2018-min", None),
        (IDEAL, "[thresholds]", "percent-flicker-max", None),
        (IDEAL, "[thresholds]", "fmi-max", Some((0.0, 1.0))),
        (IDEAL, "[thresholds]", "fdi-p2020-min", Some((0.0, 1.0))),
        (IDEAL, "[thresholds]", "mmp-min", Some((0.0, 1.0))),
        (IDEAL, "[thresholds]", "mitigation-min-hz", None),
        (IDEAL, "[thresholds]", "mitigation-max-hz", None),
        (IDEAL, "[p2020]", "contrast-threshold", None),
        (IDEAL, "[p2020]", "mmp-delta", None),
        // An HDR camera with auto exposure wrote NaN and "inf s" for a
        // subnormal frequency.
        (
            PHYSICAL,
            "[grid]",
            "frequencies-hz",
            Some((1.0 / 0.4, MAX_FREQUENCY_HZ)),
        ),
        (
            PHYSICAL,
            "[dut.camera]",
            "analog-gain",
            Some(ANALOG_GAIN_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera]",
            "digital-gain",
            Some(DIGITAL_GAIN_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera.sensor]",
            "sensitivity-e-per-cd-m2-s",
            Some(SENSITIVITY_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera.sensor]",
            "full-well-e",
            Some(FULL_WELL_E_RANGE),
        ),
        (PHYSICAL, "[dut.camera.sensor]", "read-noise-e", None),
        (
            PHYSICAL,
            "[dut.camera.sensor]",
            "e-per-dn",
            Some(E_PER_DN_RANGE),
        ),
        (
            PHYSICAL,
            "[[dut.camera.capture]]",
            "exposure-ratio",
            Some((MIN_EXPOSURE_RATIO, 1.0)),
        ),
        (
            PHYSICAL,
            "[[dut.camera.capture]]",
            "sensitivity-ratio",
            Some(SENSITIVITY_RATIO_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera.hdr]",
            "white-dn",
            Some(WHITE_DN_RANGE),
        ),
        (PHYSICAL, "[dut.camera.tone]", "log-a", Some(LOG_A_RANGE)),
        (PHYSICAL, "[dut.camera.auto-exposure]", "target-luma", None),
        (PHYSICAL, "[dut.camera.auto-exposure]", "damping", None),
        (PHYSICAL, "[dut.camera.auto-exposure]", "deadband", None),
        (
            PHYSICAL,
            "[dut.camera.auto-exposure]",
            "min-exposure-ms",
            Some((MIN_EXPOSURE_S * 1e3, 10.0)),
        ),
        (
            PHYSICAL,
            "[dut.camera.auto-exposure]",
            "max-exposure-ms",
            Some((0.05, 1e3 / 30.0)),
        ),
        (
            PHYSICAL,
            "[dut.camera.auto-exposure]",
            "max-analog-gain",
            Some(ANALOG_GAIN_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera.auto-exposure]",
            "min-digital-gain",
            Some(DIGITAL_GAIN_RANGE),
        ),
        (
            PHYSICAL,
            "[dut.camera.auto-exposure]",
            "max-digital-gain",
            Some(DIGITAL_GAIN_RANGE),
        ),
    ]
}

/// The values to try for a key with documented range `range`: the
/// extremes, the ends, and just inside and outside each end.
fn probes_of(range: Option<(f64, f64)>) -> Vec<f64> {
    let mut v = EXTREMES.to_vec();
    if let Some((lo, hi)) = range {
        for end in [lo, hi] {
            let step = end.abs().max(1e-300) * 1e-6;
            v.extend([end, end - step, end + step]);
        }
    }
    v
}

/// A number as TOML writes it (`{:e}` keeps 5e-324 short and exact).
fn toml_number(x: f64) -> String {
    let s = format!("{x:e}");
    // TOML needs a digit after a decimal point and accepts `1e300`.
    s.replace("e", "e+").replace("e+-", "e-")
}

/// Words of `text` that hold a NaN or an infinity, other than those
/// docs/plan-format.md and docs/report.md define (`inf` for an unbounded
/// FDI in summary.csv, `+inf` in junit.xml's metric lines).
fn non_finite_words(text: &str, allowed: &[&str]) -> Vec<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '+' || c == '-' || c == '.'))
        .filter(|w| {
            let l = w.to_ascii_lowercase();
            (l.contains("nan") && l.trim_start_matches(['+', '-']) == "nan")
                || matches!(l.trim_start_matches(['+', '-']), "inf" | "infinity")
        })
        .filter(|w| !allowed.contains(w))
        .map(str::to_string)
        .collect()
}

/// Runs `text` through the pipeline in this process (no charts, HTML or
/// PDF): the exports and results.json, or the error.
fn run_in_process(text: &str) -> Result<[(String, String); 4], String> {
    let p =
        plan::parse(text, Path::new("bounds.toml"), String::new()).map_err(|e| e.to_string())?;
    let backend = ledflicker::backend::for_plan(&p, None).map_err(|e| e.to_string())?;
    let cases = plan::expand_cases(&p);
    let mut results = ledflicker::runner::run(&p, &cases, &backend, Some(1), &|_| {})
        .map_err(|e| format!("run failed: {e:#}"))?;
    ledflicker::runner::render_sample_frames(&p, &mut results, &backend)
        .map_err(|e| format!("sample frames failed: {e:#}"))?;
    let model =
        ledflicker::model::assemble(&p, ledflicker::backend::Backend::id(&backend), &results);
    let traces: String = results.iter().map(ledflicker::report::trace_csv).collect();
    Ok([
        (
            "results.json".into(),
            serde_json::to_string(&model).unwrap(),
        ),
        (
            export::CSV_FILE.into(),
            export::summary_csv(&model).unwrap(),
        ),
        (
            export::JUNIT_FILE.into(),
            export::junit_xml(&model).unwrap(),
        ),
        ("traces".into(), traces),
    ])
}

/// One probe: a key set to a value in its plan.
struct Probe {
    what: String,
    key: &'static str,
    value: f64,
    range: Option<(f64, f64)>,
    text: String,
}

/// The outputs that may hold an infinity, and how (docs/plan-format.md,
/// "Verdicts"; README legend): an unbounded FDI is `inf` in summary.csv
/// and `+inf` in the text of junit.xml and results.json.
fn allowed_infinities(file: &str) -> &'static [&'static str] {
    match file {
        "summary.csv" => &["inf"],
        "junit.xml" | "results.json" => &["+inf"],
        _ => &[],
    }
}

/// What is wrong with one probe's in-process outcome, if anything; the
/// value when it ran.
fn check(p: &Probe) -> (Vec<String>, Option<f64>) {
    let mut failures = Vec::new();
    let outcome = std::panic::catch_unwind(|| run_in_process(&p.text)).unwrap_or_else(|e| {
        let msg = e
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        Err(format!("panicked: {msg}"))
    });
    let what = &p.what;
    let own_range = p
        .range
        .is_none_or(|(lo, hi)| p.value >= lo && p.value <= hi);
    match outcome {
        Err(e) if e.starts_with("invalid test plan") => {
            // Refused at a key and its line: this key's own when the value
            // is outside its range, else the key of the cross-check.
            let located = e.contains("line ") && e.contains(", column ");
            if !located || (!own_range && !e.contains(p.key)) {
                failures.push(format!("{what}: refused without the key and line: {e}"));
            }
            let margin = |end: f64| end.abs().max(1e-300) * 1e-5;
            if let Some((lo, hi)) = p.range
                && p.value > lo + margin(lo)
                && p.value < hi - margin(hi)
            {
                failures.push(format!(
                    "{what}: inside the documented range {lo:e} ..= {hi:e} but refused: {e}"
                ));
            }
            (failures, None)
        }
        Err(e) => {
            failures.push(format!("{what}: validated, then failed: {e}"));
            (failures, None)
        }
        Ok(files) => {
            if !own_range {
                failures.push(format!(
                    "{what}: outside the documented range {:?} but accepted",
                    p.range
                ));
            }
            for (name, body) in &files {
                let bad = non_finite_words(body, allowed_infinities(name));
                if !bad.is_empty() {
                    failures.push(format!("{what}: {name} holds {bad:?}"));
                }
            }
            (failures, Some(p.value))
        }
    }
}

/// Runs `f` on every item on 2 threads (the runs are single-threaded);
/// the results in item order.
fn on_two_threads<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut out: Vec<(usize, R)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                s.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(item) = items.get(i) else { break };
                        done.push((i, f(item)));
                    }
                    done
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap())
            .collect()
    });
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, r)| r).collect()
}

#[test]
fn every_numeric_key_validates_only_what_runs() {
    let mut probes = Vec::new();
    for (base, table, key, range) in keys() {
        for value in probes_of(range) {
            probes.push(Probe {
                what: format!("{table} {key} = {value:e}"),
                key,
                value,
                range,
                text: PlanText::parse(base)
                    .set(table, key, &toml_number(value))
                    .render(),
            });
        }
    }
    let outcomes = on_two_threads(&probes, check);
    let mut failures: Vec<String> = outcomes.iter().flat_map(|(f, _)| f.clone()).collect();
    let ran = outcomes.iter().filter(|(_, v)| v.is_some()).count();
    assert!(
        ran > 100 && probes.len() - ran > 100,
        "ran {ran} of {}",
        probes.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The binary, with charts, HTML and PDF, on the smallest and largest
    // value of each key that validated.
    let mut extremes: Vec<&Probe> = Vec::new();
    for key in keys() {
        let valid: Vec<&Probe> = probes
            .iter()
            .zip(&outcomes)
            .filter(|(p, (_, v))| {
                v.is_some() && p.what.starts_with(&format!("{} {} =", key.1, key.2))
            })
            .map(|(p, _)| p)
            .collect();
        let lo = valid.iter().min_by(|a, b| a.value.total_cmp(&b.value));
        let hi = valid.iter().max_by(|a, b| a.value.total_cmp(&b.value));
        extremes.extend(lo.into_iter().chain(hi).copied());
    }
    let dir = scratch("ranges");
    let indexed: Vec<(usize, &Probe)> = extremes.into_iter().enumerate().collect();
    let binary_failures = on_two_threads(&indexed, |(i, p)| {
        let plan_path = dir.join(format!("p{i}.toml"));
        std::fs::write(&plan_path, &p.text).unwrap();
        let out = dir.join(format!("out{i}"));
        let o = ledflicker(&[
            "plan",
            plan_path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
            "--detail",
            "summary",
            "--threads",
            "1",
        ]);
        let code = o.status.code();
        if !matches!(code, Some(0 | 1 | 4)) {
            return vec![format!("{}: exit {code:?}: {}", p.what, stderr(&o))];
        }
        let mut bad = Vec::new();
        for name in ["results.json", "summary.csv", "junit.xml"] {
            let body = std::fs::read_to_string(out.join(name)).unwrap();
            let words = non_finite_words(&body, allowed_infinities(name));
            if !words.is_empty() {
                bad.push(format!("{}: {name} holds {words:?}", p.what));
            }
        }
        let _ = std::fs::remove_dir_all(&out);
        bad
    });
    failures.extend(binary_failures.into_iter().flatten());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
