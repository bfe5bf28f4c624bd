//! The lab in the loop with a camera recorder: the shipped
//! `test-plans/bench-example.toml` run against the SCPI instrument
//! simulator on 127.0.0.1 and a simulated camera
//! (`examples/lab/sim-recorder.sh`), which renders what the instrument's
//! output looked like from the simulator's log file. Its verdicts against
//! the same grid on the simulator backend, the log's sequence, and the
//! output off after Ctrl-C (docs/lab.md).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use ledflicker::backend::scpi::simulator::{Faults, SimInstrument};
use ledflicker::backend::scpi::{case_steps, connect_lines};
use ledflicker::plan;

use crate::{ledflicker_in, root, scratch, stderr};

/// The SCPI instrument simulator at a free port, logging into a file: the
/// bench of test-plans/bench-example.toml, which a run reaches through
/// `LEDFLICKER_SOURCE_ADDRESS` (the instrument) and
/// `LEDFLICKER_INSTRUMENT_LOG` (the simulated camera).
pub struct SimulatedBench {
    /// The simulator; stops when dropped.
    pub sim: SimInstrument,
    /// Its log: a line per line received, with its Unix time.
    pub log: PathBuf,
}

impl SimulatedBench {
    /// Starts the simulator, its log in `dir`.
    pub fn start(dir: &Path) -> Self {
        let log = dir.join("instrument.log");
        let sim = SimInstrument::start_at(0, Faults::default(), Some(&log)).unwrap();
        Self { sim, log }
    }

    /// The binary with `args`, run in `dir`, pointed at this bench.
    pub fn command(&self, args: &[&str], dir: &Path) -> Command {
        let mut c = Command::new(env!("CARGO_BIN_EXE_ledflicker"));
        c.env("LEDFLICKER_DB", crate::test_db())
            .env(
                "LEDFLICKER_SOURCE_ADDRESS",
                format!("127.0.0.1:{}", self.sim.port()),
            )
            .env("LEDFLICKER_INSTRUMENT_LOG", &self.log)
            .env_remove("SOURCE_DATE_EPOCH")
            .args(args)
            .current_dir(dir);
        c
    }

    /// Runs the binary with `args` in `dir` against this bench.
    pub fn run(&self, args: &[&str], dir: &Path) -> Output {
        self.command(args, dir).output().unwrap()
    }
}

/// The shipped bench plan.
fn bench_plan() -> PathBuf {
    root().join("test-plans/bench-example.toml")
}

/// The shipped bench plan, copied into `dir` with `on_s` seconds of ON
/// (its simulated camera named by its absolute path).
fn bench_example(dir: &Path, on_s: f64) -> PathBuf {
    let text = std::fs::read_to_string(bench_plan()).unwrap();
    let camera = root().join("examples/lab/sim-recorder.sh");
    let text = text
        .replace(
            "\"../examples/lab/sim-recorder.sh\"",
            &format!("\"{}\"", camera.display()),
        )
        .replace("on-s = 1.0", &format!("on-s = {on_s:?}"));
    assert!(text.contains(&camera.display().to_string()), "{text}");
    let path = dir.join("bench.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The simulator's log file: (Unix time, line) of each line received.
fn read_log(log: &Path) -> Vec<(f64, String)> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .map(|l| {
            let mut parts = l.splitn(3, ' ');
            let t: f64 = parts.next().unwrap().parse().unwrap();
            let _connection = parts.next().unwrap();
            (t, parts.next().unwrap_or_default().to_string())
        })
        .collect()
}

fn results(dir: &Path, out: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join(out).join("results.json")).unwrap()).unwrap()
}

#[test]
fn lab_bench_example_with_a_simulated_camera_gives_the_simulators_verdicts() {
    let dir = scratch("lab-bench");
    let bench = SimulatedBench::start(&dir);
    let (sim, log) = (&bench.sim, &bench.log);
    let path = bench_plan();
    let o = bench.run(
        &["plan", path.to_str().unwrap(), "--out", "bench", "-q"],
        &dir,
    );
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    assert!(!stderr(&o).contains("more than a frame"), "{}", stderr(&o));
    // The same grid on the simulator backend (no source, no recorder),
    // and on the camera stand-in that renders the plan's own values
    // (sim-camera.sh: the light the instrument should have made).
    let text = std::fs::read_to_string(&path).unwrap();
    let (head, tail) = text.split_once("[capture]").unwrap();
    let tail = &tail[tail.find("[thresholds]").unwrap()..];
    let simulator = head.replace("backend = \"command\"", "backend = \"simulator\"");
    std::fs::write(dir.join("sim.toml"), format!("{simulator}{tail}")).unwrap();
    let rig = "[capture]\ncommand = [\"sh\", \"sim-camera.sh\"]\ntimeout-s = 60.0\n\n";
    std::fs::write(dir.join("rig.toml"), format!("{head}{rig}{tail}")).unwrap();
    std::fs::copy(
        root().join("examples/lab/sim-camera.sh"),
        dir.join("sim-camera.sh"),
    )
    .unwrap();
    let mut runs = vec![results(&dir, "bench")];
    for (plan, out) in [("sim.toml", "sim"), ("rig.toml", "rig")] {
        let o = ledflicker_in(&["plan", plan, "--out", out, "-q"], &dir);
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
        runs.push(results(&dir, out));
    }
    let cases: Vec<&Vec<serde_json::Value>> = runs
        .iter()
        .map(|r| r["cases"].as_array().unwrap())
        .collect();
    assert_eq!(cases[0].len(), 2);
    let mut verdicts = Vec::new();
    for (i, b) in cases[0].iter().enumerate() {
        let (s, r) = (&cases[1][i], &cases[2][i]);
        assert_eq!(b["id"], s["id"]);
        assert_eq!(b["verdict"], s["verdict"], "{}\n{b}\n{s}", b["id"]);
        assert_eq!(b["verdict"], r["verdict"], "{}\n{b}\n{r}", b["id"]);
        verdicts.push(b["verdict"].as_str().unwrap().to_string());
        for key in ["fdi_2018", "percent_flicker"] {
            let metric = |c: &serde_json::Value| c["rois"][0]["metrics"][key].as_f64().unwrap();
            let (x, y, z) = (metric(b), metric(s), metric(r));
            eprintln!(
                "{} {key}: bench {x}, simulator {y}, plan's values {z}",
                b["id"]
            );
            // The camera saw the light the instrument was told to make:
            // the metric of the frames rendered from the plan's values,
            // within 2 % (the segments' lengths are the host clock's, the
            // PWM phase the instrument's).
            assert!(
                (x - z).abs() <= 0.02 * z.abs().max(1e-3),
                "{key}: {x} vs {z}"
            );
        }
    }
    // A failing case and a passing one: the verdict is not the same
    // whatever the frames.
    assert_eq!(verdicts, ["fail", "pass"]);
    // The log holds exactly the template's lines, each case's in the
    // documented order; the cases come in the order the workers take
    // them (one at a time at the instrument).
    let p = plan::load(&path).unwrap();
    let source = p.source.as_ref().unwrap();
    let connect = connect_lines(source);
    let mut expected: Vec<Vec<String>> = plan::expand_cases(&p)
        .iter()
        .map(|case| {
            let mut lines = Vec::new();
            for step in case_steps(source, case, &p.sequence) {
                lines.extend(step.lines);
                lines.push("SYST:ERR?".to_string());
            }
            lines
        })
        .collect();
    let logged = read_log(log);
    let lines: Vec<String> = logged.iter().map(|(_, l)| l.clone()).collect();
    assert_eq!(lines, sim.lines());
    assert_eq!(lines[..connect.len()], connect);
    let per_case = expected[0].len();
    assert!(expected.iter().all(|e| e.len() == per_case));
    let mut seen: Vec<Vec<String>> = lines[connect.len()..]
        .chunks(per_case)
        .map(<[String]>::to_vec)
        .collect();
    seen.sort();
    expected.sort();
    assert_eq!(seen, expected);
    // Each case's ON is held on-s, its OFF off-s and its PWM pwm-s, as
    // the Unix times in the log show, within what a loaded host's
    // scheduler may add to when a line is sent or logged (20 ms, under a
    // frame at 30 fps).
    let at = |line: &str| -> Vec<f64> {
        logged
            .iter()
            .filter(|(_, l)| l == line)
            .map(|(t, _)| *t)
            .collect()
    };
    let (on, off) = (at("OUTP1 ON"), at("OUTP1 OFF"));
    // Per case: off (prepare), on, off, on (pwm), off (end).
    assert_eq!((on.len(), off.len()), (4, 6));
    for case in 0..2 {
        let (on1, on2) = (on[2 * case], on[2 * case + 1]);
        let (off_step, end) = (off[3 * case + 1], off[3 * case + 2]);
        for (held, want) in [
            (off_step - on1, 1.0),
            (on2 - off_step, 1.0),
            (end - on2, 2.0),
        ] {
            assert!(held >= want - 0.02 && held < want + 0.5, "{held} s");
        }
    }
}

#[test]
fn lab_bench_example_ctrl_c_leaves_the_output_off_and_stops_the_camera() {
    let dir = scratch("lab-bench-sigint");
    let bench = SimulatedBench::start(&dir);
    let log = bench.log.clone();
    // A long ON step to send the signal in; the camera records through it.
    bench_example(&dir, 30.0);
    let mut child = bench
        .command(&["plan", "bench.toml", "--out", "out", "-q"], &dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !read_log(&log).iter().any(|(_, l)| l == "OUTP1 ON") {
        assert!(started.elapsed() < Duration::from_secs(60), "no ON step");
        std::thread::sleep(Duration::from_millis(20));
    }
    // The camera is recording: its environment names the log, as the
    // run's does.
    let log_var = format!("LEDFLICKER_INSTRUMENT_LOG={}", log.display());
    let run = child.id();
    let camera = || -> Vec<u32> {
        processes_with(&log_var)
            .into_iter()
            .filter(|&p| p != run)
            .collect()
    };
    assert!(!camera().is_empty(), "no camera running");
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let signalled = Instant::now();
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
    assert_eq!(status.code(), Some(130));
    let logged = read_log(&log);
    let last = logged
        .iter()
        .rev()
        .find(|(_, l)| l == "OUTP1 ON" || l == "OUTP1 OFF")
        .unwrap();
    assert_eq!(last.1, "OUTP1 OFF", "{logged:?}");
    // Off long before the 30 s ON step would have ended.
    let first_on = logged.iter().find(|(_, l)| l == "OUTP1 ON").unwrap();
    assert!(last.0 - first_on.0 < 20.0, "{logged:?}");
    assert_eq!(camera(), Vec::<u32>::new(), "the camera outlived the run");
}

/// Pids of the processes whose environment holds the variable `var`
/// (`NAME=value`).
fn processes_with(var: &str) -> Vec<u32> {
    let mut pids = Vec::new();
    for p in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(pid) = p.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else {
            continue;
        };
        let environ = std::fs::read(p.path().join("environ")).unwrap_or_default();
        if environ.split(|&b| b == 0).any(|v| v == var.as_bytes()) {
            pids.push(pid);
        }
    }
    pids
}

#[test]
fn lab_bench_example_dry_run_prints_the_recorder_and_every_line() {
    let dry_run = |plan: &str, address: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
            .env("LEDFLICKER_DB", crate::test_db())
            .env("LEDFLICKER_SOURCE_ADDRESS", address)
            .args(["plan", plan, "--dry-run"])
            .current_dir(root())
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr(&o),
        )
    };
    // The shipped plan, pointed at a bench's generator.
    let (code, out, err) = dry_run("test-plans/bench-example.toml", "192.168.1.50:5025");
    assert_eq!(code, Some(0), "{err}");
    for want in [
        "dry run of plan `bench-example`: 2 cases; nothing is connected or sent",
        "light source: keysight-33500b at 192.168.1.50:5025, channel 1",
        // 0.5 s lead-in, 4 s of sequence, 0.5 s tail at 30 fps.
        "camera recorder: 150 frames (5 s at 30 fps), 0.5 s after the end",
        "  sh ../examples/lab/sim-recorder.sh {out-dir} 5 30\n",
        "case 2000lux-50hz-10pct:",
        "SOUR1:FREQ 50",
        "      4.500 s  end      OUTP1 OFF",
    ] {
        assert!(out.contains(want), "{want} not in\n{out}");
    }
    // With a V4L2 camera through GStreamer.
    let dir = scratch("lab-bench-dry-run");
    let text = std::fs::read_to_string(bench_plan()).unwrap();
    let (head, tail) = text.split_once("[recorder]\n").unwrap();
    let tail = &tail[tail.find("tail-s").unwrap()..];
    let v4l2 = "gstreamer = \"v4l2src device=/dev/video0 ! video/x-raw,framerate=30/1\"\n";
    let plan = dir.join("v4l2.toml");
    std::fs::write(&plan, format!("{head}[recorder]\n{v4l2}{tail}")).unwrap();
    let (code, out, err) = dry_run(plan.to_str().unwrap(), "10.0.0.7:5025");
    assert_eq!(code, Some(0), "{err}");
    for want in [
        "light source: keysight-33500b at 10.0.0.7:5025, channel 1",
        "  gst-launch-1.0 -q -e v4l2src device=/dev/video0 ! video/x-raw,framerate=30/1 ! identity eos-after=151 !",
        "filesink location={out-dir}/camera.y4m",
    ] {
        assert!(out.contains(want), "{want} not in\n{out}");
    }
    // Only a command plan records anything to keep.
    let out = dir.join("daylight");
    let o = ledflicker_in(
        &[
            "plan",
            "test-plans/daylight.toml",
            "--keep-captures",
            "--out",
            out.to_str().unwrap(),
        ],
        root(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "--keep-captures: plan `daylight` records nothing to keep (its backend is simulator)"
        ),
        "{}",
        stderr(&o)
    );
    // A mistyped address is a usage error naming the variable.
    let (code, _, err) = dry_run("test-plans/bench-example.toml", "192.168.1.50");
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("LEDFLICKER_SOURCE_ADDRESS: `192.168.1.50` is not HOST:PORT"),
        "{err}"
    );
}

#[test]
fn lab_rig_simulate_serves_until_ctrl_c_and_logs_each_line() {
    use std::io::{BufRead, BufReader, Write};
    let dir = scratch("lab-simulate");
    let log = dir.join("instrument.log");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args(["rig", "simulate", "--port", "0", "--log"])
        .arg(&log)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let port: u16 = first
        .strip_prefix("SCPI instrument simulator on 127.0.0.1:")
        .and_then(|r| r.split(' ').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {first:?}"));
    let mut stream = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    stream.write_all(b"*IDN?\nOUTP1 ON\n").unwrap();
    let mut answer = String::new();
    BufReader::new(stream.try_clone().unwrap())
        .read_line(&mut answer)
        .unwrap();
    assert_eq!(
        answer.trim_end(),
        ledflicker::backend::scpi::simulator::IDENTITY
    );
    // The second line reaches the log without an answer to wait for.
    let started = Instant::now();
    while read_log(&log).len() < 2 {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "{:?}",
            read_log(&log)
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    // SAFETY: kill(2) on the child this test started.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "stopped: 2 line(s) received on 1 connection(s); the last output line was `OUTP1 ON`"
        ),
        "{}",
        stderr(&o)
    );
    let lines: Vec<String> = read_log(&log).into_iter().map(|(_, l)| l).collect();
    assert_eq!(lines, ["*IDN?", "OUTP1 ON"]);
}
