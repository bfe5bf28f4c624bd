//! Sharded runs: a plan run as N shards and merged gives the
//! same results.json, report.html and report.pdf, byte for byte, as one
//! run with the same --date; broken shard sets are refused with exit 2,
//! naming the shards; a merged report signs and verifies like any other.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::recgen::{self, Recording};
use crate::{ledflicker, ledflicker_in, root, scratch, text};

const DATE: &str = "2026-11-23";
const COMPARED: [&str; 3] = ["results.json", "report.html", "report.pdf"];

fn run(args: &[&str], dir: &Path) -> Output {
    ledflicker_in(args, dir)
}

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

/// Runs `plan` once into `dir/single` and as `n` shards merged into
/// `dir/merged` (both from `cwd`, with `extra` flags); returns the shard
/// directories.
fn single_and_merged(plan: &str, n: usize, cwd: &Path, dir: &Path, extra: &[&str]) -> Vec<PathBuf> {
    let single = dir.join("single");
    let o = run(
        &[
            &[
                "plan",
                plan,
                "--date",
                DATE,
                "-q",
                "--out",
                single.to_str().unwrap(),
            ],
            extra,
        ]
        .concat(),
        cwd,
    );
    let single_code = code(&o);
    assert!([0, 1, 4].contains(&single_code), "{}", text(&o));
    let mut shards = Vec::new();
    for k in 0..n {
        let out = dir.join(format!("shard-{k}"));
        let spec = format!("{k}/{n}");
        let o = run(
            &[
                "plan",
                plan,
                "--shard",
                &spec,
                "--out",
                out.to_str().unwrap(),
            ],
            cwd,
        );
        // A shard exits 0 whatever its verdicts: the merge judges.
        assert_eq!(code(&o), 0, "{}", text(&o));
        shards.push(out);
    }
    let merged = dir.join("merged");
    let mut args = vec![
        "merge",
        "--date",
        DATE,
        "-q",
        "--out",
        merged.to_str().unwrap(),
    ];
    args.extend(extra);
    // Shards given out of order: the merge orders by case index.
    args.extend(shards.iter().rev().map(|s| s.to_str().unwrap()));
    let o = run(&args, cwd);
    assert_eq!(code(&o), single_code, "merge: {}", text(&o));
    for f in COMPARED {
        let a = std::fs::read(single.join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(a == b, "{plan}: merged {f} differs from the single run's");
    }
    shards
}

#[test]
fn simulated_plan_in_three_shards_merges_to_the_single_run_byte_for_byte() {
    let dir = scratch("shard-sim");
    let plan = root().join("tests/fixtures/plans/small_failing.toml");
    let shards = single_and_merged(plan.to_str().unwrap(), 3, root(), &dir, &[]);
    // 4 equal cases over 3 shards go round-robin: 0 and 3, then 1, then 2.
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(shards[0].join("shard.json")).unwrap()).unwrap();
    assert_eq!(manifest["cases"], serde_json::json!([0, 3]));
    assert_eq!(manifest["case_count"], 4);
    assert!(shards[0].join("traces/2000lux-60hz-20pct.csv").is_file());
    // Traces too: every case's CSV is the single run's.
    for entry in std::fs::read_dir(dir.join("single/traces")).unwrap() {
        let name = entry.unwrap().file_name();
        let a = std::fs::read(dir.join("single/traces").join(&name)).unwrap();
        let b = std::fs::read(dir.join("merged/traces").join(&name)).unwrap();
        assert!(a == b, "trace {name:?} differs");
    }
}

#[test]
fn a_sweep_of_two_thousand_cases_in_two_shards_merges_to_the_single_run_byte_for_byte() {
    // More cases than a report lists: the merge reads them back from its
    // store, as the single run does, and both reports summarise alike.
    let dir = scratch("shard-sweep");
    let plan = dir.join("sweep-2100.toml");
    std::fs::write(&plan, ledflicker::bench::sweep_plan(210)).unwrap();
    single_and_merged(plan.to_str().unwrap(), 2, root(), &dir, &[]);
    for file in ["summary.csv", "junit.xml"] {
        let a = std::fs::read(dir.join("single").join(file)).unwrap();
        let b = std::fs::read(dir.join("merged").join(file)).unwrap();
        assert!(a == b, "merged {file} differs from the single run's");
    }
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("merged/results.json")).unwrap()).unwrap();
    assert_eq!(results["cases"].as_array().map(Vec::len), Some(2100));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn more_shards_than_cases_leaves_empty_shards_that_still_merge() {
    let dir = scratch("shard-empty");
    let plan = root().join("tests/fixtures/plans/base.toml");
    let shards = single_and_merged(
        plan.to_str().unwrap(),
        6,
        root(),
        &dir,
        &["--detail", "summary"],
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(shards[5].join("shard.json")).unwrap()).unwrap();
    assert_eq!(manifest["cases"], serde_json::json!([]));
}

/// Three CSV recordings from the independent generator, with segments
/// detected (so the trace charts draw the detection signal).
pub(crate) fn captured_plan(dir: &Path) -> PathBuf {
    let mut cases = String::new();
    for (i, (hz, phase)) in [(60.0, 0.57), (150.0, 0.2), (90.0, 0.4)]
        .into_iter()
        .enumerate()
    {
        let rec = Recording {
            name: "r",
            lead_in_s: i as f64,
            on_seen_s: 1.5,
            lead_out_s: 0.5,
            frequency_hz: hz,
            exposure_s: 5.0e-3,
            duty: 0.2,
            phase,
            dropped: None,
            overshoot: 0.3,
        };
        recgen::write_csv(&dir.join(format!("r{i}.csv")), &rec.frames());
        cases += &format!(
            "[[case]]\nid = \"r{i}\"\nsource = \"r{i}.csv\"\nlight-lux = 2000.0\nfrequency-hz = {hz}\nduty-cycle = 0.2\n\n"
        );
    }
    let text = format!(
        "format-version = 2\n[plan]\nid = \"shard-captured\"\ntitle = \"sharded captures\"\n\n\
         [sequence]\non-s = {}\noff-s = {}\npwm-s = {}\n\n[dut]\nbackend = \"captured\"\n\n\
         [capture]\nsettle-s = {}\n\n{cases}\
         [[roi]]\nname = \"led\"\nkind = \"led\"\nx-px = 0\ny-px = 0\nwidth-px = 1\nheight-px = 1\n",
        recgen::ON_S,
        recgen::OFF_S,
        recgen::PWM_S,
        recgen::SETTLE_S
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn captured_plan_shards_by_capture_and_merges_byte_for_byte() {
    let dir = scratch("shard-captured");
    captured_plan(&dir);
    let shards = single_and_merged("plan.toml", 2, &dir, &dir, &["--detail", "full"]);
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("merged/results.json")).unwrap()).unwrap();
    assert_eq!(
        results["cases"][0]["capture"]["segments"]["method"],
        "detected"
    );
    // The two shards split the three captures between them.
    let mut ran: Vec<u64> = Vec::new();
    for s in &shards {
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(s.join("shard.json")).unwrap()).unwrap();
        let cases = m["cases"].as_array().unwrap();
        assert!(!cases.is_empty(), "{m}");
        ran.extend(cases.iter().map(|c| c.as_u64().unwrap()));
    }
    ran.sort_unstable();
    assert_eq!(ran, [0, 1, 2]);
}

/// Video captures carry a sample frame and a lit frame each, rendered in
/// the shards as in a single run; the merge checks them and keeps them.
#[test]
fn the_p2020_video_plan_in_three_shards_merges_to_the_single_run_byte_for_byte() {
    let dir = scratch("shard-p2020");
    single_and_merged("test-plans/p2020-samples.toml", 3, root(), &dir, &[]);
    for f in ["frames/test_vid1.png", "frames/test_vid1-view.png"] {
        let (a, b) = (dir.join("single").join(f), dir.join("merged").join(f));
        assert!(a.is_file(), "{f}");
        assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap(), "{f}");
    }
}

/// Three shards of the small plan, for the refusal tests.
fn three_shards(name: &str) -> (PathBuf, Vec<PathBuf>) {
    let dir = scratch(name);
    let plan = dir.join("plan.toml");
    std::fs::copy(root().join("tests/fixtures/plans/base.toml"), &plan).unwrap();
    let shards: Vec<PathBuf> = (0..3)
        .map(|k| {
            let out = dir.join(format!("s{k}"));
            let o = run(
                &[
                    "plan",
                    "plan.toml",
                    "--shard",
                    &format!("{k}/3"),
                    "-q",
                    "--out",
                    out.to_str().unwrap(),
                ],
                &dir,
            );
            assert_eq!(code(&o), 0, "{}", text(&o));
            out
        })
        .collect();
    (dir, shards)
}

fn merge(dir: &Path, shards: &[&Path]) -> Output {
    let out = dir.join("merged");
    let mut args = vec![
        "merge",
        "--date",
        DATE,
        "-q",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(shards.iter().map(|s| s.to_str().unwrap()));
    run(&args, dir)
}

#[test]
fn a_missing_or_duplicated_shard_is_refused_and_named() {
    let (dir, s) = three_shards("shard-refuse");
    let o = merge(&dir, &[&s[0], &s[2]]);
    assert_eq!(code(&o), 2, "{}", text(&o));
    assert!(text(&o).contains("missing shard 1 of 3"), "{}", text(&o));
    assert!(!dir.join("merged").exists());

    let o = merge(&dir, &[&s[0], &s[1], &s[2], &s[1]]);
    assert_eq!(code(&o), 2, "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("shard 1/3 is given 2 times"), "{t}");
    assert!(t.contains(&format!("`{}`", s[1].display())), "{t}");

    // A copy of a shard under another name is a duplicate too.
    let copy = dir.join("s1-again");
    copy_dir(&s[1], &copy);
    let o = merge(&dir, &[&s[0], &s[1], &copy, &s[2]]);
    assert_eq!(code(&o), 2);
    assert!(text(&o).contains("s1-again"), "{}", text(&o));

    // The merge's own estimate is held to --max-memory before anything
    // is written.
    std::fs::remove_dir_all(&copy).unwrap();
    let out = dir.join("merged");
    let mut args = vec!["merge", "-q", "--max-memory", "1MB", "--out"];
    args.push(out.to_str().unwrap());
    args.extend(s.iter().map(|p| p.to_str().unwrap()));
    let o = run(&args, &dir);
    assert_eq!(code(&o), 2, "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("cannot merge the 3 shards of plan")
            && t.contains("the merge is too large: peak memory")
            && t.contains("at most 1 MB; --max-memory raises it"),
        "{t}"
    );
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("ledflicker-new"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // The glob form finds the three and merges.
    let o = run(
        &["merge", "--date", DATE, "-q", "--out", "merged", "s*"],
        &dir,
    );
    assert_eq!(code(&o), 0, "{}", text(&o));
    assert!(dir.join("merged/report.pdf").is_file());
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn shards_of_another_plan_a_changed_plan_or_a_damaged_file_are_refused() {
    let (dir, s) = three_shards("shard-mismatch");
    // A shard of another seed of the plan.
    let other = dir.join("other.toml");
    let text_of = std::fs::read_to_string(dir.join("plan.toml")).unwrap();
    std::fs::write(&other, text_of.replace("seed = 7", "seed = 8")).unwrap();
    let foreign = dir.join("foreign");
    let o = run(
        &[
            "plan",
            "other.toml",
            "--shard",
            "1/3",
            "-q",
            "--out",
            "foreign",
        ],
        &dir,
    );
    assert_eq!(code(&o), 0, "{}", text(&o));
    let o = merge(&dir, &[&s[0], &foreign, &s[2]]);
    assert_eq!(code(&o), 2);
    let t = text(&o);
    assert!(
        t.contains("plan hash") && t.contains("seed") && t.contains("foreign"),
        "{t}"
    );

    // A damaged case file.
    let cases = s[2].join("cases.cbor");
    let mut bytes = std::fs::read(&cases).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xff;
    std::fs::write(&cases, &bytes).unwrap();
    let o = merge(&dir, &[&s[0], &s[1], &s[2]]);
    assert_eq!(code(&o), 2);
    assert!(
        text(&o).contains("cases.cbor") && text(&o).contains("SHA-256"),
        "{}",
        text(&o)
    );
    bytes[mid] ^= 0xff;
    std::fs::write(&cases, &bytes).unwrap();

    // The plan changed after the shards ran.
    std::fs::write(dir.join("plan.toml"), format!("{text_of}\n# edited\n")).unwrap();
    let o = merge(&dir, &[&s[0], &s[1], &s[2]]);
    assert_eq!(code(&o), 2);
    assert!(
        text(&o).contains("changed since the shards ran"),
        "{}",
        text(&o)
    );

    // Not a shard directory at all.
    let o = merge(&dir, &[&dir.join("plan.toml")]);
    assert_eq!(code(&o), 2);
    assert!(text(&o).contains("not a shard directory"), "{}", text(&o));
}

#[test]
fn shard_flags_are_checked() {
    let dir = scratch("shard-flags");
    let plan = root().join("tests/fixtures/plans/base.toml");
    let plan = plan.to_str().unwrap();
    for bad in ["3/3", "1/0", "one/3"] {
        let o = run(&["plan", plan, "--shard", bad, "--out", "x"], &dir);
        assert_eq!(code(&o), 2, "{bad}: {}", text(&o));
        assert!(text(&o).contains(bad), "{}", text(&o));
    }
    // --shard writes a shard directory, so it needs --out and no report flags.
    let o = run(&["plan", plan, "--shard", "0/2"], &dir);
    assert_eq!(code(&o), 2, "{}", text(&o));
    let o = run(&["plan", plan, "--shard", "auto", "--out", "x"], &dir);
    assert_eq!(code(&o), 2, "{}", text(&o));
    assert!(text(&o).contains("SLURM_ARRAY_TASK_ID"), "{}", text(&o));
    // A user's folder is never a shard directory.
    std::fs::create_dir_all(dir.join("mine")).unwrap();
    std::fs::write(dir.join("mine/notes.txt"), "keep").unwrap();
    let o = run(&["plan", plan, "--shard", "0/2", "--out", "mine"], &dir);
    assert_eq!(code(&o), 2, "{}", text(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("mine/notes.txt")).unwrap(),
        "keep"
    );
}

#[test]
fn shard_auto_reads_slurm_and_kubernetes_indices() {
    let dir = scratch("shard-auto");
    let plan = root().join("tests/fixtures/plans/base.toml");
    let manifest = |out: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(dir.join(out).join("shard.json")).unwrap()).unwrap()
    };
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args([
            "plan",
            plan.to_str().unwrap(),
            "--shard",
            "auto",
            "-q",
            "--out",
            "slurm",
        ])
        .current_dir(&dir)
        .env("SLURM_ARRAY_TASK_ID", "3")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .env("SLURM_ARRAY_TASK_MIN", "1")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap();
    assert_eq!(code(&o), 0, "{}", text(&o));
    assert_eq!(
        manifest("slurm")["shard"],
        serde_json::json!({"index": 2, "count": 3})
    );
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
        .env("LEDFLICKER_DB", crate::test_db())
        .args([
            "plan",
            plan.to_str().unwrap(),
            "--shard",
            "auto",
            "-q",
            "--out",
            "k8s",
        ])
        .current_dir(&dir)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env("JOB_COMPLETION_INDEX", "1")
        .env("LEDFLICKER_SHARD_COUNT", "2")
        .output()
        .unwrap();
    assert_eq!(code(&o), 0, "{}", text(&o));
    assert_eq!(
        manifest("k8s")["shard"],
        serde_json::json!({"index": 1, "count": 2})
    );
    assert_eq!(manifest("k8s")["cases"], serde_json::json!([1, 3]));
}

#[test]
fn a_merged_report_signs_and_verifies() {
    let (dir, s) = three_shards("shard-sign");
    let o = merge(&dir, &[&s[0], &s[1], &s[2]]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let key = dir.join("keys/tester.key");
    std::fs::create_dir_all(dir.join("keys")).unwrap();
    let o = ledflicker(&[
        "keygen",
        "--signer",
        "Ada Tester, Tested by",
        "--org",
        "Lab GmbH",
        "--out",
        key.to_str().unwrap(),
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let merged = dir.join("merged");
    let o = ledflicker(&[
        "sign",
        merged.to_str().unwrap(),
        "--key",
        key.to_str().unwrap(),
        "--signer",
        "Ada Tester, Tested by",
        "--date",
        DATE,
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let crt = dir.join("keys/tester.crt");
    let o = ledflicker(&[
        "verify",
        merged.to_str().unwrap(),
        "--trust",
        crt.to_str().unwrap(),
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    // A signed merged report is not overwritten without --force.
    let o = merge(&dir, &[&s[0], &s[1], &s[2]]);
    assert_eq!(code(&o), 2, "{}", text(&o));
}

fn yaml(name: &str) -> serde_yaml::Value {
    let path = root().join("examples/kubernetes").join(name);
    serde_yaml::from_str(&std::fs::read_to_string(&path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn strings(v: &serde_yaml::Value) -> Vec<String> {
    v.as_sequence()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

/// The container's env var `name`, from the manifest.
fn env_value(container: &serde_yaml::Value, name: &str) -> Option<String> {
    container["env"]
        .as_sequence()?
        .iter()
        .find(|e| e["name"] == name)
        .and_then(|e| e["value"].as_str().map(str::to_string))
}

#[test]
fn kubernetes_manifests_parse_and_their_commands_run() {
    let pvc = yaml("volume.yaml");
    let shards = yaml("shards-job.yaml");
    let merge_job = yaml("merge-job.yaml");
    assert_eq!(pvc["kind"], "PersistentVolumeClaim");
    assert!(strings(&pvc["spec"]["accessModes"]).contains(&"ReadWriteMany".to_string()));
    let claim = pvc["metadata"]["name"].as_str().unwrap();
    let spec = &shards["spec"];
    assert_eq!(shards["kind"], "Job");
    assert_eq!(spec["completionMode"], "Indexed");
    let completions = spec["completions"].as_u64().unwrap();
    assert!(spec["parallelism"].as_u64().unwrap() <= completions);
    let mut pods = Vec::new();
    for job in [&shards, &merge_job] {
        let pod = &job["spec"]["template"]["spec"];
        assert_eq!(pod["restartPolicy"], "Never");
        assert_eq!(
            pod["volumes"][0]["persistentVolumeClaim"]["claimName"],
            claim
        );
        let c = &pod["containers"][0];
        assert_eq!(c["volumeMounts"][0]["name"], pod["volumes"][0]["name"]);
        assert_eq!(c["volumeMounts"][0]["mountPath"], c["workingDir"]);
        assert_eq!(strings(&c["command"]), ["ledflicker"]);
        pods.push(c.clone());
    }
    assert_eq!(pods[0]["workingDir"], pods[1]["workingDir"]);
    // --shard auto reads the count the manifest passes: spec.completions.
    assert_eq!(
        env_value(&pods[0], "LEDFLICKER_SHARD_COUNT"),
        Some(completions.to_string())
    );
    let shard_args = strings(&pods[0]["args"]);
    assert!(
        shard_args.windows(2).any(|w| w == ["--shard", "auto"]),
        "{shard_args:?}"
    );
    let merge_args = strings(&pods[1]["args"]);
    assert_eq!(merge_args[0], "merge");

    // Run both Jobs' commands as the pods would, in a scratch /work that
    // holds the small plan under the manifest's plan path.
    let work = scratch("shard-k8s");
    let plan_arg = &shard_args[1];
    std::fs::create_dir_all(work.join(plan_arg).parent().unwrap()).unwrap();
    std::fs::copy(
        root().join("tests/fixtures/plans/base.toml"),
        work.join(plan_arg),
    )
    .unwrap();
    for k in 0..completions {
        let args: Vec<String> = shard_args
            .iter()
            .map(|a| a.replace("$(JOB_COMPLETION_INDEX)", &k.to_string()))
            .collect();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_ledflicker"))
            .env("LEDFLICKER_DB", crate::test_db())
            .args(&args)
            .current_dir(&work)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env("JOB_COMPLETION_INDEX", k.to_string())
            .env(
                "LEDFLICKER_SHARD_COUNT",
                env_value(&pods[0], "LEDFLICKER_SHARD_COUNT").unwrap(),
            )
            .output()
            .unwrap();
        assert_eq!(code(&o), 0, "shard {k}: {}", text(&o));
    }
    let o = run(
        &merge_args.iter().map(String::as_str).collect::<Vec<_>>(),
        &work,
    );
    assert_eq!(code(&o), 0, "{}", text(&o));
    assert!(
        text(&o).contains(&format!("merged {completions} shards")),
        "{}",
        text(&o)
    );
}

#[test]
fn rig_plan_shards_by_case_and_merges() {
    let dir = scratch("shard-rig");
    let plan = "test-plans/command-sim-rig.toml";
    let single = dir.join("single");
    let o = run(
        &[
            "plan",
            plan,
            "--date",
            DATE,
            "-q",
            "--out",
            single.to_str().unwrap(),
        ],
        root(),
    );
    assert_eq!(code(&o), 0, "{}", text(&o));
    let mut args = vec![
        "merge".to_string(),
        "--date".into(),
        DATE.into(),
        "-q".into(),
    ];
    args.extend(["--out".into(), dir.join("merged").display().to_string()]);
    for k in 0..2 {
        let out = dir.join(format!("s{k}"));
        let spec = format!("{k}/2");
        let o = run(
            &[
                "plan",
                plan,
                "--shard",
                &spec,
                "--out",
                out.to_str().unwrap(),
            ],
            root(),
        );
        assert_eq!(code(&o), 0, "{}", text(&o));
        args.push(out.display().to_string());
    }
    let o = run(&args.iter().map(String::as_str).collect::<Vec<_>>(), root());
    assert_eq!(code(&o), 0, "{}", text(&o));
    for f in ["report.html", "report.pdf"] {
        let a = std::fs::read(single.join(f)).unwrap();
        let b = std::fs::read(dir.join("merged").join(f)).unwrap();
        assert!(a == b, "rig plan: merged {f} differs");
    }
    let a = std::fs::read_to_string(single.join("results.json")).unwrap();
    let b = std::fs::read_to_string(dir.join("merged/results.json")).unwrap();
    assert!(
        !a.contains("ledflicker-rig-"),
        "results.json must not name the rig's random scratch directory"
    );
    assert!(a.contains("image sequence `frames`"), "{a}");
    assert_eq!(a, b, "rig plan: merged results.json differs");
}
