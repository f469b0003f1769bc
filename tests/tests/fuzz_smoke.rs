//! Brief, deterministic fuzzing of every reader on stable Rust: each target of
//! `lobe_tests::fuzz` runs on its seed corpus, on deterministic mutations of it (bit flips,
//! overwrites with interesting bytes, truncations, insertions, duplicated slices, extreme
//! numbers) and on every input kept in tests/fuzz-regressions/<target>/ (crashes found by
//! `scripts/fuzz.sh`, kept after the fix). A panic fails the test and writes the input to
//! target/fuzz-failures/ for replay. The libFuzzer targets of fuzz/ explore further.

use lobe_tests::fuzz::{TARGETS, mutations, run, seeds};
use std::panic::{AssertUnwindSafe, catch_unwind};

#[test]
fn every_reader_survives_mutated_input() {
    let scratch = tempfile::tempdir().unwrap();
    let regressions = lobe_tests::workspace().join("tests/fuzz-regressions");
    let failures = lobe_tests::workspace().join("target/fuzz-failures");
    let mut failed = Vec::new();
    let mut total = 0usize;
    // Keep panics quiet while probing; report them below.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    for (t, name) in TARGETS.iter().enumerate() {
        let mut inputs: Vec<Vec<u8>> = Vec::new();
        for (k, seed) in seeds(name).iter().enumerate() {
            // Large seeds (a whole MERL or RGL table) get few mutations.
            let n = if seed.len() > 1 << 20 { 6 } else { 400 };
            inputs.push(seed.clone());
            inputs.extend(mutations(seed, n, (t * 1000 + k) as u64 + 1));
        }
        if let Ok(rd) = std::fs::read_dir(regressions.join(name)) {
            for e in rd.flatten() {
                inputs.push(std::fs::read(e.path()).unwrap());
            }
        }
        for (k, input) in inputs.iter().enumerate() {
            total += 1;
            if catch_unwind(AssertUnwindSafe(|| run(name, input, scratch.path()))).is_err() {
                std::fs::create_dir_all(&failures).unwrap();
                let f = failures.join(format!("{name}-{k}"));
                std::fs::write(&f, input).unwrap();
                failed.push(format!("{name} input {k} (saved as {})", f.display()));
            }
        }
    }
    std::panic::set_hook(hook);
    eprintln!("{total} inputs over {} targets", TARGETS.len());
    assert!(failed.is_empty(), "readers panicked: {failed:#?}");
}

/// Writes the seed corpus of every target to fuzz/corpus/<target>/ (for scripts/fuzz.sh).
#[test]
#[ignore = "run by scripts/fuzz.sh"]
fn write_corpus() {
    for name in TARGETS {
        let dir = lobe_tests::workspace().join("fuzz/corpus").join(name);
        std::fs::create_dir_all(&dir).unwrap();
        for (k, s) in seeds(name).iter().enumerate() {
            std::fs::write(dir.join(format!("seed-{k}")), s).unwrap();
        }
    }
}
