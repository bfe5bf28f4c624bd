//! The plan parser and validator on arbitrary text: never panics; a plan
//! that validates has a work estimate within the documented limits.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ledflicker::plan::{self, bounds, WorkEstimate};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = std::path::Path::new("fuzz.toml");
    if let Ok(p) = plan::parse(text, path, String::new()) {
        let e = WorkEstimate::of(&p);
        assert!(e.row_integrals <= bounds::MAX_ROW_INTEGRALS);
        assert!(e.memory_bytes <= bounds::MAX_MEMORY_BYTES);
        assert!(e.output_bytes <= bounds::MAX_OUTPUT_BYTES);
    }
});
