//! A shard's `cases.cbor` on arbitrary bytes, through the check `merge`
//! runs (decode, invariants against the plan, evaluation again from the
//! traces): never panics; cases that pass are evaluated from finite data,
//! and the report model built from them holds no NaN or infinity.
#![no_main]

use ledflicker::shard::{ShardSpec, check};
use libfuzzer_sys::fuzz_target;

#[path = "shard_common.rs"]
mod shard_common;

fn assert_finite(v: &ciborium::Value) {
    match v {
        ciborium::Value::Float(x) => assert!(x.is_finite(), "{x} in the report model"),
        ciborium::Value::Array(a) => a.iter().for_each(assert_finite),
        ciborium::Value::Map(m) => m.iter().for_each(|(k, v)| {
            assert_finite(k);
            assert_finite(v);
        }),
        ciborium::Value::Tag(_, v) => assert_finite(v),
        _ => {}
    }
}

fuzz_target!(|data: &[u8]| {
    let f = shard_common::fixture();
    let listed: Vec<usize> = f.cases.iter().map(|c| c.index).collect();
    let spec = ShardSpec::new(0, 1).expect("shard 0/1");
    let path = std::path::Path::new("fuzz/cases.cbor");
    if let Ok(results) = check::shard_cases(&f.plan, &f.cases, &listed, data, path, spec) {
        for r in &results {
            assert!(
                r.acquisition
                    .rois
                    .iter()
                    .flat_map(|t| &t.luma)
                    .all(|v| v.is_finite())
            );
            assert_eq!(r.metrics.len(), f.plan.rois.len());
        }
        // CBOR keeps NaN and infinities (JSON would write them as null).
        let model = ledflicker::model::assemble(&f.plan, "sim-ideal", &results);
        let value = ciborium::Value::serialized(&model).expect("the model serialises");
        assert_finite(&value);
    }
});
