//! `calibrate` on one 8K frame (7680 x 4320, 16-bit PNG), timed with divan:
//! `cargo bench --bench calibrate`. Reading the frame, the band estimate,
//! the camera-model fit, the written profile and the closed loop (the
//! simulator rendering all 4320 rows through that profile) are all timed.
//! `ledflicker bench --calibrate-8k` times the same steps in a release
//! build of the command.

fn main() {
    divan::main();
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn calibrate_8k_frame(bencher: divan::Bencher) {
    let dir = std::env::temp_dir().join(format!("ledflicker-bench-8k-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("frame-8k.png");
    ledflicker::bench::write_8k_frame(&path).unwrap();
    let out = dir.join("profile.toml");
    bencher.bench_local(|| ledflicker::bench::calibrate_8k_once(&path, &out).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}
