//! Issue 12: verdicts a carmaker can rely on. P2020 limits in plans, judged
//! captures, every metric in every output, the method per backend and an
//! auto-exposure target a user can set.

use std::path::Path;
use std::process::Output;

use ledflicker::backend::sim::Simulator;
use ledflicker::metrics::Verdict;
use ledflicker::plan;
use ledflicker::runner;
use serde_json::Value;

use crate::{ledflicker_in as ledflicker, pdf_text, root, scratch};

fn run(plan: &Path, out: &Path) -> (Output, String) {
    let o = ledflicker(
        &[
            "plan",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--date",
            "2026-02-01",
        ],
        root(),
    );
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o, text)
}

fn json(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
}

#[test]
fn p2020_samples_fail_test_vid2_on_fmi_and_mmp_in_every_output() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh"
    );
    let out = scratch("p2020-verdicts");
    let (o, stdout) = run(&root().join("test-plans/p2020-samples.toml"), &out);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    let j = json(&out);
    let vid2 = &j["cases"][1];
    assert_eq!(vid2["id"], "test_vid2");
    assert_eq!(vid2["verdict"], "fail");
    assert_eq!(j["thresholds"]["basis"], "as-captured");
    let checks = vid2["checks"].as_array().unwrap();
    for metric in ["fmi", "mmp"] {
        // Every one of the 36 ROIs beats to 0 DN: FMI 1, MMP < 0.1.
        let failed = checks
            .iter()
            .filter(|k| k["metric"] == metric && k["pass"] == false)
            .count();
        assert_eq!(failed, 36, "{metric}");
    }
    // test_vid1 is steady (FMI <= 0.056, MMP 1): it passes.
    assert_eq!(j["cases"][0]["verdict"], "pass");

    // Terminal: the worst ROI, the failed criterion, every metric, a legend.
    let row = stdout
        .lines()
        .find(|l| l.starts_with("test_vid2"))
        .unwrap_or_else(|| panic!("{stdout}"));
    // The light beats to 0 DN, the OFF level: FDI (2018) is 0/0 and fails
    // its default minimum, and FMI, FDI (P2020) and MMP fail theirs.
    assert!(
        row.contains("FAIL: fdi_2018 undefined is not >= 0.1 on roi"),
        "{row}"
    );
    assert!(
        row.contains("failed: fdi_2018, fmi, fdi_p2020, mmp"),
        "{row}"
    );
    assert!(row.contains("1.000"), "{row}");
    // Each capture's darkest PWM frame, read again from the video, whole,
    // and the ROI map of the method on each capture's frame where the lamp
    // is lit (these videos have no ON segment: the brightest PWM frame),
    // test_vid2's too, whose darkest frame is black.
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for case in ["test_vid1", "test_vid2", "test_vid3"] {
        let frame = image::open(out.join(format!("frames/{case}.png"))).unwrap();
        assert_eq!((frame.width(), frame.height()), (1280, 800), "{case}");
        let c = j["cases"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["id"] == case)
            .unwrap();
        assert_eq!(c["sample_frame"]["path"], format!("frames/{case}.png"));
        let lit = &c["capture"]["lit_frame"];
        assert_eq!(lit["segment"], "pwm", "{case}: {lit}");
        let lit = lit["frame"].as_u64().unwrap();
        assert_ne!(Some(lit), c["sample_frame"]["frame"].as_u64(), "{case}");
        let caption =
            format!("ROIs on frame {lit} of case {case} (its PWM frame of highest LED-ROI luma");
        assert!(html.contains(&caption), "{caption}");
    }
    assert_eq!(html.matches("<figcaption>ROIs on frame").count(), 3);
    let header = stdout.lines().find(|l| l.starts_with("case")).unwrap();
    for col in ["roi", "FMI", "FDI P2020", "MMP", "criterion"] {
        assert!(header.contains(col), "{header}");
    }
    assert!(stdout.contains("+inf = unbounded FDI"), "{stdout}");
    assert!(stdout.contains("n/a = undefined"), "{stdout}");
    assert!(
        stdout.contains("worst = worst case over PWM phase"),
        "{stdout}"
    );
    // The row shows the worst ROI. test_vid2: every ROI fails FDI (2018) and
    // FMI alike, so the lowest MMP decides. test_vid1 passes and its FDI and
    // MMP margins tie, so the highest FMI (the closest to its limit) decides.
    let column = |case: &str, i: usize| -> String {
        stdout
            .lines()
            .find(|l| l.starts_with(case))
            .unwrap()
            .split_whitespace()
            .nth(i)
            .unwrap()
            .to_string()
    };
    // test_vid1 has a dark OFF reference: its FDI (2018) is +inf, but a
    // capture has no worst case over phase, so that column is n/a, not +inf.
    assert_eq!(column("test_vid1", 3), "+inf", "{stdout}");
    assert_eq!(column("test_vid1", 4), "n/a", "{stdout}");
    let extreme = |case: usize, metric: &str, max: bool| {
        let values = j["cases"][case]["rois"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["metrics"][metric].as_f64().unwrap());
        let v = if max {
            values.fold(f64::NEG_INFINITY, f64::max)
        } else {
            values.fold(f64::INFINITY, f64::min)
        };
        format!("{v:.3}")
    };
    assert_eq!(column("test_vid2", 9), extreme(1, "mmp", false));
    assert_eq!(column("test_vid1", 7), extreme(0, "fmi", true));
    assert!(stdout.contains("overall: FAIL"), "{stdout}");
    assert!(stdout.contains("0 cases not judged"), "{stdout}");
    assert!(stdout.contains("as captured"), "{stdout}");

    // summary.csv: fmi per ROI, limits, the failed criteria, empty conditions.
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let row: Vec<&str> = csv
        .lines()
        .find(|l| l.starts_with("test_vid2,"))
        .unwrap()
        .split(',')
        .collect();
    assert_eq!(row[col("fmi")], "1");
    assert_eq!(row[col("fmi_max")], "0.1");
    assert_eq!(row[col("mmp_min")], "0.9");
    assert!(
        row[col("failed")].contains("fmi 1.000 > 0.1 on roi0"),
        "{row:?}"
    );
    assert!(row[col("failed")].contains("mmp "), "{row:?}");
    for c in ["light_lux", "frequency_hz", "duty"] {
        assert_eq!(row[col(c)], "", "unknown {c} is an empty cell");
    }
    assert!(!csv.contains("e-"), "no exponents in summary.csv");

    // junit.xml: the failure names the criterion; every KPI is listed.
    let junit = std::fs::read_to_string(out.join("junit.xml")).unwrap();
    let start = junit.find("name=\"test_vid2\"").unwrap();
    let block = &junit[start..start + junit[start..].find("</testcase>").unwrap()];
    assert!(
        block.contains("failed: fdi_2018, fmi, fdi_p2020, mmp)\""),
        "{block}"
    );
    assert!(block.contains("fmi 1.000 &gt; 0.1 on roi0"), "{block}");
    assert!(block.contains("fdi_p2020 "), "{block}");

    // HTML and PDF show the KPIs, the limits and the capture's method.
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for needle in [
        "<th title=\"Flicker Modulation Index (P2020)\">FMI</th>",
        "<th title=\"Modulation Mitigation Probability (P2020)\">MMP</th>",
        "FMI &lt;= 0.1",
        "Capture <code>",
        "test_vid2.mp4",
        "frames used",
        "trace as captured",
    ] {
        assert!(html.contains(needle), "`{needle}` not in report.html");
    }
    assert!(!html.contains("ideal camera simulator"));
    let pdf = pdf_text(&out.join("report.pdf"));
    for needle in ["FMI", "P2020", "MMP", "fmi", "1.000"] {
        assert!(pdf.contains(needle), "`{needle}` not in the PDF text");
    }
}

/// A captured plan with a flickering CSV trace and no conditions.
fn csv_plan(dir: &Path, extra_thresholds: &str, extra_case: &str) -> std::path::PathBuf {
    let mut trace = String::from("frame,time_s,a\n");
    for k in 0..40 {
        let v = if k < 10 {
            5.0
        } else if k % 2 == 0 {
            60.0
        } else {
            100.0
        };
        trace += &format!("{k},{},{v}\n", k as f64 / 30.0);
    }
    std::fs::write(dir.join("t.csv"), trace).unwrap();
    let text = format!(
        "[plan]\nid = \"judged\"\ntitle = \"judged\"\n[dut]\nbackend = \"captured\"\n\
         [capture]\noff-frames = [0, 10]\npwm-frames = [10]\n\
         [thresholds]\nmitigation-min-hz = 90.0\n{extra_thresholds}\n\
         [[case]]\nsource = \"t.csv\"\n{extra_case}\n\
         [[roi]]\nname = \"a\"\nx-px = 0\ny-px = 0\nwidth-px = 1\nheight-px = 1\n"
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn capture_without_conditions_is_judged_on_percent_flicker() {
    let dir = scratch("judged-capture");
    // PF = 100 (100 - 60) / 160 = 25 % > 10 %: fails, although the
    // frequency is unknown and below the mitigation minimum is unknowable.
    let plan = csv_plan(&dir, "percent-flicker-max = 10.0", "");
    let (o, stdout) = run(&plan, &dir.join("out"));
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    let j = json(&dir.join("out"));
    let case = &j["cases"][0];
    assert_eq!(case["verdict"], "fail");
    let metrics: Vec<&str> = case["checks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["metric"].as_str().unwrap())
        .collect();
    assert_eq!(metrics, ["fdi_2018", "percent_flicker"]);
    assert!(
        stdout.contains("FAIL: percent_flicker 25.000 > 10 on a"),
        "{stdout}"
    );
    // Within the limit it passes: judged, exit 0.
    let plan = csv_plan(&dir, "percent-flicker-max = 30.0", "");
    let (o, stdout) = run(&plan, &dir.join("out2"));
    assert_eq!(o.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("overall: PASS (1 pass, 0 fail of 1 cases; 0 cases not judged)"));
}

#[test]
fn an_all_informative_run_never_reads_pass_and_exits_4() {
    let dir = scratch("not-judged");
    let plan = csv_plan(&dir, "percent-flicker-max = 30.0", "informative = true");
    let (o, stdout) = run(&plan, &dir.join("out"));
    assert_eq!(o.status.code(), Some(4), "{stdout}");
    assert!(stdout.contains("overall: NOT JUDGED"), "{stdout}");
    assert!(stdout.contains("1 case not judged"), "{stdout}");
    assert!(!stdout.contains("PASS"), "{stdout}");
    let j = json(&dir.join("out"));
    assert_eq!(j["verdict"], "info");
    assert!(
        j["cases"][0]["not_judged"]
            .as_str()
            .unwrap()
            .contains("informative")
    );
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(html.contains("No case was judged"));
    let junit = std::fs::read_to_string(dir.join("out/junit.xml")).unwrap();
    assert!(junit.contains("<skipped message=\"not judged: the plan marks"));
}

#[test]
fn threshold_errors_are_all_reported_with_keys_lines_and_hints() {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "fdi-2018-min = 0.1",
            "fdi-2018-min = 0.1\nfmi-max = 1.5\nmmp-min = -0.1\nfdi-p2020-mni = 0.9\n\
             [[thresholds.light-level]]\nlight-lux = 40.0\nfmi-max = 0.2\n\
             [[thresholds.light-level]]\nfdi-p2020-min = 2.0",
        );
    let err = plan::parse(&text, Path::new("t.toml"), String::new())
        .unwrap_err()
        .to_string();
    for needle in [
        "`thresholds.fmi-max`: 1.5 is outside [0, 1]",
        "`thresholds.mmp-min`: -0.1 is outside [0, 1]",
        "`thresholds.fdi-p2020-mni`: unknown key",
        "did you mean `fdi-p2020-min`?",
        "`thresholds.light-level[0].light-lux`: no case is at 40 lux",
        "the plan's light levels are: 2000",
        "`thresholds.light-level[1].light-lux`: missing required key",
        "`thresholds.light-level[1].fdi-p2020-min`: 2 is outside [0, 1]",
    ] {
        assert!(err.contains(needle), "`{needle}` not in:\n{err}");
    }
    assert!(err.contains("line"), "{err}");
}

#[test]
fn light_level_limits_apply_to_their_level_only() {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace("levels-lux = [2000.0]", "levels-lux = [40.0, 2000.0]")
        .replace(
            "mitigation-min-hz = 90.0",
            "mitigation-min-hz = 90.0\n[[thresholds.light-level]]\nlight-lux = 40.0\nfmi-max = 0.0\n",
        );
    let p =
        plan::parse(&text, Path::new("t.toml"), String::new()).unwrap_or_else(|e| panic!("{e}"));
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(1), &|_| {}).unwrap();
    for r in results.iter().filter(|r| r.verdict != Verdict::Info) {
        let fmi = r.checks.iter().find(|k| k.metric == "fmi");
        if r.case.light_lux == 40.0 {
            assert_eq!(fmi.unwrap().threshold, 0.0, "{}", r.case.id);
        } else {
            assert!(fmi.is_none(), "{}", r.case.id);
        }
    }
}

#[test]
fn simulated_report_names_its_camera_and_the_worst_phase_basis() {
    let p = plan::load(&root().join("test-plans/deegan2018.toml")).unwrap();
    let cases = plan::expand_cases(&p);
    let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
    let model = ledflicker::model::assemble(&p, "sim-physical", &results);
    assert!(
        model
            .method
            .acquisition
            .contains("physical camera simulator, camera `deegan2018-hdr3`"),
        "{}",
        model.method.acquisition
    );
    assert!(!model.method.acquisition.contains("ideal"));
    // deegan2018.toml asks for basis = "as-captured".
    assert!(model.method.verdict_basis.contains("as simulated"));
    let notes = &model.notes;
    assert!(
        notes
            .iter()
            .any(|n| n.contains("physical camera simulator"))
    );
    assert!(!notes.iter().any(|n| n.contains("ideal camera")));
    let daylight = plan::load(&root().join("test-plans/daylight.toml")).unwrap();
    let m = ledflicker::model::method::method(&daylight);
    assert!(m.verdict_basis.contains("worst case over PWM phase"));
    assert!(m.acquisition.contains("ideal camera simulator"));
    // The rig: its command, and judged as captured whatever the plan asks.
    let rig = plan::load(&root().join("test-plans/command-sim-rig.toml")).unwrap();
    let m = ledflicker::model::method::method(&rig);
    assert!(m.acquisition.contains("sim-rig.sh"), "{}", m.acquisition);
    assert!(
        m.verdict_basis.contains("as captured"),
        "{}",
        m.verdict_basis
    );
    assert!(!m.acquisition.contains("simulator"), "{}", m.acquisition);
}

#[test]
fn auto_exposure_target_keys_are_checked() {
    let profile =
        std::fs::read_to_string(root().join("reference-data/cameras/deegan2018-hdr3.toml"))
            .unwrap();
    let plan = std::fs::read_to_string(root().join("test-plans/deegan2018.toml")).unwrap();
    let dir = scratch("ae-keys");
    std::fs::write(
        dir.join("plan.toml"),
        plan.replace("../reference-data/cameras/deegan2018-hdr3.toml", "cam.toml"),
    )
    .unwrap();
    for (edit, needle) in [
        (
            "target-luma = 0.413\ntarget = 0.0003",
            "give target-luma or target, not both",
        ),
        ("target-luma = 1.5", "1.5 is outside (0, 1)"),
        ("target = 1.5", "must be below 1"),
    ] {
        std::fs::write(
            dir.join("cam.toml"),
            profile.replace("target-luma = 0.413", edit),
        )
        .unwrap();
        let err = plan::load(&dir.join("plan.toml")).unwrap_err().to_string();
        assert!(err.contains(needle) && err.contains("cam.toml"), "{err}");
    }
}

/// The Deegan 2018 profile's `target-luma = 0.413` is its old linear
/// `target = 0.0003` through the log tone curve: Table 1 moves by less than
/// the noise of one run.
#[test]
fn target_luma_reproduces_the_old_linear_target() {
    let profile =
        std::fs::read_to_string(root().join("reference-data/cameras/deegan2018-hdr3.toml"))
            .unwrap();
    let plan = std::fs::read_to_string(root().join("test-plans/deegan2018.toml")).unwrap();
    let dir = scratch("ae-legacy");
    std::fs::write(
        dir.join("plan.toml"),
        plan.replace("../reference-data/cameras/deegan2018-hdr3.toml", "cam.toml"),
    )
    .unwrap();
    let mut table = Vec::new();
    for edit in ["target-luma = 0.413", "target = 0.0003"] {
        std::fs::write(
            dir.join("cam.toml"),
            profile.replace("target-luma = 0.413", edit),
        )
        .unwrap();
        let p = plan::load(&dir.join("plan.toml")).unwrap();
        let cases = plan::expand_cases(&p);
        let results = runner::run(&p, &cases, &Simulator::new(&p), Some(2), &|_| {}).unwrap();
        let row: Vec<(f64, f64)> = results
            .iter()
            .map(|r| {
                (
                    r.metrics[0].fdi_2018.value.unwrap(),
                    r.metrics[0].percent_flicker.value.unwrap(),
                )
            })
            .collect();
        eprintln!("{edit}: (FDI, PF) at 60 and 150 Hz = {row:?}");
        table.push(row);
    }
    for (new, old) in table[0].iter().zip(&table[1]) {
        assert!((new.0 - old.0).abs() < 0.02, "FDI {new:?} vs {old:?}");
        assert!((new.1 - old.1).abs() < 1.0, "PF {new:?} vs {old:?}");
    }
}

#[test]
fn hdr_example_runs_to_finite_plausible_numbers() {
    let p =
        plan::load(&root().join("test-plans/hdr-example.toml")).unwrap_or_else(|e| panic!("{e}"));
    let cases = plan::expand_cases(&p);
    assert_eq!(cases.len(), 2 * 6 * 3);
    let results = runner::run(&p, &cases, &Simulator::new(&p), None, &|_| {}).unwrap();
    let full_scale = p.dut.camera.full_scale_dn;
    for r in &results {
        let (led, bg) = (&r.metrics[0], &r.metrics[1]);
        eprintln!(
            "{:<22} {:?} FDI {:>8.3} PF {:>6.2} FMI {:>6.3} bg OFF {:>6.1} DN",
            r.case.id,
            r.verdict,
            led.fdi_2018.value.unwrap_or(f64::NAN),
            led.percent_flicker.value.unwrap_or(f64::NAN),
            r.p2020[0].fmi.value.unwrap_or(f64::NAN),
            bg.levels.off.unwrap_or(f64::NAN)
        );
    }
    for r in &results {
        let led = &r.metrics[0];
        let pf = led.percent_flicker.value.unwrap();
        let fdi = led.fdi_2018.value.unwrap_or(f64::INFINITY);
        assert!(
            pf.is_finite() && (0.0..100.0).contains(&pf),
            "{} PF {pf}",
            r.case.id
        );
        assert!(
            !(fdi < -0.9 && pf > 90.0),
            "{}: FDI {fdi}, PF {pf}: the exposure loses the lamp",
            r.case.id
        );
        assert!(!led.saturated, "{}: the lamp clips the output", r.case.id);
        // Auto exposure puts the grey background near target-luma (0.46 of
        // full scale) in the OFF segment, where the lamp is dark.
        let bg = &r.metrics[1];
        let off = bg.levels.off.unwrap();
        assert!(
            (off / full_scale - 0.46).abs() < 0.05,
            "{}: background {off:.1} DN",
            r.case.id
        );
    }
    // More duty, more light: the lamp stands further above the OFF level.
    let fdi = |id: &str| {
        results.iter().find(|r| r.case.id == id).unwrap().metrics[0]
            .fdi_2018
            .value
            .unwrap()
    };
    for lux in [40, 2000] {
        assert!(fdi(&format!("{lux}lux-150hz-50pct")) > fdi(&format!("{lux}lux-150hz-10pct")));
    }
}

/// summary.csv's `failed` column lists failed checks of judged cases
/// only: daylight's cases below the mitigation boundary miss the FDI
/// limit but were not judged, so they failed nothing.
#[test]
fn summary_csv_names_no_failure_for_a_case_that_was_not_judged() {
    let dir = scratch("summary-info");
    let out = dir.join("out");
    let o = crate::ledflicker(&["plan", "daylight", "-q", "--out", out.to_str().unwrap()]);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{}",
        crate::text(&o)
    );
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (verdict, failed) = (at("verdict"), at("failed"));
    assert_eq!(failed, header.len() - 1);
    let mut info = 0;
    for line in lines {
        let fields: Vec<&str> = line.split(',').collect();
        if fields[verdict] == "info" {
            info += 1;
            assert!(fields[failed..].join(",").is_empty(), "{line}");
        }
    }
    // The test means something only if some unjudged case does miss a
    // limit (its checks in results.json say so).
    let j: Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let missed = j["cases"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["verdict"] == "info")
        .filter(|c| {
            c["checks"]
                .as_array()
                .unwrap()
                .iter()
                .any(|k| k["pass"] == false)
        })
        .count();
    assert!(
        info > 0 && missed > 0,
        "info rows {info}, unjudged cases missing a limit {missed}"
    );
}

/// A run of more than 50 cases lists its failing cases only (at most 50)
/// and says how to see the rest; `--all-cases` lists every case.
#[test]
fn a_large_run_lists_its_failing_cases_only_unless_asked() {
    let dir = scratch("summary-rows");
    let grid = std::fs::read_to_string(root().join("test-plans/grid-192.toml")).unwrap();
    // A 5 ms exposure loses the LED at low duty: some cases fail.
    let short_exposure = grid.replace("exposure-ms = 11.111", "exposure-ms = 5.0");
    assert_ne!(short_exposure, grid);
    let run = |name: &str, text: &str, extra: &[&str]| {
        let plan = dir.join(format!("{name}.toml"));
        std::fs::write(&plan, text).unwrap();
        let mut args = vec!["plan", plan.to_str().unwrap(), "--out", name, "--no-db"];
        args.extend_from_slice(extra);
        let o = crate::ledflicker_in(&args, &dir);
        let out = String::from_utf8(o.stdout).unwrap();
        let rows: Vec<String> = out
            .lines()
            .filter(|l| l.contains("lux-"))
            .map(str::to_string)
            .collect();
        (o.status.code(), rows, out)
    };
    let (code, rows, out) = run("pass", &grid, &[]);
    assert_eq!(code, Some(0), "{out}");
    assert!(rows.is_empty(), "{out}");
    assert!(
        out.contains("(192 cases not listed: every case is in summary.csv"),
        "{out}"
    );
    let (_, rows, out) = run("pass-all", &grid, &["--all-cases"]);
    assert_eq!(rows.len(), 192, "{out}");
    assert!(!out.contains("not listed"), "{out}");
    let (code, rows, out) = run("fail", &short_exposure, &[]);
    assert_eq!(code, Some(1), "{out}");
    assert!(!rows.is_empty() && rows.len() <= 50, "{}", rows.len());
    assert!(
        rows.iter()
            .all(|r| r.split_whitespace().nth(1) == Some("fail")),
        "{out}"
    );
    let fails = out
        .lines()
        .find_map(|l| l.strip_prefix("overall: FAIL ("))
        .and_then(|l| l.split(" pass, ").nth(1))
        .and_then(|l| l.split(' ').next())
        .and_then(|n| n.parse::<usize>().ok())
        .unwrap();
    assert_eq!(rows.len(), fails.min(50), "{out}");
    // 32 fail at 5 ms, all listed: no "of them failing".
    assert!(
        out.contains(&format!(
            "({} more cases not listed: every case",
            192 - rows.len()
        )),
        "{out}"
    );
    // At 1 ms more than 50 cases fail: the line says how many of those
    // left out fail too.
    let many = grid.replace("exposure-ms = 11.111", "exposure-ms = 1.0");
    let (code, rows, out) = run("many", &many, &[]);
    assert_eq!(code, Some(1), "{out}");
    assert_eq!(rows.len(), 50, "{out}");
    assert!(out.contains("(142 more cases not listed, "), "{out}");
    assert!(out.contains(" of them failing: every case"), "{out}");
}
