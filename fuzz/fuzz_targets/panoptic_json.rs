//! Fuzz target `panoptic_json`: see `autoact::fuzz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    assert!(autoact::fuzz::run("panoptic_json", data));
});
