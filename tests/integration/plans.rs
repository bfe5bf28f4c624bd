//! Plan loading: the shipped plans are valid, bad plans fail with every
//! error located, and the documented example stays in step with the code.

use ledflicker::plan;

use crate::root;

#[test]
fn shipped_plans_are_valid() {
    let mut n = 0;
    for entry in std::fs::read_dir(root().join("test-plans")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let p = plan::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(!plan::expand_cases(&p).is_empty());
            n += 1;
        }
    }
    assert!(n >= 2);
}

#[test]
fn daylight_plan_covers_the_issue_grid() {
    let p = plan::load(&root().join("test-plans/daylight.toml")).unwrap();
    assert_eq!(p.light_levels_lux, vec![2000.0]);
    assert!(p.frequencies_hz.len() >= 6);
    assert!(
        p.frequencies_hz
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
            <= 50.0
    );
    assert!(p.frequencies_hz.iter().cloned().fold(0.0, f64::max) >= 1000.0);
    assert!(p.duty_cycles.len() >= 4);
    assert!(p.duty_cycles.contains(&0.05) && p.duty_cycles.contains(&1.0));
    let low = plan::load(&root().join("test-plans/lowlight.toml")).unwrap();
    assert_eq!(low.light_levels_lux, vec![40.0]);
}

#[test]
fn invalid_plans_report_every_error_with_its_line() {
    let dir = root().join("tests/fixtures/plans");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("err_") && n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 9, "fixtures in {}: {names:?}", dir.display());
    for name in names {
        let rel = std::path::PathBuf::from("tests/fixtures/plans").join(&name);
        let err = plan::load(&rel).expect_err("fixture must be invalid");
        insta::with_settings!({ snapshot_suffix => name.as_str(), input_file => &rel }, {
            insta::assert_snapshot!(err.to_string());
        });
    }
}

#[test]
fn out_of_range_plan_lists_all_problems_at_once() {
    let err = plan::load(std::path::Path::new(
        "tests/fixtures/plans/err_out_of_range.toml",
    ))
    .unwrap_err();
    match err {
        plan::PlanError::Invalid { diagnostics, .. } => {
            let keys: Vec<&str> = diagnostics.iter().map(|d| d.key.as_str()).collect();
            for k in [
                "grid.duty-cycles[1]",
                "grid.duty-cycles[2]",
                "grid.frequencies-hz[1]",
                "grid.frequencies-hz[2]",
                "light.levels-lux",
                "sequence.pwm-s",
                "dut.camera.exposure-ms",
                "scene.background-reflectance",
            ] {
                assert!(keys.contains(&k), "missing {k} in {keys:?}");
            }
            assert!(
                diagnostics
                    .iter()
                    .all(|d| d.location.is_some() && d.hint.is_some())
            );
        }
        other => panic!("expected a validation error, got {other}"),
    }
}

#[test]
fn roi_outside_the_sensor_is_rejected() {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml")).unwrap()
        + "\n[[roi]]\nname = \"edge\"\nx-px = 1200\ny-px = 10\n";
    let err = plan::parse(&text, std::path::Path::new("inline.toml"), String::new()).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("roi[0].x-px") && text.contains("outside the sensor"),
        "{text}"
    );
}

/// The full example in docs/plan-format.md must be a valid plan that uses
/// no unknown key.
#[test]
fn documented_example_plan_is_valid() {
    let doc = std::fs::read_to_string(root().join("docs/plan-format.md")).unwrap();
    let start = doc
        .find("```toml\n")
        .expect("docs/plan-format.md has a ```toml block")
        + 8;
    let end = start + doc[start..].find("```").unwrap();
    let p = plan::parse(
        &doc[start..end],
        std::path::Path::new("docs/plan-format.md"),
        String::new(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.id, "example");
}

#[test]
fn ranges_expand_by_index_and_include_the_stop() {
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            "frequency-range-hz = { start = 50.0, stop = 84.9, step = 0.1 }",
        )
        .replace("duty-cycles = [0.2, 0.5]", "duty-cycles = [0.5]");
    // 350 cases; the work limits are off, as this checks the grid only.
    let p = plan::parse_within(
        &text,
        std::path::Path::new("inline.toml"),
        String::new(),
        false,
    )
    .unwrap();
    assert_eq!(p.frequencies_hz.len(), 350);
    assert_eq!(*p.frequencies_hz.last().unwrap(), 50.0 + 349.0 * 0.1);
    assert!((p.frequencies_hz[349] - 84.9).abs() < 1e-9);
}

/// A plan of one line of megabytes: `validate` quotes a window of the line
/// around the error (and cuts long messages), so its stderr stays a few
/// lines, whatever the error.
#[test]
fn a_one_line_plan_of_megabytes_gets_a_short_error() {
    let dir = crate::scratch("one-line-plan");
    let pad = "x".repeat(4 << 20);
    let plans = [
        // A syntax error at the end of the line.
        (
            "syntax",
            format!("plan = {{ id = \"a\", title = \"{pad}\", seed = }}"),
        ),
        // A type error whose span is the whole 4 MB string.
        (
            "type",
            format!("plan = {{ id = \"a\", title = \"t\", seed = \"{pad}\" }}"),
        ),
        // An unknown key of 4 MB.
        (
            "unknown",
            format!("plan = {{ id = \"a\", title = \"t\", {pad} = 1 }}"),
        ),
        // A ROI name of 4 MB.
        (
            "name",
            format!("roi = [{{ name = \"{pad}-\", x-px = 0, y-px = 0 }}]"),
        ),
    ];
    for (what, text) in plans {
        let path = dir.join(format!("{what}.toml"));
        std::fs::write(&path, &text).unwrap();
        let o = crate::ledflicker(&["validate", path.to_str().unwrap()]);
        let err = crate::stderr(&o);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{what}: {}",
            &err[..err.len().min(2000)]
        );
        assert!(
            err.len() < 4096,
            "{what}: {} bytes of stderr: {}",
            err.len(),
            &err[..err.len().min(2000)]
        );
    }
}

/// Under a short line the error shows the whole line and a caret under
/// the error column; under a long one, 120 characters around it.
#[test]
fn a_syntax_error_shows_a_window_of_its_line() {
    let long = format!(
        "plan = {{ id = \"a\", title = \"{}\", seed = }}",
        "y".repeat(500)
    );
    let err = plan::parse(&long, std::path::Path::new("long.toml"), String::new())
        .unwrap_err()
        .to_string();
    let lines: Vec<&str> = err.lines().collect();
    let shown = lines.iter().find(|l| l.starts_with("1 | ")).unwrap();
    let carets = lines.iter().find(|l| l.contains('^')).unwrap();
    assert!(
        shown.starts_with("1 | ...y") && shown.ends_with("seed = }"),
        "{err}"
    );
    assert!(shown.chars().count() <= 4 + 3 + 120, "{err}");
    // The caret stands under the character at the error column.
    let at = carets.find('^').unwrap();
    assert_eq!(&shown[at..at + 1], "}", "{err}");
    assert!(
        err.contains(&format!("line 1, column {}\n", long.len())),
        "{err}"
    );
}

/// A captured case's conditions have the grid's ranges: a frequency needs
/// one period in `[sequence] pwm-s`, and light levels and duty cycles
/// their lower bounds (docs/plan-format.md, "Limits").
#[test]
fn captured_case_conditions_have_the_grid_ranges() {
    let text = "[plan]\nid = \"c\"\ntitle = \"c\"\n[sequence]\npwm-s = 10.0\n\
        [dut]\nbackend = \"captured\"\n[[roi]]\nname = \"led\"\nx-px = 0\ny-px = 0\n\
        [[case]]\nsource = \"capture_led.csv\"\nlight-lux = 5e-324\nfrequency-hz = 0.05\nduty-cycle = 1e-9\n";
    let path = root().join("tests/fixtures/plans/inline.toml");
    let err = plan::parse(text, &path, String::new())
        .unwrap_err()
        .to_string();
    for key in [
        "case[0].light-lux",
        "case[0].frequency-hz",
        "case[0].duty-cycle",
    ] {
        assert!(err.contains(&format!("`{key}`: ")), "{key}: {err}");
    }
    assert!(err.contains("0.05 Hz is below the 0.1 Hz limit"), "{err}");
    // At one period in the segment the case validates.
    let ok = text
        .replace("5e-324", "40.0")
        .replace("0.05", "0.1")
        .replace("1e-9", "0.2");
    plan::parse(&ok, &path, String::new()).unwrap_or_else(|e| panic!("{e}"));
}

/// A binary away from its source tree runs the shipped plans by name: the
/// plan and the camera profile it names come from the copies built in, and
/// the report lists them as such, with the hashes of the source tree's
/// files.
#[test]
fn shipped_plans_run_by_name_from_an_empty_directory() {
    let dir = super::scratch("built-in-plans");
    let ran = super::ledflicker_in(&["validate", "deegan2018"], &dir);
    assert!(ran.status.success(), "{}", super::stderr(&ran));
    assert!(
        super::text(&ran).contains("(test-plans/deegan2018.toml (built in))"),
        "{}",
        super::text(&ran)
    );
    let ran = super::ledflicker_in(&["plan", "deegan2018", "--out", "out", "-q"], &dir);
    assert!(
        matches!(ran.status.code(), Some(0 | 1)),
        "{}",
        super::stderr(&ran)
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/results.json")).unwrap())
            .unwrap();
    let inputs = results["report"]["inputs"].as_array().unwrap();
    let sha = |path: &str| {
        let bytes = std::fs::read(super::root().join(path)).unwrap();
        ledflicker::util::sha256_hex(&bytes)
    };
    for (role, path) in [
        ("plan", "test-plans/deegan2018.toml"),
        (
            "camera-profile",
            "reference-data/cameras/deegan2018-hdr3.toml",
        ),
    ] {
        let input = inputs
            .iter()
            .find(|i| i["role"] == role)
            .unwrap_or_else(|| panic!("no {role} in {inputs:?}"));
        assert_eq!(input["path"], format!("{path} (built in)"));
        assert_eq!(input["sha256"], sha(path));
    }
    // A shipped rig plan runs its script from the plan's folder, which is
    // not there.
    let ran = super::ledflicker_in(&["plan", "command-sim-rig", "--out", "rig", "-q"], &dir);
    assert_eq!(ran.status.code(), Some(3));
    let err = super::stderr(&ran);
    assert!(
        err.contains("the rig runs in the plan's folder `test-plans`"),
        "{err}"
    );
    // A local file of that name is the plan, not the built-in copy.
    std::fs::create_dir(dir.join("test-plans")).unwrap();
    let mine = std::fs::read_to_string(super::root().join("test-plans/daylight.toml"))
        .unwrap()
        .replace("id = \"daylight\"", "id = \"my-daylight\"");
    std::fs::write(dir.join("test-plans/daylight.toml"), mine).unwrap();
    let ran = super::ledflicker_in(&["validate", "daylight"], &dir);
    assert!(super::text(&ran).contains("plan `my-daylight` (test-plans/daylight.toml)"));
    let ran = super::ledflicker_in(&["validate", "no-such-plan"], &dir);
    assert_eq!(ran.status.code(), Some(2));
    assert!(
        super::stderr(&ran).contains("the built-in plans"),
        "{}",
        super::stderr(&ran)
    );
}

/// The files of a report directory whose text a built-in run and a run of
/// the checkout's file share, but for the built-in inputs' label; the
/// PDF (compressed text) and the case store (binary) are left out.
fn report_texts(dir: &std::path::Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            let name = path.strip_prefix(dir).unwrap().display().to_string();
            if path.is_dir() {
                stack.push(path);
            } else if !matches!(name.as_str(), "report.pdf" | "cases.sqlite")
                && !name.ends_with(".png")
            {
                let text = std::fs::read_to_string(&path).unwrap();
                out.push((name, text.replace(" (built in)", "")));
            }
        }
    }
    out.sort();
    out
}

/// An installed binary, run where no checkout is (a temporary directory
/// outside the source tree), gives the outputs of the checkout's own
/// files: the simulated daylight plan, the P2020 sample videos (built
/// into the binary), and `calibrate` on a frame named by its path. Only
/// the inputs' label "(built in)" differs, and the PNGs byte for byte.
#[test]
fn built_in_plans_and_calibrate_away_from_the_checkout_give_the_checkouts_outputs() {
    assert!(
        ledflicker::capture::ffmpeg_available(),
        "ffmpeg/ffprobe not found: run scripts/test.sh, which installs them"
    );
    let away = tempfile::tempdir().unwrap();
    let here = super::scratch("checkout-runs");
    for name in ["daylight", "p2020-samples"] {
        let common = ["--date", "2026-01-01", "-q", "--threads", "2", "--out"];
        let plan_file = format!("test-plans/{name}.toml");
        let mut args = vec!["plan", name];
        args.extend(common);
        args.push("out");
        let built_in = super::ledflicker_in(&args, away.path());
        let out = here.join(name);
        let mut args = vec!["plan", plan_file.as_str()];
        args.extend(common);
        args.push(out.to_str().unwrap());
        let checkout = super::ledflicker(&args);
        assert_eq!(
            built_in.status.code(),
            checkout.status.code(),
            "{name}: {}{}",
            super::stderr(&built_in),
            super::stderr(&checkout)
        );
        assert!(matches!(checkout.status.code(), Some(0 | 1)), "{name}");
        let (a, b) = (report_texts(&away.path().join("out")), report_texts(&out));
        assert!(a.len() > 5, "{name}: {a:?}");
        let names = |v: &[(String, String)]| v.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
        assert_eq!(names(&a), names(&b), "{name}");
        for ((file, x), (_, y)) in a.iter().zip(&b) {
            assert!(x == y, "{name}: {file} differs away from the checkout");
        }
        let results = std::fs::read_to_string(away.path().join("out/results.json")).unwrap();
        assert!(results.contains(&format!("test-plans/{name}.toml (built in)")));
        for png in ["charts", "frames"].map(|d| away.path().join("out").join(d)) {
            for entry in std::fs::read_dir(&png).into_iter().flatten() {
                let p = entry.unwrap().path();
                let rel = p.strip_prefix(away.path().join("out")).unwrap();
                assert_eq!(
                    std::fs::read(&p).unwrap(),
                    std::fs::read(out.join(rel)).unwrap()
                );
            }
        }
        std::fs::remove_dir_all(away.path().join("out")).unwrap();
    }
    let frame = root().join("reference-data/gyroflow-rs-banding/frame_example.png");
    let args = [
        "calibrate",
        frame.to_str().unwrap(),
        "--frequency-hz",
        "1000",
        "--duty",
        "0.5",
        "--json",
        "--out",
    ];
    let profile = |dir: &std::path::Path| {
        let mut a = args.to_vec();
        let out = dir.join("profile.toml");
        a.push(out.to_str().unwrap());
        let ran = super::ledflicker_in(&a, dir);
        assert!(ran.status.success(), "{}", super::stderr(&ran));
        let written = std::fs::read_to_string(&out).unwrap();
        (
            String::from_utf8(ran.stdout).unwrap(),
            written.replace(dir.to_str().unwrap(), "DIR"),
        )
    };
    let (a, b) = (profile(away.path()), profile(&here));
    assert!(a.0.contains("line_time"), "{}", a.0);
    assert_eq!(
        a.0.replace(away.path().to_str().unwrap(), "DIR"),
        b.0.replace(here.to_str().unwrap(), "DIR")
    );
    assert_eq!(a.1, b.1);
}
