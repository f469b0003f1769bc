#!/usr/bin/env bash
# Creates tools/mitsuba/.venv with Mitsuba 3, numpy, OpenImageIO, maturin, pytest, tqdm and
# a Jupyter kernel (pinned in requirements.txt) and the lobe Python package built from
# tools/python (its lobe.mitsuba holds the Mitsuba plugins the tools use), and, when run as root on Debian,
# installs libllvm19 for Mitsuba's llvm_ad_rgb variant (without it the tools fall back to
# scalar_rgb, much slower). Idempotent: a second run only checks, and rebuilds the lobe
# package only when a source of it (tools/python or a crate it builds on) changed.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$here/.venv"
if ! ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    (apt-get install -y -qq libllvm19 >/dev/null 2>&1 || { apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1; }) \
      || echo "setup.sh: could not install libllvm19; Mitsuba will use scalar_rgb" >&2
  else
    echo "setup.sh: libllvm19 not found; install it (apt-get install libllvm19) for llvm_ad_rgb" >&2
  fi
fi
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import mitsuba, numpy, OpenImageIO, maturin, pytest, tqdm, ipykernel, ipywidgets, jupyter_client, distributed" 2>/dev/null \
   || ! "$venv/bin/pip" freeze 2>/dev/null | grep -q '^mitsuba==3.9.1$'; then
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$here/requirements.txt"
fi
root="$(cd "$here/../.." && pwd)"
stamp="$venv/.lobe-package-built"
if ! "$venv/bin/python" -c "import lobe.mitsuba" 2>/dev/null || [ ! -f "$stamp" ] \
   || [ -n "$(find "$root/tools/python" "$root/materials/src" "$root/renderer/src" "$root/tools/analysis/src" \
              "$root/Cargo.lock" -newer "$stamp" -not -path '*/__pycache__*' -print -quit)" ]; then
  touch "$stamp.new"
  # Built by the venv's pinned maturin, into the workspace's target/ (shared with cargo).
  PATH="$venv/bin:$PATH" "$venv/bin/pip" install -q --disable-pip-version-check --no-build-isolation --force-reinstall --no-deps "$root/tools/python" >&2
  mv "$stamp.new" "$stamp"
fi
echo "$venv"
