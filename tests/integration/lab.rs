//! The lab in the loop: `examples/lab/bench-scpi.toml` run against the
//! SCPI instrument simulator on 127.0.0.1 (docs/lab.md): the lines each
//! case sends, the instrument's error stopping the run, the output left
//! off after Ctrl-C, `rig check` and `plan --dry-run`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use ledflicker::backend::scpi::simulator::{Faults, IDENTITY, SimInstrument};
use ledflicker::backend::scpi::{case_steps, connect_lines};
use ledflicker::plan;

use crate::{ledflicker_in, root, scratch, stderr};

/// The example bench plan in `dir`, pointed at the simulator on `port`,
/// with one case and `on_s` seconds of ON; the camera stand-in beside it.
fn bench_plan(dir: &Path, port: u16, on_s: f64) -> PathBuf {
    let text = std::fs::read_to_string(root().join("examples/lab/bench-scpi.toml")).unwrap();
    let text = text
        .replace("\"192.168.1.50\"", "\"127.0.0.1\"")
        .replace("port = 5025 ", &format!("port = {port} "))
        .replace("frequencies-hz = [90.0, 137.0]", "frequencies-hz = [90.0]")
        .replace("on-s = 1.0", &format!("on-s = {on_s:?}"));
    assert!(text.contains(&format!("port = {port}")), "{text}");
    std::fs::copy(
        root().join("examples/lab/sim-camera.sh"),
        dir.join("sim-camera.sh"),
    )
    .unwrap();
    let path = dir.join("bench.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The last output on or off line the simulator received.
fn last_output(lines: &[String]) -> Option<&str> {
    lines
        .iter()
        .rev()
        .find(|l| *l == "OUTP1 ON" || *l == "OUTP1 OFF")
        .map(String::as_str)
}

#[test]
fn lab_bench_plan_sends_the_templates_sequence_and_logs_the_step_times() {
    let dir = scratch("lab-run");
    let sim = SimInstrument::start(Faults::default()).unwrap();
    let path = bench_plan(&dir, sim.port(), 1.0);
    let o = ledflicker_in(&["plan", "bench.toml", "--out", "out", "-q"], &dir);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    // The ON and OFF lengths found in the recording agree with the log.
    assert!(!stderr(&o).contains("more than a frame"), "{}", stderr(&o));
    // Exactly the template's lines, each step followed by the error query.
    let p = plan::load(&path).unwrap();
    let source = p.source.as_ref().unwrap();
    let case = &plan::expand_cases(&p)[0];
    let mut expected = connect_lines(source);
    for step in case_steps(source, case, &p.sequence) {
        expected.extend(step.lines);
        expected.push("SYST:ERR?".to_string());
    }
    assert_eq!(sim.lines(), expected);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("out/results.json")).unwrap()).unwrap();
    let log = &json["cases"][0]["capture"]["light_source"];
    assert_eq!(log["identity"], IDENTITY);
    assert_eq!(log["instrument"], "keysight-33500b");
    let steps = log["steps"].as_array().unwrap();
    let names: Vec<&str> = steps.iter().map(|s| s["step"].as_str().unwrap()).collect();
    assert_eq!(names, ["prepare", "on", "off", "pwm", "end"]);
    let t: Vec<f64> = steps
        .iter()
        .map(|s| s["time_s"].as_f64().unwrap())
        .collect();
    // Held lead-in 0.5 s, ON 1 s, OFF 1 s, PWM 2 s, from the host clock;
    // off by at most what a loaded host's scheduler adds to a step's
    // sending (20 ms, under a frame at 30 fps) and the answers' time.
    for (i, want) in [0.5, 1.0, 1.0, 2.0].into_iter().enumerate() {
        let held = t[i + 1] - t[i];
        assert!(
            held >= want - 0.02 && held < want + 0.5,
            "step {i}: {held} s"
        );
    }
    // Segments found in the recording, which starts in the dark.
    let case = &json["cases"][0];
    assert_eq!(case["capture"]["segments"]["method"], "detected", "{case}");
    assert_eq!(case["capture"]["segments"]["rule"], "sequence", "{case}");
    assert_eq!(case["rois"][0]["levels"]["on"], 40.0, "{case}");
}

#[test]
fn lab_an_instrument_error_stops_the_run_with_its_message_and_the_output_off() {
    let dir = scratch("lab-error");
    let sim = SimInstrument::start(Faults {
        error_on: Some(("DCYC".into(), -222, "Data out of range".into())),
        ..Faults::default()
    })
    .unwrap();
    bench_plan(&dir, sim.port(), 0.5);
    let o = ledflicker_in(&["plan", "bench.toml", "--out", "out", "-q"], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("-222, \"Data out of range\""), "{err}");
    assert!(err.contains("after the `off` step"), "{err}");
    assert_eq!(last_output(&sim.lines()), Some("OUTP1 OFF"));
    assert!(!dir.join("out/results.json").exists());
}

#[test]
fn lab_ctrl_c_during_a_case_leaves_the_output_off() {
    let dir = scratch("lab-sigint");
    let sim = SimInstrument::start(Faults::default()).unwrap();
    // The simulator's clock starts a moment before this one.
    let sim_clock = Instant::now();
    // A long ON step to send the signal in.
    bench_plan(&dir, sim.port(), 30.0);
    let err_path = dir.join("stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["plan", "bench.toml", "--out", "out", "-q"])
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !sim.lines().iter().any(|l| l == "OUTP1 ON") {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no ON step: {:?}",
            sim.lines()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let signalled = Instant::now();
    let signal_at = signalled - sim_clock;
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if signalled.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            panic!("still running 20 s after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    assert_eq!(status.code(), Some(130), "{err}");
    let lines = sim.lines();
    assert_eq!(last_output(&lines), Some("OUTP1 OFF"), "{lines:?}");
    // Off soon after the signal, long before the 30 s ON ended.
    let on = sim
        .received()
        .into_iter()
        .rev()
        .find(|r| r.line == "OUTP1 OFF")
        .unwrap();
    let first_on = sim
        .received()
        .into_iter()
        .find(|r| r.line == "OUTP1 ON")
        .unwrap();
    assert!(on.at > first_on.at, "{lines:?}");
    let latency = on.at.saturating_sub(signal_at);
    eprintln!("output off {latency:?} after SIGINT");
    assert!(
        latency < Duration::from_secs(2),
        "output off {latency:?} after SIGINT"
    );
}

#[test]
fn lab_rig_check_prints_the_identity_and_sends_only_queries() {
    let dir = scratch("lab-check");
    let sim = SimInstrument::start(Faults::default()).unwrap();
    bench_plan(&dir, sim.port(), 1.0);
    let o = ledflicker_in(&["rig", "check", "bench.toml"], &dir);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(out.contains(&format!("identity: {IDENTITY}")), "{out}");
    assert!(
        out.contains(&format!("keysight-33500b at 127.0.0.1:{}", sim.port())),
        "{out}"
    );
    assert!(out.contains("error queue: empty"), "{out}");
    assert_eq!(sim.lines(), ["*IDN?", "SYST:ERR?"]);
}

#[test]
fn lab_rig_check_of_an_unreachable_instrument_fails_naming_it() {
    let dir = scratch("lab-check-down");
    let port = {
        let sim = SimInstrument::start(Faults::default()).unwrap();
        sim.port()
    };
    bench_plan(&dir, port, 1.0);
    let o = ledflicker_in(&["rig", "check", "bench.toml"], &dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains(&format!("cannot reach the instrument at 127.0.0.1:{port}")),
        "{err}"
    );
}

#[test]
fn lab_dry_run_prints_every_line_and_connects_to_nothing() {
    let o = ledflicker_in(
        &["plan", "examples/lab/bench-scpi.toml", "--dry-run"],
        root(),
    );
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for want in [
        "dry run of plan `bench-scpi`: 2 cases; nothing is connected or sent",
        "case 2000lux-137hz-10pct:",
        "SOUR1:FREQ 137",
        "SOUR1:FUNC:SQU:DCYC 10",
        "      0.500 s  on       OUTP1 ON",
        "      4.500 s  end      OUTP1 OFF",
    ] {
        assert!(out.contains(want), "{want} not in\n{out}");
    }
    assert!(!root().join("reports/bench-scpi").exists());
}

#[test]
fn lab_bench_plan_gives_the_verdicts_of_the_same_rig_without_a_source() {
    let dir = scratch("lab-verdicts");
    let sim = SimInstrument::start(Faults::default()).unwrap();
    let path = bench_plan(&dir, sim.port(), 1.0);
    let text = std::fs::read_to_string(&path).unwrap();
    // The same plan and camera, the light left to the rig: no lead-in, the
    // segments from [sequence].
    let (head, tail) = text.split_once("[source]").unwrap();
    let tail = &tail[tail.find("[thresholds]").unwrap()..];
    std::fs::write(dir.join("plain.toml"), format!("{head}{tail}")).unwrap();
    let mut metrics = Vec::new();
    for (plan, out) in [("bench.toml", "a"), ("plain.toml", "b")] {
        let o = ledflicker_in(&["plan", plan, "--out", out, "-q"], &dir);
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(out).join("results.json")).unwrap())
                .unwrap();
        metrics.push(json["cases"][0].clone());
    }
    let (with, without) = (&metrics[0], &metrics[1]);
    assert_eq!(with["verdict"], without["verdict"]);
    assert!(without["capture"].get("light_source").is_none());
    for key in ["fdi_2018", "percent_flicker"] {
        let a = with["rois"][0]["metrics"][key].as_f64().unwrap();
        let b = without["rois"][0]["metrics"][key].as_f64().unwrap();
        assert!(
            (a - b).abs() <= 1e-6 * b.abs().max(1.0),
            "{key}: {a} vs {b}"
        );
    }
}
