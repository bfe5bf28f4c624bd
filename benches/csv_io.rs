//! CSV in and out, timed with divan: `cargo bench --bench csv_io`.
//! Reading a user's long CSV trace, and writing the trace CSVs of the
//! daylight plan (traces/<case>.csv).

use std::path::PathBuf;

use ledflicker::capture::{LumaWeights, ReadOptions, VideoDecode, VideoRange, read_capture};
use ledflicker::plan;

fn main() {
    divan::main();
}

/// Frames of the long trace: 10 minutes at 240 frames/s.
const FRAMES: usize = 144_000;
/// ROI columns of the long trace.
const ROIS: usize = 8;

/// A CSV trace as another tool writes it: `frame,time_s,segment` and one
/// luma column per ROI, with six decimals (about 11 MB).
fn long_trace() -> (tempfile::TempDir, PathBuf, Vec<String>) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("long.csv");
    let names: Vec<String> = (0..ROIS).map(|k| format!("roi{k:02}")).collect();
    let mut text = format!("frame,time_s,segment,{}\n", names.join(","));
    for i in 0..FRAMES {
        text += &format!("{i},{:.6},pwm", i as f64 / 240.0);
        for k in 0..ROIS {
            let luma = 100.0 + 50.0 * ((i * (k + 1)) as f64 * 0.37).sin();
            text += &format!(",{luma:.6}");
        }
        text.push('\n');
    }
    std::fs::write(&path, text).expect("write the trace");
    (dir, path, names)
}

/// Reads the 144,000-frame, 8-ROI trace (the file stays in the page cache).
#[divan::bench(sample_count = 20)]
fn read_csv_trace_144000_frames_8_rois(bencher: divan::Bencher) {
    let (_dir, path, names) = long_trace();
    let opts = ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        colour_transfer: ledflicker::capture::ColourTransfer::Linear,
        fps: None,
        decoder_threads: None,
    };
    bencher.bench_local(|| {
        read_capture(divan::black_box(&path), &[], &names, &opts)
            .expect("read")
            .time_s
            .len()
    });
}

/// Writes the trace CSVs of every case of the daylight plan.
#[divan::bench(sample_count = 20)]
fn write_daylight_trace_csvs(bencher: divan::Bencher) {
    let shipped = plan::shipped::plan("daylight").expect("daylight is built in");
    let plan = plan::load_built_in(shipped).expect("daylight loads");
    let cases = plan::expand_cases(&plan);
    let backend = ledflicker::backend::for_plan(&plan, None).expect("backend");
    let results =
        ledflicker::runner::run(&plan, &cases, &backend, None, &|_| {}).expect("daylight runs");
    bencher.bench_local(|| {
        results
            .iter()
            .map(|r| ledflicker::report::trace_csv(divan::black_box(r)).len())
            .sum::<usize>()
    });
}
