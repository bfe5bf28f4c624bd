//! Hot loops of the simulator, timed with divan: `cargo bench`.
//! The speed-against-error table is `ledflicker bench`.

use ledflicker::backend::Backend;
use ledflicker::backend::sim::Simulator;
use ledflicker::physics::PwmDrive;
use ledflicker::physics::shutter::{Shutter, ShutterModel};
use ledflicker::plan;

fn main() {
    divan::main();
}

fn shutter() -> Shutter {
    Shutter {
        model: ShutterModel::Rolling {
            line_time_s: 14.565e-6,
        },
        exposure_s: 0.011111,
        fps: 30.0,
    }
}

/// One frame's ON fraction for a 2-row ROI: the inner loop of every trace.
#[divan::bench]
fn frame_on_fraction_2_rows(bencher: divan::Bencher) {
    let pwm = PwmDrive::new(150.0, 0.2, 0.0).unwrap();
    let s = shutter();
    let mut k = 0u64;
    bencher.bench_local(|| {
        k += 1;
        s.frame_on_fraction(divan::black_box(&pwm), k, 399..401)
    });
}

/// The batched exact core: 1920 frames (64 s at 30 fps) of a 2-row ROI,
/// bit-identical to 1920 calls of the function above.
#[divan::bench]
fn frame_on_fractions_1920_frames_2_rows(bencher: divan::Bencher) {
    let pwm = PwmDrive::new(150.0, 0.2, 0.0).unwrap();
    let s = shutter();
    let mut out = Vec::with_capacity(1920);
    bencher.bench_local(|| {
        out.clear();
        s.frame_on_fractions(divan::black_box(&pwm), 0..1920, 399..401, &mut out);
        out.len()
    });
}

/// The exact worst case over phase for a 2-row ROI.
#[divan::bench]
fn phase_envelope_2_rows(bencher: divan::Bencher) {
    let pwm = PwmDrive::new(150.0, 0.2, 0.0).unwrap();
    let s = shutter();
    bencher.bench_local(|| s.phase_envelope(divan::black_box(&pwm), 399..401));
}

/// The band estimator on one 800-row profile: the LED-only rows of the
/// daylight camera at 500 Hz, 20 % duty (each daylight case and sample
/// frame runs it once).
#[divan::bench(sample_count = 20)]
fn band_estimate_800_rows(bencher: divan::Bencher) {
    let pwm = PwmDrive::new(500.0, 0.2, 0.0).unwrap();
    let s = shutter();
    let profile: Vec<f64> = (0..800)
        .map(|r| s.frame_on_fraction(&pwm, 0, r..r + 1))
        .collect();
    bencher.bench_local(|| {
        ledflicker::calibrate::bands::estimate_profile(divan::black_box(&profile))
            .map(|e| e.period_rows)
    });
}

/// One 64 s case on the 3-capture HDR + auto-exposure profile.
#[divan::bench(sample_count = 10)]
fn hdr_case_64_s(bencher: divan::Bencher) {
    let plan =
        ledflicker::bench::bench_plan(Some("reference-data/cameras/deegan2018-hdr3.toml")).unwrap();
    let cases = plan::expand_cases(&plan);
    let sim = Simulator::new(&plan);
    bencher.bench_local(|| sim.acquire(divan::black_box(&cases[7])).unwrap());
}
