//! Fuzz target `spec`: see `autoact::fuzz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    assert!(autoact::fuzz::run("spec", data));
});
