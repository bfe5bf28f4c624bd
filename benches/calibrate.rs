//! `calibrate` on one 8K frame (7680 x 4320, 16-bit PNG), timed with divan:
//! `cargo bench --bench calibrate`. Reading the frame, the band estimate,
//! the camera-model fit, the written profile and the closed loop (the
//! simulator rendering all 4320 rows through that profile) are all timed.

use ledflicker::calibrate::profile::{self, ProfileOptions};
use ledflicker::calibrate::synth::SynthFrame;
use ledflicker::calibrate::{Light, calibrate, frames};

fn main() {
    divan::main();
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn calibrate_8k_frame(bencher: divan::Bencher) {
    let dir = std::env::temp_dir().join(format!("ledflicker-bench-8k-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("frame-8k.png");
    // An 8K sensor reading out 4320 rows in 15.7 ms, a 1 kHz LED.
    SynthFrame {
        width: 7680,
        height: 4320,
        line_time_s: 3.641e-6,
        noise_dn: 200.0,
        vignetting: 0.3,
        bits16: true,
        ..SynthFrame::base()
    }
    .save(&path, 90)
    .unwrap();
    let out = dir.join("profile.toml");
    bencher.bench_local(|| {
        let set = frames::load(std::slice::from_ref(&path), None, None).unwrap();
        let light = Light {
            frequency_hz: 1000.0,
            frequency_sigma_hz: 0.0,
            duty: None,
        };
        let cal = calibrate(&set, light).unwrap();
        let opts = ProfileOptions {
            name: "bench".to_string(),
            fps: None,
        };
        std::fs::write(&out, profile::profile_toml(&cal, &opts)).unwrap();
        let fps = profile::frame_rate(&cal, &opts);
        profile::closed_loop(&cal, &out, fps).unwrap()
    });
    let _ = std::fs::remove_dir_all(&dir);
}
