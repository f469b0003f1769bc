#!/usr/bin/env bash
# Render any lobe scene with Mitsuba 3 (making the venv on first use):
#   tools/mitsuba/render.sh SCENE.json OUT.exr [--spp N] [--runs K] [--seed S]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$("$here/setup.sh" | tail -n 1)"
exec "$venv/bin/python" "$here/render.py" "$@"
