#!/usr/bin/env bash
# Fuzz every reader with libFuzzer (cargo-fuzz) for SECONDS each (default 60):
#   scripts/fuzz.sh [SECONDS] [TARGET ...]
# Needs a nightly toolchain and cargo-fuzz; installs both when missing. Seeds come from
# lobe_tests::fuzz::seeds (written to fuzz/corpus/<target>/): a valid file of every format
# the targets read, generated (MERL, binned, fit JSON, scene JSON, OBJ, glTF and GLB, EXR,
# HDR, binary and ASCII PLY) or collected (the repository's scenes, bunny OBJ, glTF stage as GLB and studio EXR;
# every RGL file of ../shared/data/rgl or $LOBE_DATA/rgl, never committed). A crash is saved by libFuzzer
# in fuzz/artifacts/<target>/; after fixing it, copy the input to
# tests/fuzz-regressions/<target>/ so that the stable test (CI) replays it forever.
# CI runs the stable, deterministic mutation test instead (tests/tests/fuzz_smoke.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-60}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(scene_json merl binned rgl fit_json obj ply gltf envmap_exr envmap_hdr partial_render)
fi
# fuzz/Cargo.lock is tracked: the run must not rewrite it. A stale one (a dependency of the
# workspace changed) is refused here, before cargo-fuzz would silently update it.
if ! cargo metadata --locked --offline --manifest-path fuzz/Cargo.toml --format-version 1 >/dev/null 2>&1 &&
   ! cargo metadata --locked --manifest-path fuzz/Cargo.toml --format-version 1 >/dev/null; then
  echo "fuzz/Cargo.lock is out of date: refresh it with" >&2
  echo "  cargo metadata --manifest-path fuzz/Cargo.toml --format-version 1 >/dev/null" >&2
  echo "and commit it (scripts/test.sh checks it too)" >&2
  exit 1
fi
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
cargo test --release -q -p lobe-tests --test fuzz_smoke -- --ignored write_corpus
# nv-flip's bundled C++ (tinyexr with miniz) defines a global twice, which AddressSanitizer
# reports as an ODR violation at start-up, before any input: not a bug of lobe's readers.
# Leak detection is off: the targets render, and a render's rayon pool threads exit
# asynchronously after the pool is dropped, so LeakSanitizer reports their deques, stacks
# and glibc's thread-local destructor lists as leaked (seen in the gltf, envmap_exr and
# envmap_hdr targets). The targets look for panics, hangs, memory errors and runaway
# allocations (-rss_limit_mb), which AddressSanitizer and libFuzzer still catch.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_odr_violation=0:detect_leaks=0}"
status=0
for t in "${targets[@]}"; do
  echo "== $t ($secs s)"
  cargo +nightly fuzz run "$t" "fuzz/corpus/$t" -- -max_total_time="$secs" -rss_limit_mb=4096 -timeout=20 -detect_leaks=0 || status=1
done
exit $status
