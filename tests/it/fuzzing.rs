//! The fuzzing harness's regressions: every input in `fuzz/regressions/` (named `<target>--<what>`) (crashers and
//! hostile cases found by `cargo fuzz` or `tools/fuzz_cli.py`, or written from an issue) is run
//! through the same entry point its fuzz target calls (`autoact::fuzz::run`) and must come back
//! without a panic. And the harness is whole: one `cargo fuzz` target per entry point.

use std::path::Path;

#[test]
fn every_regression_input_is_read_without_a_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut replayed = 0;
    // Flat, one file per input, named `<target>--<what it breaks>`.
    for file in std::fs::read_dir(&root).unwrap() {
        let path = file.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let (target, _) = name
            .split_once("--")
            .unwrap_or_else(|| panic!("fuzz/regressions/{name}: not named <target>--<what>"));
        assert!(
            autoact::fuzz::TARGETS.contains(&target),
            "fuzz/regressions/{name} names no fuzz target"
        );
        let data = std::fs::read(&path).unwrap();
        assert!(autoact::fuzz::run(target, &data), "{}", path.display());
        replayed += 1;
    }
    assert!(replayed >= 10, "only {replayed} regression inputs");
}

#[test]
fn there_is_one_cargo_fuzz_target_per_entry_point() {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let manifest = std::fs::read_to_string(fuzz.join("Cargo.toml")).unwrap();
    for target in autoact::fuzz::TARGETS {
        let source = fuzz.join(format!("fuzz_targets/{target}.rs"));
        let text = std::fs::read_to_string(&source)
            .unwrap_or_else(|e| panic!("{}: {e}", source.display()));
        assert!(
            text.contains(&format!("autoact::fuzz::run(\"{target}\"")),
            "{} does not call its entry point",
            source.display()
        );
        assert!(
            manifest.contains(&format!("name = \"{target}\"")),
            "fuzz/Cargo.toml has no [[bin]] {target}"
        );
    }
    assert!(!autoact::fuzz::run("no-such-target", b""));
}
