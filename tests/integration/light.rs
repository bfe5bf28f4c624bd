//! `ledflicker light WAVEFORM.csv` against figures computed elsewhere:
//! - Percent Flicker, the Flicker Index and the SVM of 13 waveforms
//!   (square waves at six duties, sines, a triangle, rectified mains, two
//!   real lamps) against tests/data/light/reference.csv, made by an
//!   independent NumPy script (reference.py there; SOURCE.md) and, where a
//!   closed form exists, against the continuous waveform's SVM;
//! - PstLM against the Aalto light flickermeter's values
//!   (tests/data/pstlm/aalto-reference.csv);
//! - the errors, each naming the file and the line.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use crate::{ledflicker, root, scratch, text};

/// One row of reference.csv.
struct Reference {
    kind: String,
    frequency_hz: f64,
    duty: f64,
    modulation: f64,
    rate_hz: f64,
    samples: usize,
    lamp: String,
    analysed_samples: u64,
    percent_flicker: f64,
    flicker_index: f64,
    svm: f64,
    svm_continuous: Option<f64>,
}

fn references() -> Vec<Reference> {
    let text = std::fs::read_to_string(root().join("tests/data/light/reference.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            Reference {
                kind: f[0].to_string(),
                frequency_hz: f[1].parse().unwrap(),
                duty: f[2].parse().unwrap(),
                modulation: f[3].parse().unwrap(),
                rate_hz: f[4].parse().unwrap(),
                samples: f[5].parse().unwrap(),
                lamp: f[7].to_string(),
                analysed_samples: f[8].parse().unwrap(),
                percent_flicker: f[9].parse().unwrap(),
                flicker_index: f[10].parse().unwrap(),
                svm: f[11].parse().unwrap(),
                svm_continuous: f[12].parse().ok(),
            }
        })
        .collect()
}

/// The waveform of a row as SOURCE.md defines it, written as a CSV file
/// (`time_s,light`) in `dir`; a lamp's is its own record.
fn write_waveform(r: &Reference, dir: &Path, name: &str) -> PathBuf {
    if r.kind == "lamp" {
        return root().join("tests/data/lamps").join(&r.lamp);
    }
    let per = (r.rate_hz / r.frequency_hz).round() as usize;
    let mut csv = String::from("time_s,light\n");
    for i in 0..r.samples {
        let x = match r.kind.as_str() {
            "square" => f64::from(u8::from(i % per < (r.duty * per as f64).round() as usize)),
            "sine" => 1.0 + r.modulation * (2.0 * PI * r.frequency_hz * i as f64 / r.rate_hz).sin(),
            "triangle" => {
                let u = (i % per) as f64 / per as f64;
                0.2 + 0.8 * (1.0 - (2.0 * u - 1.0).abs())
            }
            "rectified" => (PI * r.frequency_hz * i as f64 / r.rate_hz).sin().abs(),
            other => panic!("unknown kind {other}"),
        };
        csv.push_str(&format!("{},{x}\n", i as f64 / r.rate_hz));
    }
    let path = dir.join(name);
    std::fs::write(&path, csv).unwrap();
    path
}

/// `light --json` of `path`, parsed.
fn light_json(path: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["light", path.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    let o = ledflicker(&args);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn value(v: &serde_json::Value, key: &str) -> f64 {
    v[key]["value"]
        .as_f64()
        .unwrap_or_else(|| panic!("{key}: {v}"))
}

#[test]
fn light_matches_the_independent_reference_on_13_waveforms() {
    let dir = scratch("light-reference");
    for (k, r) in references().iter().enumerate() {
        let path = write_waveform(r, &dir, &format!("w{k}.csv"));
        // The references are exact waveforms, read without a band limit.
        let v = light_json(&path, &["--bandwidth", "none"]);
        let label = format!(
            "{} {} Hz {} ({})",
            r.kind,
            r.frequency_hz,
            r.duty,
            path.display()
        );
        assert_eq!(v["format"], "ledflicker.light/2");
        let f = value(&v, "fundamental_hz");
        // The lamps' ripple follows their 60 Hz mains, not exactly 120 Hz.
        let tolerance = if r.kind == "lamp" { 2.0 } else { 1e-3 };
        assert!((f - r.frequency_hz).abs() < tolerance, "{label}: {f} Hz");
        assert_eq!(
            v["analysed_samples"].as_u64(),
            Some(r.analysed_samples),
            "{label}"
        );
        let pf = v["percent_flicker"].as_f64().unwrap();
        assert!((pf - r.percent_flicker).abs() < 1e-9, "{label}: PF {pf}");
        let fi = v["flicker_index"].as_f64().unwrap();
        assert!((fi - r.flicker_index).abs() < 1e-9, "{label}: FI {fi}");
        let svm = value(&v, "svm");
        assert!(
            (svm - r.svm).abs() < 1e-9 * r.svm.max(1.0),
            "{label}: SVM {svm} vs {}",
            r.svm
        );
        if let Some(cont) = r.svm_continuous {
            // Sampling: a square's edges fall on samples (docs/light.md).
            assert!(
                (svm - cont).abs() < 1e-4 * cont,
                "{label}: SVM {svm} vs continuous {cont}"
            );
        }
    }
}

#[test]
fn closed_forms_hold_for_squares_and_sines() {
    // A square wave of duty D: Percent Flicker 100 %, Flicker Index 1 - D;
    // a sine of modulation m: Percent Flicker 100 m.
    for r in references().iter().filter(|r| r.kind == "square") {
        assert!((r.percent_flicker - 100.0).abs() < 1e-12);
        assert!(
            (r.flicker_index - (1.0 - r.duty)).abs() < 1e-12,
            "{}",
            r.duty
        );
    }
    let sines: Vec<_> = references()
        .into_iter()
        .filter(|r| r.kind == "sine")
        .collect();
    assert!((sines[1].percent_flicker - 30.0).abs() < 1e-9);
    let dir = scratch("light-closed-forms");
    let path = write_waveform(&sines[1], &dir, "sine.csv");
    let v = light_json(&path, &["--bandwidth", "none"]);
    assert!((v["percent_flicker"].as_f64().unwrap() - 100.0 * sines[1].modulation).abs() < 1e-9);
    assert_eq!(v["ieee1789"]["region"], "elevated-risk");
    // Band-limited to B, a sine of f keeps exp(-(ln 2 / 2) (f / B)^2) of
    // its modulation (the Gaussian's response; docs/light.md).
    for b in [10_000.0, 1000.0, 300.0] {
        let v = light_json(&path, &["--bandwidth", &b.to_string()]);
        let f = sines[1].frequency_hz;
        let want = 100.0 * sines[1].modulation * (-(2f64.ln() / 2.0) * (f / b).powi(2)).exp();
        let pf = v["percent_flicker"].as_f64().unwrap();
        assert!((pf - want).abs() < 1e-4 * want, "B {b}: {pf} vs {want}");
        assert_eq!(v["bandwidth_hz"].as_f64(), Some(b));
    }
}

/// The Aalto rows this test runs: 30 s at 4 kHz each (tests/data/pstlm/SOURCE.md).
fn aalto_rows() -> Vec<(String, f64, f64, f64, f64)> {
    let text =
        std::fs::read_to_string(root().join("tests/data/pstlm/aalto-reference.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[0] != "lamp")
        .map(|f| {
            (
                f[0].to_string(),
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
                f[3].parse().unwrap(),
                f[5].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn pst_lm_of_a_csv_record_matches_the_aalto_flickermeter() {
    let dir = scratch("light-pstlm");
    let rate = 4000.0;
    // Three of the table's kinds: the reference sine, a rectangular
    // fluctuation, full PWM.
    let rows = aalto_rows();
    let chosen = [0usize, 6, 9];
    for &k in &chosen {
        let (kind, f, duty, m, pst) = &rows[k];
        let mut csv = String::from("Time (s);Light (a.u.)\n");
        for i in 0..120_000u32 {
            let phase = f64::from(i) * f / rate;
            let phase = phase - phase.floor();
            let x = match kind.as_str() {
                "sine" => 1.0 + m / 2.0 * (2.0 * PI * f * f64::from(i) / rate).sin(),
                "square" if phase < *duty => 1.0 + m / 2.0,
                "square" => 1.0 - m / 2.0,
                _ => f64::from(u8::from(phase < *duty)),
            };
            // Semicolons and decimal commas, as a European export.
            csv.push_str(&format!("{};{x}\n", f64::from(i) / rate).replace('.', ","));
        }
        let path = dir.join(format!("aalto{k}.csv"));
        std::fs::write(&path, csv).unwrap();
        let v = light_json(&path, &["--intensity-column", "light (a.u.)"]);
        let got = value(&v, "pst_lm");
        assert!(
            (got - pst).abs() < 2e-3 * pst,
            "{kind} {f} Hz: PstLM {got} vs Aalto {pst}"
        );
        assert_eq!(v["intensity_column"], "Light (a.u.)");
    }
}

#[test]
fn the_table_says_why_pst_lm_is_missing_and_never_prints_nan() {
    let o = ledflicker(&["light", "tests/data/lamps/cfl.csv"]);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    for needle in [
        "light source `tests/data/lamps/cfl.csv`: columns `time_s` (s) and `value_v`",
        "fundamental",
        "percent flicker     13.53 % (IEEE 1789 modulation; 19.01 % on the raw samples)",
        "3 whole periods, 2491 samples, analysed",
        "SVM                 0.274",
        "PstLM               not computed: the waveform lasts 0.025 s; PstLM needs at least 20 s",
        "hint: record the light for 20 s or more",
        "IEEE 1789-2015      elevated-risk (at 1",
    ] {
        assert!(out.contains(needle), "`{needle}` not in:\n{out}");
    }
    assert!(!out.to_lowercase().contains("nan"), "{out}");
}

#[test]
fn bad_waveforms_are_refused_naming_the_file_and_line() {
    let dir = scratch("light-errors");
    let good: String = std::iter::once("time_s,light\n".to_string())
        .chain((0..20).map(|i| format!("{:.4},{}\n", f64::from(i) * 1e-4, i % 2)))
        .collect();
    let cases = [
        (
            "malformed.csv",
            good.replace("0.0005,1", "0.0005,one"),
            "line 7: the intensity `one` is not a finite number",
        ),
        (
            "nan.csv",
            good.replace("0.0005,1", "0.0005,nan"),
            "line 7: the intensity `nan` is not a finite number",
        ),
        (
            "negative.csv",
            good.replace("0.0005,1", "0.0005,-1"),
            "line 7: the intensity -1 is below 0 by more than 10 %",
        ),
        (
            "backwards.csv",
            good.replace("0.0005,", "0.0003,"),
            "line 7: the time 0.0003 s is not after 0.0004 s of line 6",
        ),
        (
            "gap.csv",
            good.replace("0.0005,1\n", ""),
            "sampling intervals off the even grid",
        ),
        (
            "short.csv",
            "time_s,light\n0,1\n0.001,0\n".to_string(),
            "2 samples; the analysis needs at least 8",
        ),
        (
            "dark.csv",
            good.replace(",1\n", ",0\n"),
            "the intensities average 0 or less",
        ),
    ];
    for (name, body, needle) in cases {
        let path = dir.join(name);
        std::fs::write(&path, body).unwrap();
        let o = ledflicker(&["light", path.to_str().unwrap()]);
        let err = text(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(needle) && err.contains(name) && err.contains("hint"),
            "{name}: `{needle}` not in {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    let o = ledflicker(&["light", dir.join("missing.csv").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("missing.csv"));
}

#[test]
fn a_record_of_levels_near_the_largest_double_is_analysed_as_the_same_light() {
    let dir = crate::scratch("light-huge");
    let mut small = String::from("time_s,light\n");
    let mut huge = String::from("time_s,light\n");
    for i in 0..4000 {
        let t = i as f64 / 40_000.0;
        let on = (t * 120.0).fract() < 0.4;
        let v = if on { 1.0 } else { 0.25 };
        small.push_str(&format!("{t},{v}\n"));
        huge.push_str(&format!("{t},{:e}\n", v * 1.7e308));
    }
    std::fs::write(dir.join("small.csv"), small).unwrap();
    std::fs::write(dir.join("huge.csv"), huge).unwrap();
    let json = |f: &str| {
        let o = crate::ledflicker_in(&["light", f, "--json"], &dir);
        assert_eq!(o.status.code(), Some(0), "{}", crate::text(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let (a, b) = (json("small.csv"), json("huge.csv"));
    for key in ["percent_flicker", "flicker_index"] {
        let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
        assert!((x - y).abs() < 1e-9 * x.abs().max(1.0), "{key}: {x} vs {y}");
    }
    assert_eq!(a["ieee1789"]["region"], b["ieee1789"]["region"]);
    let f = b["fundamental_hz"]["value"].as_f64().unwrap();
    assert!((f - 120.0).abs() < 0.5, "{f}");
}

/// A scope's record of a light: `level(t)` sampled at `rate` for
/// `seconds`, with Gaussian noise of `noise` (a fixed seed) and an offset,
/// times printed to the nanosecond as scopes export them.
fn scope_record(
    path: &Path,
    rate: f64,
    seconds: f64,
    noise: f64,
    offset: f64,
    level: impl Fn(f64) -> f64,
) {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut body = String::from("Model,scope\nTime (s),CH1 (V)\n");
    let n = (seconds * rate).round() as usize;
    for i in 0..n {
        let t = i as f64 / rate;
        let g = (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos();
        body.push_str(&format!("{t:.9},{:.5}\n", level(t) + offset + noise * g));
    }
    std::fs::write(path, body).unwrap();
}

#[test]
fn a_noisy_scope_record_reads_its_lights_modulation_once_band_limited() {
    // A 120 Hz ripple of 8 % (Percent Flicker 8 %) over 1 V, 3.2 periods
    // at 500 kHz with 20 mV of noise: the raw extremes read far more.
    let dir = scratch("light-scope");
    let path = dir.join("ripple.csv");
    let pi2 = 2.0 * std::f64::consts::PI;
    scope_record(&path, 500_000.0, 3.2 / 120.0, 0.02, 0.0, |t| {
        1.0 + 0.08 * (pi2 * 120.0 * t).sin()
    });
    let v = light_json(&path, &[]);
    assert_eq!(v["bandwidth_hz"].as_f64(), Some(10_000.0));
    let pf = v["percent_flicker"].as_f64().unwrap();
    let raw = v["percent_flicker_raw"].as_f64().unwrap();
    assert!(raw > 12.0, "raw {raw}");
    // The noise left in the band still lifts the extremes a little (4
    // sigma of 4 mV on each side: about 1.6 points).
    assert!(
        (pf - 8.0).abs() < 2.0 && pf < raw - 3.0,
        "band-limited {pf}"
    );
    let f = value(&v, "fundamental_hz");
    assert!((f - 120.0).abs() < 0.5, "{f}");
    // The table says both, and the band limit.
    let o = ledflicker(&["light", path.to_str().unwrap()]);
    let t = text(&o);
    assert!(t.contains("band limit          10.0000 kHz"), "{t}");
    assert!(t.contains("on the raw samples"), "{t}");
}

#[test]
fn a_dark_phase_read_slightly_below_zero_is_dark_not_refused() {
    // 100 Hz PWM at 30 % with a -8 mV offset and 3 mV of noise.
    let dir = scratch("light-offset");
    let path = dir.join("pwm.csv");
    scope_record(&path, 100_000.0, 0.1, 0.003, -0.008, |t| {
        f64::from(u8::from((t * 100.0).fract() < 0.3))
    });
    let v = light_json(&path, &[]);
    assert!(v["read_as_dark"].as_u64().unwrap() > 1000, "{v}");
    let pf = v["percent_flicker"].as_f64().unwrap();
    assert!((pf - 100.0).abs() < 1e-9, "{pf}");
    let fi = v["flicker_index"].as_f64().unwrap();
    assert!((fi - 0.7).abs() < 0.01, "{fi}");
}

#[test]
fn a_record_short_of_whole_periods_is_analysed_over_those_it_holds() {
    // A square of 100 Hz at 20 % (SVM 7.55 in closed form) over 3.92 and
    // 20.93 periods: whole periods only, so the SVM and the Flicker Index
    // are the light's.
    let dir = scratch("light-partial");
    for periods in [3.92, 20.93] {
        let path = dir.join(format!("sq{periods}.csv"));
        scope_record(&path, 100_000.0, periods / 100.0, 0.0, 0.0, |t| {
            f64::from(u8::from((t * 100.0 + 1e-9).fract() < 0.2))
        });
        let v = light_json(&path, &["--bandwidth", "none"]);
        assert_eq!(
            v["analysed_periods"].as_u64(),
            Some(periods as u64),
            "{periods}: {v}"
        );
        let svm = value(&v, "svm");
        assert!(
            (svm - 7.55015905).abs() < 1e-3 * 7.55,
            "{periods}: SVM {svm}"
        );
        let fi = v["flicker_index"].as_f64().unwrap();
        assert!((fi - 0.8).abs() < 1e-9, "{periods}: FI {fi}");
    }
}

#[test]
fn two_tones_keep_the_svm_of_both() {
    // 100 Hz at modulation 0.3 and 130 Hz at 0.2 over 0.237 s, cut to whole
    // periods of 100 Hz: the 130 Hz tone is not whole. The SVM of the two
    // sinusoids in closed form: (sum (m / T(f))^3.7)^(1/3.7).
    let dir = scratch("light-two-tones");
    let path = dir.join("mix.csv");
    let pi2 = 2.0 * std::f64::consts::PI;
    scope_record(&path, 20_000.0, 0.237, 0.0, 0.0, |t| {
        1.0 + 0.3 * (pi2 * 100.0 * t).sin() + 0.2 * (pi2 * 130.0 * t).sin()
    });
    let v = light_json(&path, &["--bandwidth", "none"]);
    let threshold =
        |f: f64| 1.0 / (1.0 + (-0.00518 * (f - 306.6)).exp()) + 20.0 * (-f / 10.0).exp();
    let want =
        ((0.3 / threshold(100.0)).powf(3.7) + (0.2 / threshold(130.0)).powf(3.7)).powf(1.0 / 3.7);
    let svm = value(&v, "svm");
    assert_eq!(v["svm_components"], "spectral-peaks");
    assert!((svm - want).abs() < 0.01 * want, "SVM {svm} vs {want}");
    // The fundamental is the stronger tone's, not a lag the other pulls
    // the match to (103 Hz before the match's edge rule).
    let f = value(&v, "fundamental_hz");
    assert!((f - 100.0).abs() < 0.1, "{f}");
    // A band limit near the light's frequency does not move it either.
    let v = light_json(&path, &["--bandwidth", "300"]);
    let f = value(&v, "fundamental_hz");
    assert!((f - 100.0).abs() < 0.1, "B 300 Hz: {f}");
}

#[test]
fn a_known_dark_offset_is_taken_off_before_the_svm() {
    // 100 Hz PWM at 2 % duty (SVM of the ideal light in closed form) read
    // with a -5 mV offset: the offset lowers the mean and doubles the SVM
    // unless --dark gives it.
    let dir = scratch("light-dark");
    let path = dir.join("pwm.csv");
    scope_record(&path, 100_000.0, 0.2, 0.0, -0.005, |t| {
        f64::from(u8::from((t * 100.0 + 1e-9).fract() < 0.02))
    });
    let svm_of = |extra: &[&str]| {
        let mut args = vec!["--bandwidth", "none"];
        args.extend_from_slice(extra);
        value(&light_json(&path, &args), "svm")
    };
    let x = std::f64::consts::PI * 0.02;
    let threshold =
        |f: f64| 1.0 / (1.0 + (-0.00518 * (f - 306.6)).exp()) + 20.0 * (-f / 10.0).exp();
    let want = (1..=20)
        .map(|k| {
            let c = 2.0 * (x * k as f64).sin().abs() / (x * k as f64);
            (c / threshold(100.0 * k as f64)).powf(3.7)
        })
        .sum::<f64>()
        .powf(1.0 / 3.7);
    let (raw, dark) = (svm_of(&[]), svm_of(&["--dark", "-0.005"]));
    assert!(raw > 1.2 * want, "{raw} vs {want}");
    assert!((dark - want).abs() < 1e-3 * want, "{dark} vs {want}");
}

#[test]
fn an_exact_dark_stays_dark_through_a_narrow_band_limit_and_a_slow_record_names_no_method() {
    // A noiseless PWM whose dark is exactly 0, band-limited with a wide
    // kernel (the FFT path): nothing is read below 0.
    let dir = scratch("light-exact-dark");
    let path = dir.join("pwm.csv");
    scope_record(&path, 100_000.0, 0.5, 0.0, 0.0, |t| {
        f64::from(u8::from((t * 50.0 + 1e-9).fract() < 0.1))
    });
    let v = light_json(&path, &["--bandwidth", "400"]);
    assert_eq!(v["read_as_dark"].as_u64(), Some(0), "{v}");
    // Sampled at 3 kHz: no SVM, and no way of taking its components.
    let slow = dir.join("slow.csv");
    scope_record(&slow, 3000.0, 0.5, 0.0, 0.0, |t| {
        f64::from(u8::from((t * 100.0 + 1e-9).fract() < 0.5))
    });
    let v = light_json(&slow, &[]);
    assert!(
        v["svm"]["value"].is_null() && v["svm_components"].is_null(),
        "{v}"
    );
}

#[test]
fn under_two_periods_nothing_is_given_that_needs_the_period() {
    let dir = scratch("light-short");
    let path = dir.join("short.csv");
    let pi2 = 2.0 * std::f64::consts::PI;
    scope_record(&path, 20_000.0, 1.6 / 100.0, 0.0, 0.0, |t| {
        1.0 + 0.5 * (pi2 * 100.0 * t).sin()
    });
    let v = light_json(&path, &[]);
    assert!(v["fundamental_hz"]["value"].is_null(), "{v}");
    assert!(v["svm"]["value"].is_null(), "{v}");
    assert!(
        v["svm"]["reason"].as_str().unwrap().contains("too short"),
        "{v}"
    );
}

#[test]
fn a_light_at_90_hz_is_judged_on_the_90_hz_side_whatever_the_sampling_and_noise() {
    // 5 % modulation at exactly 90 Hz: within the 7.2 % low-risk limit of
    // 90 Hz and up, above the 2.25 % of below 90 Hz. The estimate may fall
    // a few millionths below 90 Hz; within its resolution it is 90 Hz.
    let dir = scratch("light-90");
    let pi2 = 2.0 * std::f64::consts::PI;
    for (k, (rate, seconds)) in [
        (10_000.0, 0.5),
        (12_345.0, 0.31),
        (48_000.0, 0.2),
        (100_000.0, 0.05),
        (7_919.0, 1.0),
        (44_100.0, 0.123),
    ]
    .into_iter()
    .enumerate()
    {
        let path = dir.join(format!("l{k}.csv"));
        scope_record(&path, rate, seconds, 0.0, 0.0, |t| {
            1.0 + 0.05 * (pi2 * 90.0 * t).sin()
        });
        let v = light_json(&path, &["--bandwidth", "none"]);
        let f = value(&v, "fundamental_hz");
        assert!((f - 90.0).abs() < 0.01, "{rate}: {f}");
        assert_eq!(
            v["ieee1789"]["region"], "low-risk",
            "{rate} Hz, {seconds} s: {v}"
        );
        // 5 mV of noise over 3.6 periods moves the estimate by up to about
        // half a percent; the region stays.
        let noisy = dir.join(format!("n{k}.csv"));
        scope_record(&noisy, rate, 3.6 / 90.0, 0.005, 0.0, |t| {
            1.0 + 0.05 * (pi2 * 90.0 * t + k as f64).sin()
        });
        let v = light_json(&noisy, &[]);
        assert_eq!(
            v["ieee1789"]["region"], "low-risk",
            "{rate} Hz, {seconds} s: {v}"
        );
        assert_eq!(v["ieee1789"]["low_risk_max_percent"].as_f64(), Some(7.2));
    }
}

/// A scope that stamps its samples in milliseconds and says so in the
/// header (`Time (ms)`) gives the light's own frequency, not one a
/// thousandth of it; the table says the unit it read.
#[test]
fn a_time_column_in_milliseconds_gives_the_lights_frequency() {
    let dir = scratch("light-ms");
    let rows = |scale: f64| -> String {
        (0..4000)
            .map(|i| {
                let t = i as f64 * 50e-6;
                format!(
                    "{:.9},{:.6}\n",
                    t * scale,
                    1.0 + 0.5 * (2.0 * PI * 120.0 * t).sin()
                )
            })
            .collect()
    };
    let seconds = dir.join("s.csv");
    std::fs::write(&seconds, format!("Time (s),V\n{}", rows(1.0))).unwrap();
    let millis = dir.join("ms.csv");
    std::fs::write(&millis, format!("Time (ms),V\n{}", rows(1e3))).unwrap();
    let (a, b) = (light_json(&seconds, &[]), light_json(&millis, &[]));
    let f = value(&b, "fundamental_hz");
    assert!((f - 120.0).abs() < 0.05, "{f}");
    assert_eq!(value(&a, "fundamental_hz"), f);
    let table = text(&ledflicker(&["light", millis.to_str().unwrap()]));
    assert!(table.contains("`Time (ms)` (ms)"), "{table}");
    // A header that names something else in brackets is refused, not
    // read as seconds.
    let samples = dir.join("samples.csv");
    std::fs::write(&samples, format!("Time (samples),V\n{}", rows(1.0))).unwrap();
    let o = ledflicker(&["light", samples.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("not one ledflicker reads"),
        "{}",
        text(&o)
    );
}
