//! Shared by the reader targets: write the input to a file with the given
//! extension and read it as a capture; a trace that reads must be finite.

use ledflicker::capture::{self, LumaWeights, ReadOptions, RoiRect, VideoDecode, VideoRange};

pub fn read_as(data: &[u8], name: &str) {
    let dir = std::env::temp_dir().join(format!("ledflicker-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(name);
    if std::fs::write(&path, data).is_err() {
        return;
    }
    let rois = [RoiRect { x: 1, y: 1, width: 2, height: 2 }];
    let opts = ReadOptions {
        luma: LumaWeights::Bt601,
        video_decode: VideoDecode::Rgb,
        range: VideoRange::Auto,
        fps: Some(30.0),
        decoder_threads: None,
    };
    if let Ok(t) = capture::read_capture(&path, &rois, &["a".to_string()], &opts) {
        assert!(t.time_s.iter().all(|x| x.is_finite()));
        assert!(t.time_s.windows(2).all(|w| w[1] > w[0]));
        assert!(t.luma.iter().flatten().all(|x| x.is_finite()));
    }
}
