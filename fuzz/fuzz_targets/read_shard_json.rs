//! A shard's `shard.json` on arbitrary bytes, through the checks `merge`
//! runs on a manifest (parse, shard K/N, then against the plan): never
//! panics.
#![no_main]

use ledflicker::shard::merge;
use libfuzzer_sys::fuzz_target;

#[path = "shard_common.rs"]
mod shard_common;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let f = shard_common::fixture();
    let path = std::path::Path::new("fuzz/shard.json");
    if let Ok(m) = merge::parse_manifest(text, path) {
        assert!(m.shard.index < m.shard.count);
        let weights = ledflicker::shard::assign::weights(&f.plan, &f.cases);
        let owners = ledflicker::shard::assign::assign(&weights, m.shard.count);
        let _ = merge::check_manifest(&f.plan, &f.cases, &owners, &f.inputs, path, &m);
    }
});
