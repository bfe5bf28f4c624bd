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
        let v = light_json(&path, &[]);
        let label = format!(
            "{} {} Hz {} ({})",
            r.kind,
            r.frequency_hz,
            r.duty,
            path.display()
        );
        assert_eq!(v["format"], "ledflicker.light/1");
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
    let v = light_json(&write_waveform(&sines[1], &dir, "sine.csv"), &[]);
    assert!((v["percent_flicker"].as_f64().unwrap() - 100.0 * sines[1].modulation).abs() < 1e-9);
    assert_eq!(v["ieee1789"]["region"], "elevated-risk");
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
        "percent flicker     19.01 %",
        "3 whole periods, 2500 samples, analysed",
        "SVM                 0.275",
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
            "line 7: the intensity -1 is negative",
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
            "every intensity is 0",
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
