//! The binary: exit codes, outputs, messages.

use std::process::Command;

use crate::{ledflicker, mkfifo, root, run_with_deadline, scratch, stderr};

/// Far longer than refusing an input takes; a run still going then waits
/// on it.
const WAIT_AT_MOST: std::time::Duration = std::time::Duration::from_secs(20);

#[test]
fn validate_accepts_shipped_plans_by_path_and_by_name() {
    for arg in [
        "test-plans/daylight.toml",
        "daylight",
        "daylight.toml",
        "lowlight",
    ] {
        let o = ledflicker(&["validate", arg]);
        assert_eq!(o.status.code(), Some(0), "{arg}: {}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains("is valid"));
    }
}

#[test]
fn bare_plan_name_is_found_from_another_directory() {
    let dir = scratch("bare-name");
    let o = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["validate", "lowlight"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn invalid_plan_exits_2_with_key_line_and_hint() {
    let o = ledflicker(&["validate", "tests/fixtures/plans/err_out_of_range.toml"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.starts_with("error: invalid test plan `tests/fixtures/plans/err_out_of_range.toml`"),
        "{e}"
    );
    assert!(
        e.contains("grid.duty-cycles[1]") && e.contains("line 15") && e.contains("hint:"),
        "{e}"
    );
}

#[test]
fn missing_plan_exits_2() {
    let o = ledflicker(&["plan", "no-such-plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not found"), "{}", stderr(&o));
    let o = ledflicker(&["validate", "nowhere/plan.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nowhere/plan.toml"));
}

#[test]
fn bad_usage_exits_2() {
    assert_eq!(ledflicker(&["plan"]).status.code(), Some(2));
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "100",
        "--duty",
        "1.5",
        "--exposure-ms",
        "1",
        "--fps",
        "30",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("duty"), "{}", stderr(&o));
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "100",
        "--duty",
        "0.5",
        "--exposure-ms",
        "1",
        "--fps",
        "30",
        "--rows",
        "5:5",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn plan_run_writes_results_traces_and_report() {
    let out = scratch("plan-run");
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        out.to_str().unwrap(),
        "--date",
        "2026-01-02",
        "--detail",
        "full",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("overall: PASS") && stdout.contains("2000lux-150hz-20pct"),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["cases"].as_array().unwrap().len(), 4);
    let csv = std::fs::read_to_string(out.join("traces/2000lux-60hz-20pct.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("frame,time_s,segment,led"));
    // 0.5 s ON + 0.5 s OFF + 4 s PWM at 30 fps.
    assert_eq!(lines.clone().count(), 150);
    let segments: Vec<&str> = lines.map(|l| l.split(',').nth(2).unwrap()).collect();
    assert_eq!(segments.iter().filter(|s| **s == "on").count(), 15);
    assert_eq!(segments.iter().filter(|s| **s == "off").count(), 15);
    assert_eq!(segments.iter().filter(|s| **s == "pwm").count(), 120);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("2026-01-02") && html.contains("<svg"));
    // The darkest PWM frame of each case, as a PNG file and inline.
    let png = image::open(out.join("frames/2000lux-150hz-20pct.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1280, 800));
    // Beside them, the frame at the worst phase of each case that fails
    // on a worst phase its trace does not show.
    let worst = json["cases"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c.get("worst_phase").is_some())
        .count();
    // And the ROI map of the method's set-up: the first case's frame.
    let roi_maps = html.matches("<figcaption>ROIs on frame").count();
    assert_eq!(roi_maps, 1);
    assert_eq!(
        html.matches("data:image/png;base64,").count(),
        4 + worst + roi_maps
    );
    assert_eq!(
        json["cases"][0]["sample_frame"]["path"],
        "frames/2000lux-60hz-20pct.png"
    );
    // No temporary files are left behind; `.ledflicker` marks the report
    // as ledflicker's.
    for e in std::fs::read_dir(&out).unwrap() {
        let name = e.unwrap().file_name();
        let name = name.to_string_lossy();
        assert!(!name.starts_with('.') || name == ".ledflicker", "{name:?}");
    }
}

#[test]
fn failing_case_exits_1() {
    let out = scratch("plan-fail");
    let plan = out.join("strict.toml");
    let text = std::fs::read_to_string(root().join("tests/fixtures/plans/base.toml"))
        .unwrap()
        .replace(
            "fdi-2018-min = 0.1",
            "fdi-2018-min = 0.1\npercent-flicker-max = 1.0",
        );
    std::fs::write(&plan, text).unwrap();
    let o = ledflicker(&[
        "plan",
        plan.to_str().unwrap(),
        "--out",
        out.join("r").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("overall: FAIL"));
}

#[test]
fn signed_report_is_not_overwritten_without_force() {
    let out = scratch("signed");
    // A signed earlier report: `plan` replaces only reports it wrote,
    // recognised here by results.json's schema.
    let earlier = r#"{"schema": "ledflicker.results/3"}"#;
    std::fs::write(out.join("results.json"), earlier).unwrap();
    std::fs::write(out.join("signoff.json"), "{}").unwrap();
    let args = [
        "plan",
        "tests/fixtures/plans/base.toml",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = ledflicker(&args);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        earlier
    );
    let o = ledflicker(&[&args[..], &["--force"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        earlier
    );
    assert!(!out.join("signoff.json").exists());
}

#[test]
fn same_plan_gives_identical_files_whatever_the_threads() {
    let a = scratch("det-a");
    let b = scratch("det-b");
    for (dir, threads) in [(&a, "1"), (&b, "3")] {
        let o = ledflicker(&[
            "plan",
            "daylight",
            "--out",
            dir.to_str().unwrap(),
            "--threads",
            threads,
            "--date",
            "2026-01-01",
            "-q",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    for f in [
        "results.json",
        "report.html",
        "traces/2000lux-100hz-5pct.csv",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn simulate_prints_a_csv_with_frame_and_on_fraction() {
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "90",
        "--duty",
        "0.5",
        "--exposure-ms",
        "5",
        "--fps",
        "30",
        "--frames",
        "3",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let s = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = s.lines().collect();
    assert_eq!(lines[0], "frame,time_s,on_fraction");
    assert_eq!(lines.len(), 4);
    // 5 ms from a rising edge at 90 Hz (period 11.1 ms, ON 5.56 ms): all ON.
    assert_eq!(lines[1], "0,0,1");
}

#[test]
fn simulate_summary_prints_one_json_object_with_results_names() {
    // 91.5 Hz at 30 fps: f_a = 1.5 Hz; a 2 ms exposure fits in the OFF gap
    // of a 10 % duty PWM, so the LED vanishes at its worst phase.
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "91.5",
        "--duty",
        "0.1",
        "--exposure-ms",
        "2",
        "--fps",
        "30",
        "--frames",
        "600",
        "--background",
        "0.1",
        "--summary",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in [
        "fdi_2018",
        "percent_flicker",
        "fdi_2018_worst_phase",
        "percent_flicker_worst_phase",
        "apparent_frequency_hz",
    ] {
        assert!(v["metrics"][key].is_number(), "{key}: {v}");
    }
    assert!((v["apparent_frequency_hz"].as_f64().unwrap() - 1.5).abs() < 1e-12);
    assert_eq!(v["hazard_class"], "turn-indicator-like");
    assert!(v["metrics"]["fdi_2018_worst_phase"].as_f64().unwrap().abs() < 1e-12);
    assert_eq!(v["drive"]["ieee1789_region"], "elevated-risk");
    // Phase locked: steady, with a coverage warning that says why.
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "90",
        "--duty",
        "0.5",
        "--exposure-ms",
        "3",
        "--fps",
        "30",
        "--summary",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["apparent_frequency_hz"], 0.0);
    assert_eq!(v["hazard_class"], "steady");
    assert!(v["beat"]["note"].as_str().unwrap().contains("phase locked"));
    assert!(
        v["reasons"]["phase_coverage"]
            .as_str()
            .unwrap()
            .contains("phase lock")
    );
    // No background: FDI is null with its reason, never NaN.
    let o = ledflicker(&[
        "simulate",
        "--frequency-hz",
        "100",
        "--duty",
        "0.5",
        "--exposure-ms",
        "3",
        "--fps",
        "30",
        "--summary",
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(!text.contains("NaN"));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["metrics"]["fdi_2018"].is_null() && v["reasons"]["fdi_2018"].is_string());
    assert!(v["colour"].is_null());
    // Colour: an RGB LED with unequal die duties shifts hue with phase; a
    // white LED on a grey background does not.
    let colour = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec![
            "simulate",
            "--frequency-hz",
            "151",
            "--duty",
            "0.3",
            "--exposure-ms",
            "3",
            "--fps",
            "30",
            "--background",
            "0.05",
            "--summary",
        ];
        args.extend_from_slice(extra);
        let o = ledflicker(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["colour"].clone()
    };
    let c = colour(&["--rgb-duty", "0.3,0.5,0.2"]);
    assert!(c["chroma_shift"].as_f64().unwrap() > 0.05, "{c}");
    assert!(c["hue_shift_deg"].as_f64().unwrap() > 1.0, "{c}");
    let c = colour(&["--led-rgb", "1,1,1"]);
    assert!(c["chroma_shift"].as_f64().unwrap() < 1e-12, "{c}");
    assert!(c["hue_shift_deg"].is_null(), "{c}");
}

#[test]
fn advise_prints_the_eq1_bound_and_writes_a_plot() {
    let dir = scratch("advise");
    let svg = dir.join("advise.svg");
    let o = ledflicker(&[
        "advise",
        "--min-hz",
        "90",
        "--max-hz",
        "1000",
        "--min-duty",
        "0.1",
        "--hz-step",
        "10",
        "--duty-step",
        "0.05",
        "--speed-px-per-s",
        "500",
        "--hdr-ratio",
        "4",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    // (1 - 0.1) / 90 Hz = 10 ms.
    assert!(out.contains("= 10.0000 ms"), "{out}");
    assert!(out.contains("HDR short"), "{out}");
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.contains("DejaVu Sans"));
    let o = ledflicker(&[
        "advise",
        "--min-hz",
        "100",
        "--max-hz",
        "90",
        "--min-duty",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn bands_estimates_the_frequency_of_a_rendered_frame() {
    // Render a 600-row frame of a 700 Hz, 30 % PWM with 20 us lines (closed
    // form per row, 16-bit) and read the frequency back from the bands.
    use ledflicker::analysis::banding::row_profile;
    use ledflicker::physics::{PwmDrive, Shutter, ShutterModel};
    let shutter = Shutter {
        model: ShutterModel::Rolling { line_time_s: 20e-6 },
        exposure_s: 1e-4,
        fps: 30.0,
    };
    let pwm = PwmDrive::new(700.0, 0.3, 0.0).unwrap();
    let rows = row_profile(&shutter, &pwm, 0, 600);
    let img = image::ImageBuffer::from_fn(64, 600, |_, y| {
        image::Luma([(1000.0 + 60000.0 * rows[y as usize]) as u16])
    });
    let dir = scratch("bands");
    let path = dir.join("frame.png");
    img.save(&path).unwrap();
    let o = ledflicker(&["bands", path.to_str().unwrap(), "--line-time-us", "20"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = v["estimated_frequency_hz"].as_f64().unwrap();
    assert!((f - 700.0).abs() < 1.0, "{f}");
}

#[test]
fn a_report_rerun_in_place_links_its_unchanged_files_and_never_a_users_copy() {
    use std::os::unix::fs::MetadataExt;
    let root_dir = scratch("rerun-in-place");
    let out = root_dir.join("report");
    let run = |plan: &str, out: &std::path::Path| {
        let o = ledflicker(&[
            "plan",
            plan,
            "--out",
            out.to_str().unwrap(),
            "-q",
            "--force",
            "--date",
            "2026-01-02",
        ]);
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    };
    let base = "tests/fixtures/plans/base.toml";
    run(base, &out);
    // What a run writes at the top is what the output folder rules call
    // the report's own names (a user's entry of such a name is refused).
    let mut written: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != ledflicker::outdir::MARKER)
        .collect();
    written.sort();
    // All of them but profile/, which only a report profile's logo or
    // templates make.
    let mut names = ledflicker::outdir::REPORT_ENTRIES.to_vec();
    names.retain(|n| *n != "profile");
    names.sort();
    assert_eq!(written, names);
    let traces: Vec<std::path::PathBuf> = std::fs::read_dir(out.join("traces"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(traces.len() >= 2, "{traces:?}");
    let inode = |p: &std::path::Path| std::fs::metadata(p).unwrap().ino();
    let before: Vec<u64> = traces.iter().map(|p| inode(p)).collect();
    // A user keeps a hard-linked copy of one trace.
    let copy = root_dir.join("kept.csv");
    std::fs::hard_link(&traces[0], &copy).unwrap();
    let kept = std::fs::read(&copy).unwrap();

    run(base, &out);
    // Unchanged traces are the same files; the one the user also holds was
    // written anew, and the user's copy is intact.
    assert_ne!(inode(&traces[0]), before[0]);
    assert_eq!(inode(&copy), before[0]);
    assert_eq!(std::fs::read(&copy).unwrap(), kept);
    assert_eq!(std::fs::read(&traces[0]).unwrap(), kept);
    for (path, ino) in traces.iter().zip(&before).skip(1) {
        assert_eq!(inode(path), *ino, "{}", path.display());
        assert_eq!(std::fs::metadata(path).unwrap().nlink(), 1);
    }

    // Another plan of the same cases (other limits: other verdicts and
    // charts) over the same directory gives what it gives in a new one.
    let tree = |dir: &std::path::Path| {
        let mut files = Vec::new();
        for sub in ["traces", "charts", "frames"] {
            for e in std::fs::read_dir(dir.join(sub)).unwrap() {
                let p = e.unwrap().path();
                files.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
        files.sort();
        files
    };
    let first_charts = tree(&out);
    let failing = "tests/fixtures/plans/small_failing.toml";
    run(failing, &out);
    let fresh = root_dir.join("fresh");
    run(failing, &fresh);
    let (over, anew) = (tree(&out), tree(&fresh));
    assert_eq!(over.len(), anew.len());
    for ((p, a), (q, b)) in over.iter().zip(&anew) {
        assert_eq!(p, q);
        assert!(
            a == b,
            "{} differs from the same file written anew",
            p.display()
        );
    }
    // The second plan changed some files and kept others.
    let changed = over
        .iter()
        .zip(&first_charts)
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > 0 && changed < over.len(),
        "{changed} of {} changed",
        over.len()
    );
}

/// Runs the binary with its standard output a pipe whose reader is gone
/// before the first line is written (`ledflicker ... | head -c 0`).
fn with_closed_stdout(args: &[&str]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(args)
        .current_dir(root())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn a_reader_that_closes_the_pipe_ends_the_output_not_the_command() {
    let dir = scratch("epipe");
    let out = dir.join("report");
    let report = out.to_str().unwrap();
    let o = ledflicker(&["plan", "daylight", "--out", report, "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let many_frames = [
        "simulate",
        "--frequency-hz",
        "90",
        "--duty",
        "0.5",
        "--exposure-ms",
        "5",
        "--fps",
        "30",
        "--frames",
        "100000",
    ];
    for args in [
        &["validate", "daylight"][..],
        &["verify", report][..],
        &many_frames[..],
        &["plan", "daylight", "--out", report, "--force"][..],
    ] {
        let closed = with_closed_stdout(args);
        let open = ledflicker(args);
        // The exit code is the command's own, never a panic's (101) nor a
        // write error's (3): `verify | head` must still say "not verified".
        assert_eq!(closed.status.code(), open.status.code(), "{args:?}");
        assert!(
            matches!(open.status.code(), Some(0 | 1 | 4)),
            "{args:?}: {}",
            stderr(&open)
        );
        let err = stderr(&closed);
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe"),
            "{args:?}: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Seconds of the "write report" span of `plan --timings` on stderr.
fn report_stage(timings: &str) -> f64 {
    // The first figure after the name; the peak memory may follow it.
    let rest = timings
        .lines()
        .find_map(|l| l.strip_prefix("    write report "))
        .unwrap_or_else(|| panic!("no `write report` in: {timings}"));
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn ctrl_c_in_the_report_stage_stops_at_once_and_keeps_the_old_report() {
    let dir = scratch("pdf-sigint");
    let out = dir.join("o");
    let o_arg = out.to_str().unwrap();
    // grid-192 at full detail, the longest report: first run whole, for
    // the old report and for how long its report stage (PDF layout beside
    // the other renderers) takes on this machine now.
    let full = ["plan", "grid-192", "-q", "--detail", "full", "--out", o_arg];
    let o = ledflicker(&[&full[..], &["--timings"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report_s = report_stage(&stderr(&o));
    let before = std::fs::read(out.join("results.json")).unwrap();
    let mut run = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(full)
        .current_dir(root())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    // The stages before the report's vary more than the report stage on
    // a loaded machine, so the signal is timed from the first picture the
    // report stage writes (charts/, built aside as `.charts.tmp-PID`), a
    // third of the way into the stage.
    let staging = dir.join(format!(".o.ledflicker-new-{}", run.id()));
    let drawing = || {
        std::fs::read_dir(&staging).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| e.file_name().to_string_lossy().contains("charts"))
        })
    };
    while !drawing() {
        assert!(
            run.try_wait().unwrap().is_none() && start.elapsed().as_secs() < 300,
            "the report stage never began"
        );
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    std::thread::sleep(std::time::Duration::from_secs_f64(report_s / 3.0));
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(run.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let signalled = std::time::Instant::now();
    let status = loop {
        if let Some(status) = run.try_wait().unwrap() {
            break status;
        }
        assert!(
            signalled.elapsed().as_secs() < 60,
            "no stop within 60 s of SIGINT"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let took = signalled.elapsed().as_secs_f64();
    assert_eq!(
        status.code(),
        Some(130),
        "stopped after {:?}",
        start.elapsed()
    );
    // The stop polls every 50 ms, then removes the new generation; a run
    // that waited for the layout to end would take the rest of the stage,
    // two thirds of it.
    assert!(
        took < 0.25 * report_s,
        "stopped {took:.3} s after SIGINT, in a report stage of {report_s:.3} s"
    );
    assert_eq!(std::fs::read(out.join("results.json")).unwrap(), before);
    // Of the new generation only the run's finished case store is kept,
    // for `--resume`, which the message names.
    let left: Vec<String> = std::fs::read_dir(&staging)
        .expect("the staging directory keeps the case store")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        left,
        [ledflicker::store::FILE],
        "the half-written report was left behind"
    );
    let mut err = String::new();
    std::io::Read::read_to_string(&mut run.stderr.take().unwrap(), &mut err).unwrap();
    assert!(err.contains("--resume"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_fifo_given_as_golden_results_is_refused_at_once() {
    let dir = scratch("fifo-golden");
    let fifo = dir.join("golden.json");
    mkfifo(&fifo);
    let out = dir.join("o");
    let args = [
        "plan",
        "daylight",
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--golden",
        fifo.to_str().unwrap(),
    ];
    let ran = run_with_deadline(&args, &dir, std::slice::from_ref(&fifo), WAIT_AT_MOST);
    assert_eq!(ran.code, Some(2), "{}", ran.stderr);
    assert!(ran.stderr.contains("FIFO"), "{}", ran.stderr);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_fifo_given_as_the_plan_is_refused_at_once() {
    let dir = scratch("fifo-plan");
    let fifo = dir.join("plan.toml");
    mkfifo(&fifo);
    let out = dir.join("o");
    for args in [
        &["validate", fifo.to_str().unwrap()][..],
        &[
            "plan",
            fifo.to_str().unwrap(),
            "-q",
            "--out",
            out.to_str().unwrap(),
        ][..],
    ] {
        let ran = run_with_deadline(args, &dir, std::slice::from_ref(&fifo), WAIT_AT_MOST);
        assert_eq!(ran.code, Some(2), "{args:?}: {}", ran.stderr);
        assert!(ran.stderr.contains("FIFO"), "{}", ran.stderr);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--version` names the commit built; completions and the manual page
/// cover every subcommand.
#[test]
fn version_completions_and_manual_page() {
    let v = super::ledflicker(&["--version"]);
    assert!(v.status.success());
    let version = super::text(&v);
    let head = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(super::root())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let built = version
        .split("(git ")
        .nth(1)
        .and_then(|s| s.strip_suffix(")\n"))
        .unwrap_or_else(|| panic!("no commit in {version:?}"));
    // The binary may be older than HEAD only if it was built before the
    // last commit and not rebuilt: cargo rebuilds it when HEAD moves.
    if let Some(head) = head {
        assert_eq!(built, head, "{version}");
    }
    for shell in ["bash", "zsh", "fish"] {
        let c = super::ledflicker(&["completions", shell]);
        assert!(c.status.success(), "{shell}");
        let script = super::text(&c);
        for sub in ["plan", "merge", "calibrate", "verify", "completions"] {
            assert!(script.contains(sub), "{shell} completions lack `{sub}`");
        }
    }
    let bad = super::ledflicker(&["completions", "cmd.exe"]);
    assert_eq!(bad.status.code(), Some(2));
    let man = super::ledflicker(&["man"]);
    assert!(man.status.success());
    let page = super::text(&man);
    assert!(
        page.starts_with(".ie") || page.starts_with(".TH"),
        "{}",
        &page[..80.min(page.len())]
    );
    for sub in ["plan", "merge", "calibrate", "verify"] {
        assert!(page.contains(sub), "the manual page lacks `{sub}`");
    }
    let plan = super::text(&super::ledflicker(&["man", "plan"]));
    assert!(
        plan.contains("ledflicker\\-plan") && plan.contains("\\-\\-out"),
        "{plan}"
    );
    // Every page ends with EXIT STATUS, one entry per documented number
    // (the README's table), 6 and 7 among them.
    for page in [&page, &plan] {
        let status = &page[page.find(".SH \"EXIT STATUS\"").expect("no EXIT STATUS")..];
        for code in [0, 1, 2, 3, 4, 5, 6, 7, 130, 143] {
            assert!(
                status.contains(&format!("\\fB{code}\\fR")),
                "{code}: {status}"
            );
        }
    }
    let none = super::ledflicker(&["man", "nosuch"]);
    assert_eq!(none.status.code(), Some(2));
    assert!(super::stderr(&none).contains("calibrate"));
}

/// `A:B` and `R,G,B` flags are parsed by clap: a bad value is a usage
/// error (exit 2) naming the flag, the value and the form it must take.
#[test]
fn malformed_rows_and_colours_are_usage_errors_naming_the_flag() {
    let base = [
        "simulate",
        "--frequency-hz",
        "90",
        "--duty",
        "0.2",
        "--exposure-ms",
        "5",
        "--fps",
        "30",
    ];
    for (flag, value, want) in [
        ("--rows", "5:3", "not A:B with A < B"),
        ("--rows", "5", "not A:B with A < B"),
        ("--led-rgb", "1,2", "not three numbers R,G,B"),
        ("--rgb-duty", "0.5,-1,0.5", "each >= 0"),
    ] {
        let mut args = base.to_vec();
        args.extend(["--summary", flag, value]);
        let ran = super::ledflicker(&args);
        assert_eq!(ran.status.code(), Some(2), "{flag} {value}");
        let err = super::stderr(&ran);
        assert!(
            err.contains(flag) && err.contains(value) && err.contains(want),
            "{flag} {value}: {err}"
        );
    }
}

/// The built-in plans are reachable from an empty directory: listed,
/// written out, and named in the hint when a source-tree path is given.
#[test]
fn built_in_plans_are_listed_written_out_and_hinted_from_an_empty_directory() {
    let dir = super::scratch("plans-empty");
    let list = super::ledflicker_in(&["plans"], &dir);
    assert!(list.status.success(), "{}", super::text(&list));
    let listed = super::text(&list);
    for name in ["daylight", "lowlight", "p2020-samples", "sweep-23k"] {
        assert!(listed.lines().any(|l| l.starts_with(name)), "{listed}");
    }
    let show = super::ledflicker_in(&["plans", "show", "lowlight"], &dir);
    assert!(show.status.success());
    let shipped = std::fs::read(super::root().join("test-plans/lowlight.toml")).unwrap();
    assert_eq!(
        show.stdout, shipped,
        "`plans show` prints the plan as shipped"
    );
    std::fs::write(dir.join("mine.toml"), &show.stdout).unwrap();
    let o = super::ledflicker_in(&["validate", "mine.toml"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", super::text(&o));
    let o = super::ledflicker_in(&["plans", "show", "daylite"], &dir);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        super::stderr(&o).contains("one of bench-example"),
        "{}",
        super::stderr(&o)
    );
    let o = super::ledflicker_in(&["validate", "test-plans/lowlight.toml"], &dir);
    assert_eq!(o.status.code(), Some(2));
    let err = super::stderr(&o);
    assert!(
        err.contains("`lowlight` is built into ledflicker") && err.contains("plans show lowlight"),
        "{err}"
    );
    assert_eq!(err.matches("no such file").count(), 1, "{err}");
}

/// Common slips get a hint that names the fix: a duty in percent, a
/// number in quotes, a KPI misspelt, an instrument that does not answer.
#[test]
fn common_slips_are_refused_with_the_fix() {
    let dir = super::scratch("slips");
    let o = super::ledflicker(&[
        "simulate",
        "--duty",
        "20",
        "--frequency-hz",
        "90",
        "--exposure-ms",
        "11",
        "--fps",
        "30",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        super::stderr(&o).contains("give --duty 0.2"),
        "{}",
        super::stderr(&o)
    );

    let text = std::fs::read_to_string(super::root().join("test-plans/lowlight.toml")).unwrap();
    let quoted = text.replacen("exposure-ms = 30.0", "exposure-ms = \"30.0\"", 1);
    assert_ne!(quoted, text);
    std::fs::write(dir.join("q.toml"), quoted).unwrap();
    let o = super::ledflicker_in(&["validate", "q.toml"], &dir);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        super::stderr(&o).contains("hint: a number is written without quotes: exposure-ms = 30.0"),
        "{}",
        super::stderr(&o)
    );

    let db = dir.join("t.sqlite");
    let db = db.to_str().unwrap();
    let o = super::ledflicker_in(&["plan", "lowlight", "-q", "--out", "r", "--db", db], &dir);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{}",
        super::text(&o)
    );
    let o = super::ledflicker(&["trend", "--kpi", "fdi2018", "--db", db]);
    assert_eq!(o.status.code(), Some(2));
    let err = super::stderr(&o);
    assert!(
        err.contains("did you mean `fdi_2018`?") && err.contains("percent_flicker"),
        "{err}"
    );

    let bench = super::ledflicker_in(&["plans", "show", "bench-example"], &dir);
    std::fs::write(dir.join("bench.toml"), &bench.stdout).unwrap();
    // Port 1 on the loopback: nothing listens there.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", super::test_db())
        .args(["rig", "check", "bench.toml"])
        .current_dir(&dir)
        .env("LEDFLICKER_SOURCE_ADDRESS", "127.0.0.1:1")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3), "{}", super::text(&o));
    assert!(
        super::stderr(&o).contains("ledflicker rig simulate"),
        "{}",
        super::stderr(&o)
    );
}
