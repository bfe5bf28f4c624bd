//! Property tests (proptest) over random inputs within the plan's valid
//! ranges: the batched closed form equals the per-frame one, shards
//! partition a plan's cases, and results.json reads back to the same bytes.
//!
//! Each property runs a fixed number of cases from a fixed seed, and
//! writes no persistence file: every run, on any machine, tries the same
//! inputs, so a pass or a failure does not depend on the machine or on
//! earlier runs, and a failure reproduces by running the test again (the
//! shrunk input is in the panic message). Random seeds and a committed
//! `proptest-regressions/` would explore more over time, at the price of
//! a CI that can fail on a change nobody made.

use ledflicker::backend::sim::Simulator;
use ledflicker::physics::{PwmDrive, Shutter, ShutterModel};
use ledflicker::plan::{self, Plan, bounds};
use ledflicker::runner;
use ledflicker::shard::{ShardSpec, assign};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

/// `cases` inputs from a fixed seed, nothing persisted (module doc).
fn config(cases: u32) -> Config {
    Config {
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(0x1ed_f11c),
        ..Config::with_cases(cases)
    }
}

/// A camera and a PWM drive within the plan's bounds: 1 to 1000 fps, an
/// exposure from 1 us to the frame time, a global or rolling shutter,
/// 1 Hz to the largest PWM frequency, any duty from the smallest to 1,
/// a delay within the plan's limit.
fn drive_and_camera() -> impl Strategy<Value = (Shutter, PwmDrive)> {
    (
        bounds::MIN_FPS..=bounds::MAX_FPS,
        0.0..=1.0f64,
        prop::option::of(0.0..=100e-6f64),
        prop_oneof![1.0..=2000.0f64, 1.0..=bounds::MAX_FREQUENCY_HZ],
        prop_oneof![Just(1.0), bounds::MIN_DUTY..=1.0f64],
        -bounds::MAX_PWM_DELAY_S..=bounds::MAX_PWM_DELAY_S,
    )
        .prop_map(|(fps, share, line_time_s, f, duty, delay)| {
            let exposure_s = (share / fps).max(bounds::MIN_EXPOSURE_S);
            let model = match line_time_s {
                None => ShutterModel::Global,
                Some(line_time_s) => ShutterModel::Rolling { line_time_s },
            };
            let shutter = Shutter {
                model,
                exposure_s,
                fps,
            };
            let pwm = PwmDrive::new(f, duty, delay).expect("within the plan's bounds");
            (shutter, pwm)
        })
}

proptest! {
    #![proptest_config(config(256))]

    /// The batched closed form is documented as bit-identical to the
    /// per-frame one: tolerance 0 ulp, over any frame range of a case
    /// (first frame up to the plan's frame limit) and 1 to 8 ROI rows.
    #[test]
    fn batched_on_fractions_equal_frame_by_frame(
        (shutter, pwm) in drive_and_camera(),
        first in 0..bounds::MAX_FRAMES_PER_CASE,
        len in 0u64..600,
        row in 0u32..2000,
        rows in 1u32..=8,
    ) {
        let frames = first..first + len;
        let rows = row..row + rows;
        let mut batched = vec![-1.0];
        shutter.frame_on_fractions(&pwm, frames.clone(), rows.clone(), &mut batched);
        prop_assert_eq!(batched.len(), 1 + len as usize);
        prop_assert_eq!(batched[0], -1.0, "appends to what is there");
        for (k, got) in frames.zip(&batched[1..]) {
            let want = shutter.frame_on_fraction(&pwm, k, rows.clone());
            prop_assert!(got.is_finite() && (0.0..=1.0).contains(got), "frame {}: {}", k, got);
            prop_assert_eq!(got.to_bits(), want.to_bits(), "frame {}: {} != {}", k, got, want);
        }
    }
}

/// A small simulator plan (16 x 12 sensor, a 2 s sequence) from the test
/// fixture, with this grid, light, camera and seed.
fn tiny_plan(p: &TinyPlan) -> Plan {
    let list = |v: &[f64]| {
        let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        format!("[{}]", items.join(", "))
    };
    let text = format!(
        r#"format-version = 1

[plan]
id = "prop"
title = "property test plan"
seed = {seed}

[sequence]
on-s = 0.5
off-s = 0.5
pwm-s = 1.0

[light]
levels-lux = {lux}

[grid]
frequencies-hz = {freqs}
duty-cycles = {duties}

[dut]
backend = "simulator"
supplier = "Test"
model = "Ideal"

[dut.camera]
shutter = "{shutter}"
sensor-rows = 12
sensor-columns = 16
line-time-us = {line_time_us:?}
exposure-ms = {exposure_ms:?}
frame-rate-fps = {fps:?}
response-dn-per-cd-m2-s = 18.5

[thresholds]
fdi-2018-min = 0.1
mitigation-min-hz = 90.0

[[roi]]
name = "led"
x-px = 2
y-px = 4
width-px = 8
height-px = 2
"#,
        seed = p.seed,
        lux = list(&p.lux),
        freqs = list(&p.frequencies_hz),
        duties = list(&p.duties),
        shutter = if p.rolling { "rolling" } else { "global" },
        line_time_us = p.line_time_us,
        exposure_ms = p.exposure_ms,
        fps = p.fps,
    );
    plan::parse(&text, std::path::Path::new("prop.toml"), String::new())
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// What [`tiny_plan`] varies.
#[derive(Debug, Clone)]
struct TinyPlan {
    seed: u64,
    lux: Vec<f64>,
    frequencies_hz: Vec<f64>,
    duties: Vec<f64>,
    rolling: bool,
    line_time_us: f64,
    exposure_ms: f64,
    fps: f64,
}

/// Distinct values, ascending, rounded to `decimals` so that the plan's
/// text gives them back exactly.
fn distinct(
    range: std::ops::RangeInclusive<f64>,
    max: usize,
    decimals: i32,
) -> impl Strategy<Value = Vec<f64>> {
    let scale = 10f64.powi(decimals);
    prop::collection::vec(range, 1..=max).prop_map(move |v| {
        let mut v: Vec<f64> = v.into_iter().map(|x| (x * scale).round() / scale).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    })
}

fn tiny_plans(max_values: usize) -> impl Strategy<Value = TinyPlan> {
    (
        0..=i64::MAX as u64,
        distinct(1.0..=20_000.0, max_values, 1),
        distinct(20.0..=2000.0, max_values, 2),
        distinct(0.05..=1.0, max_values, 3),
        any::<bool>(),
        1.0..=30.0f64,
        0.05..=1.0f64,
        prop_oneof![Just(30.0), 10.0..=60.0f64],
    )
        .prop_map(
            |(seed, lux, frequencies_hz, duties, rolling, line_time_us, share, fps)| {
                let fps = (fps * 100.0).round() / 100.0;
                // Exposure and the readout of 12 rows fit in a frame.
                let exposure_ms = ((share * (1e3 / fps - 0.5)) * 1e3).round().max(1.0) / 1e3;
                TinyPlan {
                    seed,
                    lux,
                    frequencies_hz,
                    duties,
                    rolling,
                    line_time_us: (line_time_us * 1e3).round() / 1e3,
                    exposure_ms,
                    fps,
                }
            },
        )
}

proptest! {
    #![proptest_config(config(128))]

    /// Shard assignment over any weights: one shard each, in range.
    #[test]
    fn every_weight_gets_one_shard_in_range(
        weights in prop::collection::vec(0u64..1_000_000, 0..400),
        count in 1usize..64,
    ) {
        let shard = assign::assign(&weights, count);
        prop_assert_eq!(shard.len(), weights.len());
        prop_assert!(shard.iter().all(|&s| s < count), "{:?}", shard);
        // Deterministic: the merge recomputes it and must agree.
        prop_assert_eq!(assign::assign(&weights, count), shard);
    }

    /// The shards `0..N` of a plan run every case exactly once, in plan
    /// order within each shard, for any plan size and any N (more shards
    /// than cases too).
    #[test]
    fn shards_partition_the_cases_completely_and_disjointly(
        p in tiny_plans(4),
        count in 1usize..24,
    ) {
        let plan = tiny_plan(&p);
        let all = plan::expand_cases(&plan);
        let mut runs = vec![0usize; all.len()];
        for index in 0..count {
            let spec = ShardSpec::new(index, count).expect("index < count");
            let mine = assign::cases_of(&plan, &all, spec);
            prop_assert!(mine.windows(2).all(|w| w[0].index < w[1].index), "shard {}", index);
            for c in &mine {
                prop_assert_eq!(&all[c.index].id, &c.id);
                runs[c.index] += 1;
            }
        }
        prop_assert!(runs.iter().all(|&n| n == 1), "runs per case {:?}", runs);
    }
}

proptest! {
    #![proptest_config(config(4))]

    /// results.json written, read back and written again gives the same
    /// bytes, for simulated runs of random small plans.
    #[test]
    fn results_json_round_trips_to_the_same_bytes(p in tiny_plans(2)) {
        let plan = tiny_plan(&p);
        let cases = plan::expand_cases(&plan);
        let results = runner::run(&plan, &cases, &Simulator::new(&plan), Some(1), &|_| {})
            .unwrap_or_else(|e| panic!("{e}"));
        let model = ledflicker::model::assemble(&plan, "sim-ideal", &results);
        let text = serde_json::to_string_pretty(&model).expect("serialisable");
        let back = ledflicker::model::read_results(&text).unwrap_or_else(|e| panic!("{e}"));
        let again = serde_json::to_string_pretty(&back).expect("serialisable");
        prop_assert!(again == text, "results.json does not read back as written");
    }
}
