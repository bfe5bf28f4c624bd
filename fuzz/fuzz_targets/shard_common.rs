//! Shared by the shard targets: the plan `fuzz/plans/shard.toml`, loaded
//! once from a file (the merge hashes the plan file), with its cases and
//! inputs.

use std::sync::OnceLock;

use ledflicker::inputs::{self, InputFile};
use ledflicker::plan::{self, Plan, TestCase};

pub struct Fixture {
    pub plan: Plan,
    pub cases: Vec<TestCase>,
    // Read by read_shard_json only; each target compiles this file alone.
    #[allow(dead_code)]
    pub inputs: Vec<InputFile>,
}

pub fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let dir =
            std::env::temp_dir().join(format!("ledflicker-fuzz-shard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch directory");
        let path = dir.join("shard.toml");
        std::fs::write(&path, include_str!("../plans/shard.toml")).expect("plan file");
        let plan = plan::load(&path).expect("the fuzz plan is valid");
        let cases = plan::expand_cases(&plan);
        let inputs = inputs::collect(&plan).expect("the fuzz plan's inputs");
        Fixture {
            plan,
            cases,
            inputs,
        }
    })
}
