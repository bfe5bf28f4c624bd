//! The csv capture reader on arbitrary bytes: never panics, never
//! allocates from an unchecked header; a trace that reads is finite and its
//! times rise.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| common::read_as(data, "c.csv"));
