#!/usr/bin/env bash
# lobe's test command (README): formatting, lints, then every test in release mode.
set -euo pipefail
cd "$(dirname "$0")/.."
# Checks that could not run (no ../shared/data, no chromium, ...) are listed here by the
# tests and summarised at the end; LOBE_REQUIRE_DATA=1 (CI) turns a missing-data skip into
# a failure.
skips=target/skipped-checks.log
mkdir -p target && rm -f "$skips"
summarise_skips() {
  if [ -s "$skips" ]; then
    echo "skipped checks: $(sort -u "$skips" | wc -l)"
    sort -u "$skips" | sed 's/^/  /'
  else
    echo "skipped checks: none"
  fi
}
trap summarise_skips EXIT
cargo fmt --all -- --check
cargo clippy --release --workspace --all-targets -- -D warnings
cargo test --release --workspace
# Every reader's fuzz replay (seed corpora, their mutations, tests/fuzz-regressions/) in a
# build with overflow checks and debug assertions, as scripts/fuzz.sh's libFuzzer build
# has: an arithmetic overflow is a crash there, and must be one here.
cargo test --profile checked -p lobe-tests --test fuzz_smoke
# The lobe Python package (tools/python): built from source and installed into
# tools/mitsuba's venv by its setup.sh (with Mitsuba 3 for the plugin tests), then its
# pytest suite against the lobe binary (bit-for-bit evaluation, readers, fits, errors,
# Mitsuba renders of every plugin model z-tested against lobe's). The binary is the one
# `cargo test --release --workspace` built above for the CLI's integration tests
# (target/release/lobe); a separate `cargo build -p lobe-cli` would compile the whole stack
# again with another feature set (about 3 minutes of CI).
venv="$(bash tools/mitsuba/setup.sh | tail -n 1)"
"$venv/bin/python" -m pytest -q -p no:cacheprovider tools/python/tests
# The fuzz crate (outside the workspace) keeps a tracked lock file; it must match the
# workspace's dependencies so that scripts/fuzz.sh never rewrites it. (Not --offline: a
# fresh machine has not downloaded the fuzz crate's own dependencies, libfuzzer-sys.)
cargo metadata --locked --manifest-path fuzz/Cargo.toml --format-version 1 >/dev/null
# The builds above target this CPU (.cargo/config.toml): 16 SIMD lanes where it has
# AVX-512F. Then the 8-lane kernels an AVX2 build uses are tested too: every batched
# kernel against its scalar form, and the wavefront integrator against the scalar one.
if [ "$(uname -m)" = "x86_64" ] && rustc --print cfg -C target-cpu=native | grep -q avx512f; then
  RUSTFLAGS="-C target-cpu=x86-64-v3" cargo test --release --target-dir target/x86-64-v3 \
    -p lobe-materials -p lobe-renderer -p lobe-tests --lib \
    --test wavefront --test envmap_sampling --test lights --test bsdfs --test determinism
fi
# The portable forms of the SIMD helpers (materials/src/simd.rs and fastmath: what a
# build for baseline x86-64 without AVX uses, RUSTFLAGS="-C target-cpu=x86-64"), tested
# too.
if [ "$(uname -m)" = "x86_64" ]; then
  RUSTFLAGS="-C target-cpu=x86-64" cargo test --release -p lobe-materials \
    --target-dir target/x86-64-baseline -- fastmath simd
fi
