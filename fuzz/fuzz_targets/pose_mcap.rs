//! Fuzz target `pose_mcap`: see `autoact::fuzz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    assert!(autoact::fuzz::run("pose_mcap", data));
});
