//! The work estimate `validate` prints against what a run takes: peak
//! memory at or above the measured peak whether a plan's cases pass or
//! fail, and within 1.5 times the higher of the two, for every shipped
//! plan; and limits a user can raise.

use super::{ledflicker, root, scratch, stderr, text};
use std::process::Command;

/// Bytes of a size as `plan::bounds::bytes` prints it (`340 MB`).
fn size(value: &str, unit: &str) -> f64 {
    let v: f64 = value.parse().unwrap();
    v * match unit {
        "kB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        u => panic!("unit {u}"),
    }
}

/// The peak memory `validate` estimates for `plan` (with `extra`
/// flags), bytes.
fn estimated_memory(plan: &str, extra: &[&str]) -> f64 {
    let o = ledflicker(&[&["validate", plan][..], extra].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = text(&o);
    let after = out
        .split("peak memory ")
        .nth(1)
        .unwrap_or_else(|| panic!("no estimate in: {out}"));
    let mut words = after.split([' ', ';']);
    size(words.next().unwrap(), words.next().unwrap())
}

/// The temporary files `validate` estimates for `plan`, bytes (0 when it
/// names none).
fn estimated_scratch(plan: &str) -> f64 {
    let out = text(&ledflicker(&["validate", plan]));
    out.split("temporary files ").nth(1).map_or(0.0, |after| {
        let mut words = after.split([' ', ';', '\n']);
        size(words.next().unwrap(), words.next().unwrap())
    })
}

/// Bytes of a run's spill file: each case's results.json entry, compact.
fn spilled_bytes(results: &std::path::Path) -> f64 {
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results).unwrap()).unwrap();
    let cases = doc["cases"].as_array().unwrap();
    // The spill holds every case whole; results.json of a large run holds
    // the listed cases whole and the others as summary rows
    // (`full_record`), each counted here at the whole cases' mean size.
    let whole: Vec<f64> = cases
        .iter()
        .filter(|c| c.get("full_record").is_none())
        .map(|c| serde_json::to_string(c).unwrap().len() as f64)
        .collect();
    let rows = cases.len() - whole.len();
    let mean = whole.iter().sum::<f64>() / whole.len().max(1) as f64;
    whole.iter().sum::<f64>() + rows as f64 * mean
}

/// `plan` with every case it judges made to fail (an FDI of at least 100,
/// and a Percent Flicker of at most 0.001 %), written into `dir`: a
/// failing case gets a page of charts in
/// report.pdf, so this is a plan's costliest outcome. Paths in the plan
/// are made absolute, as it no longer sits in test-plans/.
fn failing_variant(plan: &std::path::Path, dir: &std::path::Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(plan).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with("percent-flicker-max = ") || line.starts_with("fdi-2018-min = ") {
            continue;
        }
        out.push_str(&line.replace("\"../", &format!("\"{}/", root().display())));
        out.push('\n');
        if line == "[thresholds]" {
            out.push_str("percent-flicker-max = 0.001\nfdi-2018-min = 100.0\n");
        }
    }
    assert!(out.contains("percent-flicker-max = 0.001"), "{plan:?}");
    let name = plan.file_stem().unwrap().to_str().unwrap();
    let path = dir.join(format!("{name}-failing.toml"));
    std::fs::write(&path, out).unwrap();
    path
}

/// Runs `plan` and returns its exit code and peak resident memory, bytes:
/// the high-water mark the kernel keeps for that process alone (VmHWM in
/// /proc/PID/status), read until it exits. A command plan's rig runs in
/// processes of its own, which are not ledflicker's memory (wait4's
/// maximum would count the largest of them).
/// A plan with a light source (`[source]`) runs against the SCPI
/// instrument simulator and its simulated camera.
fn measured_memory(plan: &str, out: &std::path::Path) -> (i32, f64) {
    let args = ["plan", plan, "-q", "--out", out.to_str().unwrap()];
    let light_source = std::fs::read_to_string(plan).is_ok_and(|t| t.contains("\n[source]\n"));
    let bench =
        light_source.then(|| crate::lab_bench::SimulatedBench::start(out.parent().unwrap()));
    let mut command = match &bench {
        Some(bench) => bench.command(&args, root()),
        None => {
            let mut c = Command::new(env!("CARGO_BIN_EXE_ledflicker"));
            c.env("LEDFLICKER_DB", super::test_db())
                .args(args)
                .current_dir(root())
                .env_remove("SOURCE_DATE_EPOCH");
            c
        }
    };
    let mut child = command
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let status_file = format!("/proc/{}/status", child.id());
    // The mark only grows, so the last one read is the peak but for what
    // the process adds in its last millisecond.
    let mut peak_kb = 0.0f64;
    let status = loop {
        if let Some(line) = std::fs::read_to_string(&status_file).ok().and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .map(str::to_string)
        }) {
            let kb: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
            peak_kb = peak_kb.max(kb);
        }
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    };
    assert!(peak_kb > 0.0, "{plan}: no memory figure read");
    (status.code().unwrap(), peak_kb * 1024.0)
}

#[test]
fn every_shipped_plan_runs_within_its_memory_estimate_passing_or_failing_and_the_estimate_is_within_1_5_times_the_higher_peak()
 {
    let dir = scratch("estimate");
    let mut plans: Vec<_> = std::fs::read_dir(root().join("test-plans"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    plans.sort();
    assert!(plans.len() >= 7, "{plans:?}");
    // And a sweep beyond the cases a report lists (1000 cases).
    let sweep_plan = dir.join("sweep-1000.toml");
    std::fs::write(&sweep_plan, ledflicker::bench::sweep_plan(100)).unwrap();
    plans.push(sweep_plan);
    // And the shipped dense sweep cut to 1000 cases at one light level: its
    // many failing cases make its listed cases the costliest per case.
    let dense = std::fs::read_to_string(root().join("test-plans/sweep-23k.toml")).unwrap();
    let grid_start = dense.find("frequencies-hz = [").unwrap();
    let grid_end = grid_start + dense[grid_start..].find(']').unwrap() + 1;
    let frequencies: Vec<String> = (0..50).map(|i| format!("{}.0", 50 + 5 * i)).collect();
    let dense_1k = format!(
        "{}frequencies-hz = [{}]{}",
        &dense[..grid_start],
        frequencies.join(", "),
        &dense[grid_end..]
    )
    .replace("id = \"sweep-23k\"", "id = \"dense-1k\"")
    .replace("levels-lux = [40.0, 400.0, 2000.0]", "levels-lux = [40.0]");
    let dense_plan = dir.join("dense-1k.toml");
    std::fs::write(&dense_plan, dense_1k).unwrap();
    plans.push(dense_plan);
    // And a front camera of 8 MP (3840 x 2160, rolling shutter), 56 cases:
    // its sensor must not cost memory per case.
    let front = dir.join("front-8mp.toml");
    let daylight = std::fs::read_to_string(root().join("test-plans/daylight.toml")).unwrap();
    let front_text = [
        ("id = \"daylight\"", "id = \"front-8mp\""),
        ("sensor-rows = 800", "sensor-rows = 2160"),
        ("sensor-columns = 1280", "sensor-columns = 3840"),
        ("line-time-us = 14.565", "line-time-us = 7.4"),
        (
            "duty-cycles = [0.05, 0.1, 0.2, 0.5, 1.0]",
            "duty-cycles = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0]",
        ),
    ]
    .iter()
    .fold(daylight, |text, (from, to)| {
        assert!(text.contains(from), "daylight.toml has no `{from}`");
        text.replace(from, to)
    });
    std::fs::write(&front, front_text).unwrap();
    plans.push(front);
    let mut table = Vec::new();
    for plan in &plans {
        let name = plan.file_stem().unwrap().to_str().unwrap();
        let estimate = estimated_memory(plan.to_str().unwrap(), &[]);
        let (code, peak) = measured_memory(plan.to_str().unwrap(), &dir.join(name));
        assert!(matches!(code, 0 | 1 | 4), "{name} exited {code}");
        // The shipped dense sweep already fails more cases than get a page.
        let failing_peak = match name {
            "sweep-23k" => None,
            _ => {
                let failing = failing_variant(plan, &dir);
                assert_eq!(estimated_memory(failing.to_str().unwrap(), &[]), estimate);
                let out = dir.join(format!("{name}-failing"));
                let (code, peak) = measured_memory(failing.to_str().unwrap(), &out);
                assert_eq!(code, 1, "{name}, every case failing, exited {code}");
                Some(peak)
            }
        };
        let highest = failing_peak.map_or(peak, |f| f.max(peak));
        table.push(format!(
            "{name}: estimate {:.0} MB, peak {:.0} MB, failing {}",
            estimate / 1e6,
            peak / 1e6,
            failing_peak.map_or("-".to_string(), |f| format!("{:.0} MB", f / 1e6))
        ));
        // A spilled run's temporary files, against the entries it spilled.
        let scratch = estimated_scratch(plan.to_str().unwrap());
        if ["sweep-1000", "dense-1k", "sweep-23k"].contains(&name) {
            let spilled = spilled_bytes(&dir.join(name).join("results.json"));
            assert!(
                (spilled..=1.5 * spilled).contains(&scratch),
                "{name}: temporary files estimated {scratch}, spilled {spilled}"
            );
        } else {
            assert_eq!(scratch, 0.0, "{name} holds its cases in memory");
        }
        if name == "front-8mp" {
            let o = ledflicker(&["validate", plan.to_str().unwrap()]);
            assert!(text(&o).contains("56 cases"), "{}", text(&o));
            assert!(highest < 1e9, "8 MP plan: peak {:.0} MB", highest / 1e6);
        }
        // A plan that validates must run within its estimate, whatever its
        // cases' verdicts; an estimate far above the peak would refuse
        // plans that fit.
        let ratio = estimate / highest;
        assert!(
            (1.0..=1.5).contains(&ratio),
            "{name}: estimate {:.0} MB against a peak of {:.0} MB ({ratio:.2}x)\n{}",
            estimate / 1e6,
            highest / 1e6,
            table.join("\n")
        );
    }
    eprintln!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_sweep_estimate_does_not_grow_with_its_cases_beyond_those_listed() {
    // A run larger than its report lists holds 121 model entries and a few
    // figures of every other case (its spill file has the rest).
    let dir = scratch("estimate-flat");
    let at = |frequencies: usize| {
        let plan = dir.join(format!("sweep-{frequencies}.toml"));
        std::fs::write(&plan, ledflicker::bench::sweep_plan(frequencies)).unwrap();
        let limits = ["--max-memory", "100GB", "--max-report", "100GB"];
        estimated_memory(plan.to_str().unwrap(), &limits)
    };
    let (small, large) = (at(100), at(10_000));
    // 99,000 more cases at 200 bytes each, not 10.5 kB.
    let grown = large - small;
    assert!(
        (0.0..99_000.0 * 300.0).contains(&grown),
        "{small} -> {large}"
    );
    assert!(large < 300e6, "{large}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_plan_over_the_memory_limit_names_the_flag_that_raises_it() {
    let dir = scratch("max-memory");
    let plan = dir.join("sweep.toml");
    // 200 cases of 10 minutes at 30 fps: every case is listed and charted,
    // more than 1 GB by the estimate.
    let long = ledflicker::bench::sweep_plan(20).replace("pwm-s = 3.0", "pwm-s = 600.0");
    assert!(long.contains("pwm-s = 600.0"));
    std::fs::write(&plan, long).unwrap();
    let p = plan.to_str().unwrap();
    let o = ledflicker(&["validate", p]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let err = stderr(&o);
    assert!(
        err.contains("200 cases") && err.contains("--max-memory raises it"),
        "{err}"
    );
    let estimate = estimated_memory(p, &["--max-memory", "100GB", "--max-report", "100GB"]);
    assert!(estimate > 1e9, "{estimate}");
    // Above the estimate it validates, below it does not (the estimate
    // is printed to two digits).
    let above = format!("{}MB", (estimate * 1.1 / 1e6).ceil());
    let below = format!("{}MB", (estimate / 1.1 / 1e6).floor());
    assert_eq!(
        ledflicker(&[
            "validate",
            p,
            "--max-report",
            "100GB",
            "--max-memory",
            &above
        ])
        .status
        .code(),
        Some(0)
    );
    assert_eq!(
        ledflicker(&[
            "validate",
            p,
            "--max-report",
            "100GB",
            "--max-memory",
            &below
        ])
        .status
        .code(),
        Some(2)
    );
    let o = ledflicker(&["validate", p, "--max-memory", "4 parsecs"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        stderr(&o).contains("unknown unit `parsecs`"),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A plan too large for one process runs in shards, each held to its own
/// share of the cases: 100,000 cases are refused whole and in halves, and
/// a shard of 100 of them runs.
#[test]
fn a_shard_is_checked_against_its_own_share_of_the_plan() {
    let dir = scratch("shard-share");
    let plan = dir.join("sweep.toml");
    std::fs::write(&plan, ledflicker::bench::sweep_plan(10_000)).unwrap();
    let p = plan.to_str().unwrap();
    let half = ledflicker(&["plan", p, "--shard", "0/2", "--out", "half", "-q"]);
    assert_eq!(half.status.code(), Some(2), "{}", text(&half));
    let err = stderr(&half);
    assert!(
        err.contains("shard 0/2 (50000 of 100000 cases)") && err.contains("--max-memory raises it"),
        "{err}"
    );
    let out = dir.join("small");
    let small = ledflicker(&[
        "plan",
        p,
        "--shard",
        "0/1000",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(small.status.code(), Some(0), "{}", text(&small));
    assert!(out.join("shard.json").is_file() || std::fs::read_dir(&out).unwrap().count() > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}
