#!/usr/bin/env bash
# Benchmark lobe against Mitsuba 3 (llvm_ad_rgb, scalar_rgb) on the same scenes:
#   tools/mitsuba/bench.sh --suite [--runs 11]          (scenes/bench/suite.json)
#   tools/mitsuba/bench.sh [SCENE.json ...] [--spp 64] [--reference-spp 2048] [--runs 3] [--out FILE]
# Makes the venv on first use (setup.sh).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$("$here/setup.sh" | tail -n 1)"
exec "$venv/bin/python" "$here/bench.py" "$@"
