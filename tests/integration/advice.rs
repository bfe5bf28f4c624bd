//! Advice a camera can use: no exposure beyond the frame time,
//! from `advise --fps` or from a plan's report.

use serde_json::Value;

use crate::{ledflicker, ledflicker_in, root, scratch, stderr};

fn advise_json(args: &[&str]) -> Value {
    let mut all = vec!["advise", "--json"];
    all.extend_from_slice(args);
    let o = ledflicker(&all);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn offered(a: &Value) -> Vec<f64> {
    a["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["exposure_s"].as_f64().unwrap())
        .collect()
}

#[test]
fn advise_fps_offers_nothing_beyond_the_frame() {
    let range = ["--min-hz", "50", "--max-hz", "400", "--min-duty", "0.05"];
    // Without --fps: up to 4 T* = 4 x 0.95 / 50 = 76 ms.
    let free = advise_json(&range);
    assert!(offered(&free).iter().any(|&t| t > 1.0 / 30.0));
    let mut args = range.to_vec();
    args.extend(["--fps", "30"]);
    let a = advise_json(&args);
    assert!(!offered(&a).is_empty());
    assert!(offered(&a).iter().all(|&t| t <= 1.0 / 30.0 + 1e-15), "{a}");
    assert!(!a["left_out"].as_array().unwrap().is_empty());
    // Sequential HDR T, T/4: the long capture gets (1/30) / 1.25.
    args.extend(["--hdr-ratio", "4"]);
    let a = advise_json(&args);
    let m = a["max_exposure_s"].as_f64().unwrap();
    assert!((m - 1.0 / 30.0 / 1.25).abs() < 1e-15);
    assert!(offered(&a).iter().all(|&t| t <= m + 1e-15));
    // The table says what is left out, and why.
    let o = ledflicker(&[
        "advise",
        "--min-hz",
        "45",
        "--max-hz",
        "400",
        "--min-duty",
        "0.11",
        "--fps",
        "60",
    ]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(text.contains("no exposure this camera can make"), "{text}");
    assert!(
        text.contains("left out: 19.7778 ms, longer than the frame time 16.667 ms at 60 fps"),
        "{text}"
    );
    let o = ledflicker(&[
        "advise",
        "--min-hz",
        "45",
        "--max-hz",
        "400",
        "--min-duty",
        "0.11",
        "--fps",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

/// A 60 fps plan whose lowest frequency and duty need T* = 17.8 ms: the
/// report's advice offers nothing beyond 16.67 ms and says so.
#[test]
fn plan_advice_is_bounded_by_the_frame_time() {
    let dir = scratch("advice-plan");
    let plan = std::fs::read_to_string(root().join("tests/fixtures/plans/small_failing.toml"))
        .unwrap()
        .replace("frame-rate-fps = 30.0", "frame-rate-fps = 60.0")
        .replace("exposure-ms = 11.111", "exposure-ms = 8.0")
        .replace(
            "frequencies-hz = [60.0, 150.0]",
            "frequencies-hz = [45.0, 150.0]",
        )
        .replace("mitigation-min-hz = 50.0", "mitigation-min-hz = 40.0");
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    let o = ledflicker_in(&["plan", "plan.toml", "--out", "out", "-q"], &dir);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/results.json")).unwrap())
            .unwrap();
    let a = &json["advice"]["advice"];
    assert!((a["min_exposure_s"].as_f64().unwrap() - 0.8 / 45.0).abs() < 1e-15);
    assert!(offered(a).iter().all(|&t| t <= 1.0 / 60.0 + 1e-15), "{a}");
    assert!(a["infeasible"].as_str().unwrap().contains("60 fps"));
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(html.contains("no exposure this camera can make"));
}
