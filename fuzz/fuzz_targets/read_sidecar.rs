//! The `<capture>.timestamps.csv` sidecar reader: a valid 8-frame CSV trace
//! with arbitrary bytes as its sidecar.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    let dir = std::env::temp_dir().join(format!("ledflicker-fuzz-sc-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let mut csv = String::from("frame,a\n");
    for k in 0..8 {
        csv += &format!("{k},{}\n", 10 + k);
    }
    let _ = std::fs::write(dir.join("t.csv.timestamps.csv"), data);
    let _ = std::fs::write(dir.join("t.csv"), csv);
    let rois = [ledflicker::capture::RoiRect { x: 0, y: 0, width: 1, height: 1 }];
    let opts = ledflicker::capture::ReadOptions {
        luma: ledflicker::capture::LumaWeights::Bt601,
        video_decode: ledflicker::capture::VideoDecode::Rgb,
        range: ledflicker::capture::VideoRange::Auto,
        fps: None,
        decoder_threads: None,
    };
    let _ = common::read_as;
    if let Ok(t) = ledflicker::capture::read_capture(&dir.join("t.csv"), &rois, &["a".to_string()], &opts) {
        assert!(t.time_s.iter().all(|x| x.is_finite()));
        assert!(t.time_s.windows(2).all(|w| w[1] > w[0]));
    }
});
