//! Fuzz target `layout`: see `autoact::fuzz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    assert!(autoact::fuzz::run("layout", data));
});
