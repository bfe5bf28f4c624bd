//! The case store against holding cases in memory, timed with divan:
//! `cargo bench --bench store`. The same 120 cases of a 16 x 12 sensor
//! (120 frames each) run on one worker into a `Vec`, and into the store
//! (each case encoded, inserted, committed; then `cases.sqlite` written in
//! case order and read back): the difference is what the store costs a
//! case, against the simulator's own time per case.

use ledflicker::plan::{self, Plan, TestCase};
use ledflicker::runner::{self, CaseResult, CaseSink, RunError, RunOptions};
use ledflicker::store::{Encoded, RunKey, Store, StoreError};

fn main() {
    divan::main();
}

/// The daylight plan on a 16 x 12 sensor with 12 x 10 PWM conditions.
fn small_plan() -> (tempfile::TempDir, Plan, Vec<TestCase>) {
    let text = plan::shipped::plan("daylight")
        .expect("daylight is built in")
        .text;
    let frequencies: Vec<String> = (0..12).map(|i| format!("{}.0", 90 + 37 * i)).collect();
    let duties: Vec<String> = (1..=10)
        .map(|i| format!("{:.2}", f64::from(i) * 0.09))
        .collect();
    let mut out = String::new();
    for line in text.lines() {
        let key = line.split('=').next().unwrap_or("").trim();
        let line = match key {
            "frequencies-hz" => format!("frequencies-hz = [{}]", frequencies.join(", ")),
            "duty-cycles" => format!("duty-cycles = [{}]", duties.join(", ")),
            "levels-lux" => "levels-lux = [2000.0]".to_string(),
            "on-s" => "on-s = 0.5".to_string(),
            "off-s" => "off-s = 0.5".to_string(),
            "pwm-s" => "pwm-s = 3.0".to_string(),
            "sensor-rows" => "sensor-rows = 12".to_string(),
            "sensor-columns" => "sensor-columns = 16".to_string(),
            "x-px" => "x-px = 1".to_string(),
            "y-px" => "y-px = 4".to_string(),
            "width-px" => "width-px = 10".to_string(),
            _ => line.to_string(),
        };
        out.push_str(&line);
        out.push('\n');
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("small.toml");
    std::fs::write(&path, out).expect("write the plan");
    let plan = plan::load(&path).expect("the small plan validates");
    let cases = plan::expand_cases(&plan);
    assert_eq!(cases.len(), 120);
    (dir, plan, cases)
}

struct Storing(Store);

/// Why the bench's run failed (`expect` prints it).
struct Failed(String);

impl std::fmt::Debug for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<RunError> for Failed {
    fn from(e: RunError) -> Self {
        Failed(e.to_string())
    }
}

impl From<StoreError> for Failed {
    fn from(e: StoreError) -> Self {
        Failed(e.to_string())
    }
}

impl CaseSink for Storing {
    type Error = Failed;
    type Item = Encoded;

    fn prepare(result: CaseResult) -> Encoded {
        Encoded::new(result)
    }

    fn put(&mut self, position: usize, case: Encoded) -> Result<(), Failed> {
        Ok(self.0.put_encoded(position, case)?)
    }
}

fn options() -> RunOptions {
    RunOptions {
        threads: Some(1),
        sample_frames: true,
    }
}

/// 120 cases into a `Vec` (sample frames rendered as a run does).
#[divan::bench(sample_count = 10)]
fn run_120_cases_in_memory(bencher: divan::Bencher) {
    let (_dir, plan, cases) = small_plan();
    let backend = ledflicker::backend::for_plan(&plan, None).expect("simulator");
    bencher.bench(|| {
        let mut results = runner::run(&plan, &cases, &backend, Some(1), &|_| {}).expect("run");
        runner::render_sample_frames(&plan, &mut results, &backend).expect("frames");
        results
    });
}

/// The same 120 cases into the store, finished and read back.
#[divan::bench(sample_count = 10)]
fn run_120_cases_into_the_store(bencher: divan::Bencher) {
    let (_dir, plan, cases) = small_plan();
    let backend = ledflicker::backend::for_plan(&plan, None).expect("simulator");
    let key = RunKey {
        plan_id: plan.id.clone(),
        plan_hash: "0".repeat(64),
        tool: "bench".to_string(),
        backend: "simulator".to_string(),
        case_count: cases.len(),
    };
    bencher.bench(|| {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut sink = Storing(Store::create(dir.path(), &key).expect("store"));
        runner::run_streaming(&plan, &cases, &backend, options(), &|_| {}, &mut sink).expect("run");
        let path = sink.0.finish().expect("finish");
        ledflicker::store::read_cases(&path).expect("read back")
    });
}
