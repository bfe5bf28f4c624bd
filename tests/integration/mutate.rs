//! Seeded mutation tests: the shipped plans and small capture
//! files, mutated a fixed number of times from fixed seeds, so that what
//! they cover does not depend on the machine's speed. Asserted
//! for every mutant: no panic; an error maps to exit code 2 (bad input) or
//! 3 (tool), never anything else; a plan that validates has a work estimate
//! within the documented limits, and, when small, runs with exactly the
//! estimated cases and frames and no NaN in its traces and exports.
//!
//! The mutator is our own (xorshift64*, seeded), so a failure reproduces:
//! the message prints the seed and the mutant, and every run tries the
//! same mutants; each test prints its counts.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use ledflicker::capture::{self, LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange};
use ledflicker::plan::{self, WorkEstimate, bounds};

use crate::{root, scratch};

/// Plan mutants of each run.
const PLAN_MUTANTS: usize = 300;

/// Capture mutants of each run.
const CAPTURE_MUTANTS: usize = 800;

/// xorshift64*: small, seeded, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Values that have broken parsers and numeric code before.
const NASTY: &[&str] = &[
    "0",
    "-0.0",
    "-1",
    "1e9",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551616",
    "0.0000001",
    "90.0000001",
    "4294967295",
    "4294967296",
    "\"\"",
    "\"x\"",
    "[]",
    "[1e9]",
    "true",
    "{}",
    "100000",
    "2147483648",
];

/// One mutation of a text plan: a number replaced by a nasty value, a line
/// deleted or duplicated, bytes flipped, inserted or truncated.
fn mutate_text(text: &str, rng: &mut Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    match rng.below(6) {
        0 | 1 => {
            // Replace the value of a `key = value` line.
            let candidates: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].contains(" = ") && !lines[i].starts_with('#'))
                .collect();
            if let Some(&i) = candidates.get(rng.below(candidates.len())) {
                let key = lines[i].split(" = ").next().unwrap_or("").to_string();
                lines[i] = format!("{key} = {}", NASTY[rng.below(NASTY.len())]);
            }
        }
        2 => {
            if !lines.is_empty() {
                lines.remove(rng.below(lines.len()));
            }
        }
        3 => {
            if !lines.is_empty() {
                let i = rng.below(lines.len());
                let l = lines[i].clone();
                lines.insert(rng.below(lines.len()), l);
            }
        }
        _ => {
            let mut bytes = text.as_bytes().to_vec();
            mutate_bytes(&mut bytes, rng);
            return String::from_utf8_lossy(&bytes).into_owned();
        }
    }
    lines.join("\n") + "\n"
}

/// Byte-level mutations: flip, overwrite with junk, insert, delete, truncate.
fn mutate_bytes(bytes: &mut Vec<u8>, rng: &mut Rng) {
    let n = bytes.len().max(1);
    for _ in 0..=rng.below(3) {
        let i = rng.below(bytes.len());
        match rng.below(5) {
            0 if !bytes.is_empty() => bytes[i] ^= 1 << rng.below(8),
            1 if !bytes.is_empty() => bytes[i] = rng.next() as u8,
            2 => {
                let junk: Vec<u8> = (0..1 + rng.below(8)).map(|_| rng.next() as u8).collect();
                bytes.splice(i..i, junk);
            }
            3 if !bytes.is_empty() => {
                let end = (i + 1 + rng.below(16)).min(bytes.len());
                bytes.drain(i..end);
            }
            _ => bytes.truncate(rng.below(n)),
        }
    }
}

/// Outcomes of a mutation run.
#[derive(Debug, Default)]
struct Counts {
    mutants: usize,
    invalid: usize,
    valid: usize,
    ran: usize,
}

fn shipped_plans() -> Vec<PathBuf> {
    let mut v = Vec::new();
    for dir in ["test-plans", "tests/fixtures/plans"] {
        for e in std::fs::read_dir(root().join(dir)).unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "toml") {
                v.push(e.path());
            }
        }
    }
    v.sort();
    v
}

/// Runs a small validated simulator plan and checks it against its estimate.
fn run_within_estimate(p: &plan::Plan, e: &WorkEstimate, what: &str) {
    let cases = plan::expand_cases(p);
    assert_eq!(cases.len(), e.cases, "{what}");
    let sim = ledflicker::backend::sim::Simulator::new(p);
    let results = match ledflicker::runner::run(p, &cases, &sim, Some(1), &|_| {}) {
        Ok(r) => r,
        // A plan can validate and still have no usable trace (e.g. all
        // frames saturated); that is a run error, exit code 3, not a panic.
        Err(_) => return,
    };
    for r in &results {
        assert_eq!(
            r.acquisition.frames.len() as u64,
            e.frames_per_case,
            "{what}"
        );
        let csv = ledflicker::report::trace_csv(r);
        assert!(
            !csv.contains("NaN") && !csv.contains("inf"),
            "{what}: NaN in a trace"
        );
    }
}

#[test]
fn mutated_plans_never_panic_and_validated_plans_stay_within_their_estimate() {
    let plans: Vec<(PathBuf, String)> = shipped_plans()
        .into_iter()
        .map(|p| {
            let t = std::fs::read_to_string(&p).unwrap();
            (p, t)
        })
        .collect();
    let mut rng = Rng(0x1ed_f11c_2026);
    let mut counts = Counts::default();
    for _ in 0..PLAN_MUTANTS {
        let (path, text) = &plans[rng.below(plans.len())];
        let mut mutant = text.clone();
        for _ in 0..=rng.below(3) {
            mutant = mutate_text(&mutant, &mut rng);
        }
        let what = format!(
            "mutant of {} (#{}):\n{mutant}",
            path.display(),
            counts.mutants
        );
        counts.mutants += 1;
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            plan::parse(&mutant, path, String::new()).map(|p| {
                let e = WorkEstimate::of(&p);
                (p, e)
            })
        }));
        match outcome {
            Err(_) => panic!("panic on {what}"),
            Ok(Err(err)) => {
                counts.invalid += 1;
                let code = ledflicker::cli::Failure::from(err).exit_code();
                assert_eq!(code, ledflicker::exit::ExitCode::Invalid, "{what}");
            }
            Ok(Ok((p, e))) => {
                counts.valid += 1;
                assert!(
                    e.row_integrals <= bounds::MAX_ROW_INTEGRALS
                        && e.memory_bytes <= bounds::MAX_MEMORY_BYTES
                        && e.output_bytes <= bounds::MAX_OUTPUT_BYTES,
                    "{what}: validated beyond the limits: {}",
                    e.summary()
                );
                let small = e.row_integrals < 2.0e5 && e.frame_pixels < 4.0e6 as u64;
                if small && p.dut.backend == plan::BackendKind::Simulator && counts.ran < 40 {
                    counts.ran += 1;
                    run_within_estimate(&p, &e, &what);
                }
            }
        }
    }
    eprintln!("plan mutations: {counts:?}");
    assert!(
        counts.valid > 0 && counts.invalid > 0 && counts.ran > 0,
        "{counts:?}"
    );
}

fn rois() -> Vec<RoiRect> {
    vec![RoiRect {
        x: 1,
        y: 1,
        width: 2,
        height: 2,
    }]
}

fn options() -> ReadOptions {
    ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        colour_transfer: ledflicker::capture::ColourTransfer::Linear,
        fps: Some(30.0),
        decoder_threads: None,
    }
}

/// Small valid seeds: a Y4M file, a CSV trace, a 16-bit PNG frame.
fn capture_seeds(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut y4m = b"YUV4MPEG2 W4 H4 F30:1 Ip A1:1 Cmono\n".to_vec();
    for k in 0..6u8 {
        y4m.extend(b"FRAME\n");
        y4m.extend(std::iter::repeat_n(20 + 10 * k, 16));
    }
    let mut csv = String::from("frame,time_s,a\n");
    for k in 0..8 {
        csv += &format!("{k},{},{}\n", k as f64 / 30.0, 10 + k * 5);
    }
    let png = dir.join("seed.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(4, 4, |x, y| {
        image::Luma([(x * 1000 + y * 100) as u16])
    })
    .save(&png)
    .unwrap();
    vec![
        ("y4m".to_string(), y4m),
        ("csv".to_string(), csv.into_bytes()),
        ("png".to_string(), std::fs::read(&png).unwrap()),
    ]
}

#[test]
fn mutated_captures_never_panic_and_give_finite_traces_or_input_errors() {
    let dir = scratch("mutate-captures");
    let seeds = capture_seeds(&dir);
    let names = vec!["a".to_string()];
    let mut rng = Rng(0xca97_0e5d);
    let (mut mutants, mut ok, mut input, mut tool) = (0usize, 0usize, 0usize, 0usize);
    for _ in 0..CAPTURE_MUTANTS {
        let (ext, seed) = &seeds[rng.below(seeds.len())];
        let mut bytes = seed.clone();
        mutate_bytes(&mut bytes, &mut rng);
        let path = dir.join(format!("m.{ext}"));
        std::fs::write(&path, &bytes).unwrap();
        mutants += 1;
        let r = catch_unwind(AssertUnwindSafe(|| {
            capture::read_capture(&path, &rois(), &names, &options())
        }));
        let what = format!("{ext} mutant #{mutants}: {bytes:?}");
        match r {
            Err(_) => panic!("panic on {what}"),
            Ok(Ok(t)) => {
                ok += 1;
                assert!(t.time_s.iter().all(|x| x.is_finite()), "{what}");
                assert!(t.time_s.windows(2).all(|w| w[1] > w[0]), "{what}");
                assert!(t.luma.iter().flatten().all(|x| x.is_finite()), "{what}");
            }
            Ok(Err(e)) if e.is_input_error() => input += 1,
            Ok(Err(_)) => tool += 1,
        }
    }
    eprintln!(
        "capture mutations: {mutants} mutants, {ok} read, {input} input errors (exit 2), {tool} tool errors (exit 3)"
    );
    assert!(ok > 0 && input > 0, "{ok} read, {input} input errors");
}
