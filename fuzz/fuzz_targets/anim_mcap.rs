//! Fuzz target `anim_mcap`: see `autoact::fuzz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    assert!(autoact::fuzz::run("anim_mcap", data));
});
