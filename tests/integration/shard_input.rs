//! A shard is input like any other (docs/scale-out.md): `merge` checks
//! each shard file's structure and invariants against the plan and
//! evaluates every case again from its traces, so a `cases.cbor` edited and
//! given a matching SHA-256 is refused with exit 2 naming the shard file
//! and the case, or, when its data are sound, judged afresh: a shard
//! carries data, never conclusions. A FIFO in place of a shard file is
//! refused at once.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use ledflicker::backend::RenderedFrame;
use ledflicker::metrics::Verdict;
use ledflicker::metrics::flicker::Segment;
use ledflicker::shard::record::{self, ShardCase};

use crate::{Ran, ledflicker_in, mkfifo, root, run_with_deadline, scratch, text};

const DATE: &str = "2026-11-23";

fn code(o: &Output) -> i32 {
    o.status.code().unwrap_or(-1)
}

/// `plan` (a fixture) copied into a scratch directory, run once into
/// `single` and as two shards `s0`, `s1`; returns the directory, the shard
/// directories and the single run's exit code.
fn two_shards(name: &str, plan: &str) -> (PathBuf, Vec<PathBuf>, i32) {
    let dir = scratch(name);
    std::fs::copy(
        root().join("tests/fixtures/plans").join(plan),
        dir.join("plan.toml"),
    )
    .unwrap();
    let o = ledflicker_in(
        &["plan", "plan.toml", "--date", DATE, "-q", "--out", "single"],
        &dir,
    );
    let single = code(&o);
    assert!([0, 1].contains(&single), "{}", text(&o));
    let shards = (0..2)
        .map(|k| {
            let out = dir.join(format!("s{k}"));
            let o = ledflicker_in(
                &[
                    "plan",
                    "plan.toml",
                    "--shard",
                    &format!("{k}/2"),
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
    (dir, shards, single)
}

/// Rewrites the shard's `cases.cbor` through `edit` and gives its manifest
/// the new file's SHA-256, as someone editing a shard would.
fn tamper(shard: &Path, edit: impl FnOnce(&mut Vec<ShardCase>)) {
    let path = shard.join(record::CASES);
    let bytes = std::fs::read(&path).unwrap();
    let mut cases = record::decode_cases(&bytes, &path).unwrap();
    edit(&mut cases);
    // As the shard writes it: the detection signal beside the result.
    for c in &mut cases {
        if let Some(s) = &mut c.result.acquisition.capture {
            c.capture_signal = std::mem::take(&mut s.segments.signal);
        }
    }
    let bytes = record::encode_cases(&cases).unwrap();
    std::fs::write(&path, &bytes).unwrap();
    edit_manifest(shard, |m| {
        m["cases_sha256"] = ledflicker::util::sha256_hex(&bytes).into();
    });
}

fn edit_manifest(shard: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let path = shard.join(record::MANIFEST);
    let mut m: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut m);
    std::fs::write(&path, serde_json::to_vec_pretty(&m).unwrap()).unwrap();
}

fn merge(dir: &Path, shards: &[PathBuf]) -> Output {
    let mut args = vec!["merge", "--date", DATE, "-q", "--out", "merged"];
    args.extend(shards.iter().map(|s| s.to_str().unwrap()));
    ledflicker_in(&args, dir)
}

/// Exit 2, no panic, no report, and the message names every `needles`.
fn assert_refused(dir: &Path, o: &Output, needles: &[&str]) {
    let ran = Ran {
        code: o.status.code(),
        stderr: text(o),
    };
    assert_ran_refused(dir, &ran, needles);
}

/// [`assert_refused`] of a run made with a deadline.
fn assert_ran_refused(dir: &Path, ran: &Ran, needles: &[&str]) {
    let t = &ran.stderr;
    assert_eq!(ran.code, Some(2), "{t}");
    assert!(!t.contains("panicked"), "{t}");
    for n in needles {
        assert!(t.contains(n), "`{n}` not in: {t}");
    }
    assert!(!dir.join("merged/results.json").exists(), "{t}");
}

#[test]
fn a_trace_shorter_than_its_frames_with_a_matching_hash_is_refused_naming_shard_and_case() {
    let (dir, s, _) = two_shards("shard-in-short", "base.toml");
    let mut id = String::new();
    tamper(&s[1], |cases| {
        let c = &mut cases[0].result;
        id = c.case.id.clone();
        c.acquisition.rois[0].luma.pop();
    });
    let o = merge(&dir, &s);
    assert_refused(
        &dir,
        &o,
        &[
            "s1/cases.cbor",
            &format!("(`{id}`)"),
            "luma values for",
            "hint",
        ],
    );
}

#[test]
fn a_nan_infinite_or_out_of_range_luma_is_refused_not_reported() {
    let (dir, s, _) = two_shards("shard-in-nan", "base.toml");
    for bad in [f64::NAN, f64::INFINITY] {
        tamper(&s[0], |cases| {
            cases[1].result.acquisition.rois[0].luma[40] = bad;
        });
        let o = merge(&dir, &s);
        assert_refused(&dir, &o, &["s0/cases.cbor", "not a finite number"]);
    }
    // Finite luma so large that its sums overflow.
    tamper(&s[0], |cases| {
        let luma = &mut cases[1].result.acquisition.rois[0].luma;
        luma.iter_mut().for_each(|v| *v = f64::MAX);
    });
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "out of range"]);
    // A non-finite frame time too.
    tamper(&s[0], |cases| {
        cases[0].result.acquisition.frames[3].time_s = f64::NAN;
    });
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "not finite"]);
}

#[test]
fn empty_frames_or_rois_are_invalid_input_not_a_tool_failure() {
    let (dir, s, _) = two_shards("shard-in-empty", "base.toml");
    let original = std::fs::read(s[0].join(record::CASES)).unwrap();
    let restore = || {
        std::fs::write(s[0].join(record::CASES), &original).unwrap();
        edit_manifest(&s[0], |m| {
            m["cases_sha256"] = ledflicker::util::sha256_hex(&original).into();
        });
    };
    tamper(&s[0], |cases| {
        let a = &mut cases[0].result.acquisition;
        a.frames.clear();
        a.rois.iter_mut().for_each(|r| r.luma.clear());
    });
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "PWM"]);
    restore();
    tamper(&s[0], |cases| cases[0].result.acquisition.rois.clear());
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "ROI traces"]);
    // A case of another plan, or under another id, is not this plan's.
    restore();
    tamper(&s[0], |cases| cases[0].result.case.id = "other".into());
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "`other`"]);
    restore();
    let o = merge(&dir, &s);
    assert_eq!(code(&o), 0, "{}", text(&o));
}

#[test]
fn a_simulated_case_without_its_picture_or_with_a_broken_one_is_refused() {
    let (dir, s, _) = two_shards("shard-in-picture", "base.toml");
    let original = std::fs::read(s[1].join(record::CASES)).unwrap();
    let restore = || {
        std::fs::write(s[1].join(record::CASES), &original).unwrap();
        edit_manifest(&s[1], |m| {
            m["cases_sha256"] = ledflicker::util::sha256_hex(&original).into();
        });
    };
    tamper(&s[1], |cases| cases[0].result.sample_frame = None);
    assert_refused(
        &dir,
        &merge(&dir, &s),
        &["s1/cases.cbor", "sample frame is none"],
    );
    restore();
    tamper(&s[1], |cases| {
        let f = cases[0].result.sample_frame.as_mut().unwrap();
        f.index += 1;
    });
    assert_refused(&dir, &merge(&dir, &s), &["s1/cases.cbor", "sample frame"]);
    restore();
    tamper(&s[1], |cases| {
        let f = cases[0].result.sample_frame.as_ref().unwrap();
        let mut pixels: Vec<f64> = (0..f.height).flat_map(|y| f.row(y)).collect();
        pixels[f.width as usize * 7 + 3] = f64::NAN;
        let broken =
            RenderedFrame::from_pixels(f.index, f.width, f.height, &pixels, f.full_scale_dn);
        cases[0].result.sample_frame = Some(broken);
    });
    assert_refused(
        &dir,
        &merge(&dir, &s),
        &["s1/cases.cbor", "row 7", "not finite"],
    );
}

#[test]
fn a_pass_written_over_a_failed_case_is_judged_again_from_the_traces() {
    let (dir, s, single) = two_shards("shard-in-verdict", "small_failing.toml");
    assert_eq!(single, 1, "the fixture plan fails");
    for shard in &s {
        tamper(shard, |cases| {
            for c in cases.iter_mut() {
                let r = &mut c.result;
                r.verdict = Verdict::Pass;
                r.checks.iter_mut().for_each(|k| k.pass = true);
                r.not_judged = None;
                for m in &mut r.metrics {
                    m.percent_flicker.value = Some(0.0);
                }
            }
        });
    }
    let o = merge(&dir, &s);
    assert_eq!(code(&o), 1, "{}", text(&o));
    for f in ["results.json", "report.html", "summary.csv", "junit.xml"] {
        let a = std::fs::read(dir.join("single").join(f)).unwrap();
        let b = std::fs::read(dir.join("merged").join(f)).unwrap();
        assert!(a == b, "merged {f} differs from the single run's");
    }
}

#[test]
fn a_manifest_that_does_not_describe_the_plan_is_refused() {
    let (dir, s, _) = two_shards("shard-in-manifest", "base.toml");
    let originals: Vec<Vec<u8>> = s
        .iter()
        .map(|d| std::fs::read(d.join(record::MANIFEST)).unwrap())
        .collect();
    // Edited alike in both shards, so that they agree with each other.
    for (key, value, needle) in [
        ("backend", serde_json::json!("captured"), "backend captured"),
        ("plan_id", serde_json::json!("another"), "plan id another"),
        ("seed", serde_json::json!(8), "seed 8"),
        ("cases", serde_json::json!([]), "case list []"),
    ] {
        for d in &s {
            edit_manifest(d, |m| m[key] = value.clone());
        }
        let o = merge(&dir, &s);
        assert_refused(&dir, &o, &["s0/shard.json", needle, "hint"]);
        for (d, bytes) in s.iter().zip(&originals) {
            std::fs::write(d.join(record::MANIFEST), bytes).unwrap();
        }
    }
    // An input's recorded SHA-256 that is not the plan's.
    for d in &s {
        edit_manifest(d, |m| m["inputs"][0]["sha256"] = "00".into());
    }
    assert_refused(&dir, &merge(&dir, &s), &["s0/shard.json", "inputs"]);
}

#[test]
fn a_captured_case_at_odds_with_its_own_segments_is_refused() {
    let dir = scratch("shard-in-captured");
    crate::shard::captured_plan(&dir);
    let s: Vec<PathBuf> = (0..2)
        .map(|k| {
            let out = dir.join(format!("s{k}"));
            let o = ledflicker_in(
                &[
                    "plan",
                    "plan.toml",
                    "--shard",
                    &format!("{k}/2"),
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
    let original = std::fs::read(s[0].join(record::CASES)).unwrap();
    let restore = || {
        std::fs::write(s[0].join(record::CASES), &original).unwrap();
        edit_manifest(&s[0], |m| {
            m["cases_sha256"] = ledflicker::util::sha256_hex(&original).into();
        });
    };
    // A PWM frame relabelled OFF.
    tamper(&s[0], |cases| {
        let a = &mut cases[0].result.acquisition;
        let f = a
            .frames
            .iter_mut()
            .rev()
            .find(|f| f.segment == Segment::Pwm)
            .unwrap();
        f.segment = Segment::Off;
    });
    assert_refused(
        &dir,
        &merge(&dir, &s),
        &["s0/cases.cbor", "is labelled off"],
    );
    // A frame count no capture has: refused at once, never counted out.
    restore();
    tamper(&s[0], |cases| {
        let c = cases[0].result.acquisition.capture.as_mut().unwrap();
        c.segments.capture_frames = u64::MAX;
    });
    let ran = merge_within(&dir, &s, &[], Duration::from_secs(60));
    assert_ran_refused(&dir, &ran, &["s0/cases.cbor", "detection signal"]);
    // A picture the captured backend never renders.
    restore();
    let picture = RenderedFrame::from_pixels(0, 2, 2, &[1.0; 4], 255.0);
    tamper(&s[0], |cases| cases[0].result.sample_frame = Some(picture));
    assert_refused(&dir, &merge(&dir, &s), &["s0/cases.cbor", "sample frame"]);
    restore();
    let o = merge(&dir, &s);
    assert!([0, 1, 4].contains(&code(&o)), "{}", text(&o));
}

/// Runs `merge` with a deadline: a FIFO must be refused, not waited on.
fn merge_within(dir: &Path, shards: &[PathBuf], fifos: &[PathBuf], limit: Duration) -> Ran {
    let mut args = vec!["merge", "--date", DATE, "-q", "--out", "merged"];
    args.extend(shards.iter().map(|s| s.to_str().unwrap()));
    run_with_deadline(&args, dir, fifos, limit)
}

#[test]
fn a_fifo_in_place_of_a_shard_file_is_refused_at_once() {
    for file in [record::MANIFEST, record::CASES] {
        let (dir, s, _) = two_shards(&format!("shard-in-fifo-{file}"), "base.toml");
        std::fs::remove_file(s[1].join(file)).unwrap();
        mkfifo(&s[1].join(file));
        let fifo = s[1].join(file);
        let ran = merge_within(&dir, &s, &[fifo], Duration::from_secs(20));
        assert_ran_refused(&dir, &ran, &[&format!("s1/{file}"), "FIFO"]);
    }
}
