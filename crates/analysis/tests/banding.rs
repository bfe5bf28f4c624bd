//! Band spacing of a real rolling-shutter frame (gyroflow/rollingshutter,
//! a 1000 Hz, 50 % LED, 14.565 us per line:
//! reference-data/gyroflow-rs-banding/SOURCE.md) gives back
//! the LED's frequency.

use std::path::Path;

use ledflicker_analysis::calibrate::bands::estimate_profile;

/// The repository root, where reference-data/ is.
fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

#[test]
fn real_frame_band_spacing_gives_the_led_frequency() {
    let path = root().join("reference-data/gyroflow-rs-banding/frame_example.png");
    let img = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    let (w, h) = img.dimensions();
    let profile: Vec<f64> = (0..h)
        .map(|y| (0..w).map(|x| img.get_pixel(x, y)[0] as f64).sum::<f64>() / w as f64)
        .collect();
    let estimate = estimate_profile(&profile).unwrap();
    let (f, _) = estimate.frequency_hz(14.565e-6);
    eprintln!("period {} rows -> {f} Hz", estimate.period_rows);
    // Upstream gives the readout to 0.03 % (15.730 +- 0.004 ms); allow 0.5 %.
    assert!((f - 1000.0).abs() < 5.0, "{f} Hz");
}
