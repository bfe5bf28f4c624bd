//! The plans and camera profiles that ship with ledflicker, compiled into
//! the binary, so that `ledflicker plan daylight` works wherever the binary
//! is installed, with no path of the machine that built it.
//!
//! A file on disk always wins: a plan name is looked up in `./test-plans/`
//! first, and a camera profile next to the plan and in the current
//! directory first (the user's edited copy is what they mean). Only then is
//! the built-in copy used, under its path in the source tree
//! (`test-plans/daylight.toml`), which is what reports and results.json
//! name.

/// What a built-in file's path is followed by where it is shown (a camera
/// profile's source, a report's list of inputs).
pub const BUILT_IN: &str = " (built in)";

/// `path` as a built-in file is shown: `test-plans/daylight.toml (built in)`.
pub fn label(path: &str) -> String {
    format!("{path}{BUILT_IN}")
}

/// A file compiled into the binary.
#[derive(Debug, PartialEq, Eq)]
pub struct Shipped {
    /// Its path in the source tree, e.g. `test-plans/daylight.toml`.
    pub path: &'static str,
    /// Its text.
    pub text: &'static str,
}

macro_rules! shipped {
    ($($path:literal),* $(,)?) => {
        &[$(Shipped { path: $path, text: include_str!(concat!("../../../../", $path)) }),*]
    };
}

/// The shipped test plans.
pub const PLANS: &[Shipped] = shipped![
    "test-plans/bench-example.toml",
    "test-plans/cms-colour.toml",
    "test-plans/cms-night.toml",
    "test-plans/command-sim-rig.toml",
    "test-plans/daylight.toml",
    "test-plans/deegan2018.toml",
    "test-plans/grid-192.toml",
    "test-plans/hdr-example.toml",
    "test-plans/lowlight.toml",
    "test-plans/p2020-samples.toml",
    "test-plans/rgb-signal.toml",
    "test-plans/sweep-23k.toml",
];

/// The shipped camera profiles.
pub const PROFILES: &[Shipped] = shipped![
    "reference-data/cameras/deegan2018-hdr3.toml",
    "reference-data/cameras/ideal-global.toml",
    "reference-data/cameras/ideal-rolling.toml",
    "reference-data/cameras/split-pixel-lfm.toml",
];

/// A data file compiled into the binary: a capture that a shipped plan
/// names, so that the plan runs away from the source tree too.
#[derive(Debug, PartialEq, Eq)]
pub struct ShippedData {
    /// Its path in the source tree, e.g.
    /// `reference-data/p2020-flicker-videos/test_vid1.mp4`.
    pub path: &'static str,
    /// Its bytes.
    pub bytes: &'static [u8],
}

macro_rules! shipped_data {
    ($($path:literal),* $(,)?) => {
        &[$(ShippedData { path: $path, bytes: include_bytes!(concat!("../../../../", $path)) }),*]
    };
}

/// The captures of the shipped plans (`p2020-samples`: three H.264
/// videos, 0.5 MB in all). The larger captures of reference-data/ are
/// named by tests and examples, not by a shipped plan, and stay out.
pub const DATA: &[ShippedData] = shipped_data![
    "reference-data/p2020-flicker-videos/test_vid1.mp4",
    "reference-data/p2020-flicker-videos/test_vid2.mp4",
    "reference-data/p2020-flicker-videos/test_vid3.mp4",
];

/// The shipped data file at `path`: a relative path that leads to it
/// from the source tree's root, directly or through a plan's folder
/// (`test-plans/../reference-data/...`, as a shipped plan's capture is
/// resolved). An absolute path, or one that climbs above the root, is
/// the user's, never a shipped file.
pub fn data_at(path: &std::path::Path) -> Option<&'static ShippedData> {
    use std::path::Component;
    let mut parts: Vec<&str> = Vec::new();
    for c in path.components() {
        match c {
            Component::Normal(p) => parts.push(p.to_str()?),
            Component::CurDir => {}
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    let path = parts.join("/");
    DATA.iter().find(|d| d.path == path)
}

/// The shipped plan named `name` (`daylight` or `daylight.toml`).
pub fn plan(name: &str) -> Option<&'static Shipped> {
    let file = if name.ends_with(".toml") {
        name.to_string()
    } else {
        format!("{name}.toml")
    };
    PLANS
        .iter()
        .find(|p| p.path.rsplit('/').next() == Some(&file))
}

/// For a plan file that is missing, a hint naming the built-in plan of
/// its name (`test-plans/lowlight.toml` away from the source tree), or
/// nothing.
pub fn hint_for_missing(path: &std::path::Path) -> String {
    path.file_stem()
        .map(|stem| stem.to_string_lossy().into_owned())
        .filter(|name| plan(name).is_some())
        .map_or(String::new(), |name| {
            format!(
                "\n    hint: `{name}` is built into ledflicker: give its name alone (`ledflicker plan {name}`), or write it out with `ledflicker plans show {name} > {name}.toml`"
            )
        })
}

/// The shipped plan at `path`, a path the plan was reported under
/// (`test-plans/daylight.toml`).
pub fn plan_at(path: &str) -> Option<&'static Shipped> {
    PLANS.iter().find(|p| p.path == path)
}

/// The shipped camera profile a plan's `camera-profile` names: its path
/// in the source tree, reached from the plan's folder or the source tree's
/// root (`../reference-data/cameras/ideal-global.toml`,
/// `reference-data/cameras/ideal-global.toml`). Only those two spellings,
/// so a name meant for a file of the user's is never taken for a shipped
/// one.
pub fn profile(name: &str) -> Option<&'static Shipped> {
    let name = name.strip_prefix("./").unwrap_or(name);
    let name = name.strip_prefix("../").unwrap_or(name);
    PROFILES.iter().find(|p| p.path == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shipped file is the file of the source tree, and every plan
    /// and profile of the source tree is shipped.
    #[test]
    fn the_shipped_set_is_the_source_trees() {
        let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
        for (dir, set) in [("test-plans", PLANS), ("reference-data/cameras", PROFILES)] {
            let mut on_disk: Vec<String> = std::fs::read_dir(root.join(dir))
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".toml"))
                .map(|n| format!("{dir}/{n}"))
                .collect();
            on_disk.sort();
            let shipped: Vec<&str> = set.iter().map(|s| s.path).collect();
            assert_eq!(on_disk, shipped, "{dir}");
            for s in set {
                let text = std::fs::read_to_string(root.join(s.path)).unwrap();
                assert_eq!(text, s.text, "{}", s.path);
            }
        }
    }

    #[test]
    fn names_find_their_shipped_files() {
        assert_eq!(plan("daylight").unwrap().path, "test-plans/daylight.toml");
        assert_eq!(
            plan("daylight.toml").unwrap().path,
            "test-plans/daylight.toml"
        );
        assert!(plan("nightlight").is_none());
        assert!(plan_at("test-plans/lowlight.toml").is_some());
        assert!(plan_at("elsewhere/lowlight.toml").is_none());
        let want = "reference-data/cameras/ideal-global.toml";
        for name in [
            "../reference-data/cameras/ideal-global.toml",
            "reference-data/cameras/ideal-global.toml",
            "./reference-data/cameras/ideal-global.toml",
        ] {
            assert_eq!(profile(name).unwrap().path, want, "{name}");
        }
        assert!(profile("ideal-global.toml").is_none());
        assert!(profile("/etc/reference-data/cameras/ideal-global.toml").is_none());
        assert!(profile("../../reference-data/cameras/ideal-global.toml").is_none());
    }

    #[test]
    fn shipped_captures_are_found_through_a_plans_folder_only_inside_the_tree() {
        let root = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
        for d in DATA {
            assert_eq!(
                std::fs::read(root.join(d.path)).unwrap(),
                d.bytes,
                "{}",
                d.path
            );
        }
        let want = "reference-data/p2020-flicker-videos/test_vid2.mp4";
        for name in [
            "test-plans/../reference-data/p2020-flicker-videos/test_vid2.mp4",
            "./reference-data/p2020-flicker-videos/test_vid2.mp4",
            want,
        ] {
            let found = data_at(std::path::Path::new(name)).map(|d| d.path);
            assert_eq!(found, Some(want), "{name}");
        }
        for name in [
            "../reference-data/p2020-flicker-videos/test_vid2.mp4",
            "/reference-data/p2020-flicker-videos/test_vid2.mp4",
            "test-plans/reference-data/p2020-flicker-videos/test_vid2.mp4",
            "reference-data/p2020-flicker-videos/test.tiff",
        ] {
            assert!(data_at(std::path::Path::new(name)).is_none(), "{name}");
        }
    }
}
