//! A report's `results.json` on arbitrary bytes, as `import` reads it:
//! parsed, its verdicts judged again from its values and limits, and its
//! set-up taken for `compare`. Never panics; a report that is accepted
//! has counts that add up.
#![no_main]

use ledflicker::campaign::{rejudge, setup::Setup};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(results) = ledflicker::model::read_results(text) else {
        return;
    };
    let problems = rejudge::mismatches(&results);
    let setup = Setup::of(&results);
    let _ = setup.test_hash();
    let _ = setup.device_label();
    if problems.is_empty() {
        let c = &results.counts;
        assert_eq!(c.pass + c.fail + c.info, c.total);
        assert_eq!(c.total, results.cases.len());
    }
});
