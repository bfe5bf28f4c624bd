//! The read-back of an Aravis camera's settings after a `[recorder]` has
//! recorded it through `aravissrc` (docs/lab.md, "Camera settings"): the
//! element reports nothing of what the camera took, so Aravis' own
//! `arv-tool-0.8 control` reads the GenICam features once the recording
//! has released the camera. It runs contained like any rig command (its
//! own process group, a time limit, its output bounded).

use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use super::rig;

/// The program that reads a camera's features.
pub const ARV_TOOL: &str = "arv-tool-0.8";

/// The GenICam features read: the SFNC's `ExposureTime` (µs) and `Gain`
/// (dB), and `ExposureTimeAbs` (µs), the exposure's name before SFNC 2.
/// A raw gain (`GainRaw`) has no unit and is not read.
const FEATURES: &[&str] = &["ExposureTime", "ExposureTimeAbs", "Gain"];

/// Longest wait for the read-back: finding the camera and reading three
/// registers takes Aravis well under a second on a lab network.
const TIMEOUT: Duration = Duration::from_secs(10);

/// The camera an `aravissrc` pipeline records: `Some(name)` for its
/// `camera-name=`, `Some(None)` for Aravis' first camera, `None` when the
/// pipeline does not start with `aravissrc`.
pub fn camera_of(args: &[String]) -> Option<Option<String>> {
    if args.first().map(String::as_str) != Some("aravissrc") {
        return None;
    }
    let name = args
        .iter()
        .skip(1)
        .take_while(|a| *a != "!")
        .find_map(|a| a.strip_prefix("camera-name="))
        .map(String::from);
    Some(name)
}

/// The camera's exposure (µs) and gain (dB) as it reports them; each
/// `None` when it has no such feature, and both when it cannot be read
/// (no `arv-tool-0.8`, no answer within the time limit).
pub fn read_back(camera: Option<&str>) -> (Option<f64>, Option<f64>) {
    // run_until keeps stderr only: the tool's answer goes there.
    let mut command = Command::new("sh");
    command.args(["-c", "exec \"$0\" \"$@\" >&2", ARV_TOOL]);
    if let Some(name) = camera {
        command.args(["-n", name]);
    }
    command.arg("control").args(FEATURES);
    let Ok(done) = rig::run_until(
        &mut command,
        String::new(),
        TIMEOUT,
        &AtomicBool::new(false),
    ) else {
        return (None, None);
    };
    if !done.status.success() {
        return (None, None);
    }
    parse(&done.stderr)
}

/// `arv-tool control`'s lines `Feature = value ...`: the exposure from
/// `ExposureTime`, else `ExposureTimeAbs`, and the gain from `Gain`.
fn parse(text: &str) -> (Option<f64>, Option<f64>) {
    let value = |feature: &str| {
        text.lines().find_map(|l| {
            let (name, rest) = l.split_once(" = ")?;
            if name.trim() != feature {
                return None;
            }
            rest.split_whitespace()
                .next()?
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
        })
    };
    (
        value("ExposureTime").or_else(|| value("ExposureTimeAbs")),
        value("Gain"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_camera_is_named_by_the_pipelines_first_element() {
        let args = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
        assert_eq!(
            camera_of(&args("aravissrc exposure=10 camera-name=Fake-1 ! x")),
            Some(Some("Fake-1".to_string()))
        );
        assert_eq!(camera_of(&args("aravissrc ! x camera-name=y")), Some(None));
        assert_eq!(camera_of(&args("v4l2src camera-name=z")), None);
    }

    #[test]
    fn features_are_read_from_arv_tools_answer() {
        // The fake camera of Aravis 0.8 names its exposure the old way and
        // its gain only raw.
        let fake = "Feature 'ExposureTime' not found\nExposureTimeAbs = 5000 min:10 max:1e+07\nFeature 'Gain' not found\n";
        assert_eq!(parse(fake), (Some(5000.0), None));
        let sfnc = "ExposureTime = 9998.5 min:20 max:1e+06\nExposureTimeAbs = 1\nGain = 6.02 min:0 max:24\n";
        assert_eq!(parse(sfnc), (Some(9998.5), Some(6.02)));
        assert_eq!(parse("Gain = nan\n"), (None, None));
    }
}
