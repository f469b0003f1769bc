#!/usr/bin/env bash
# Render (or re-render) the Mitsuba reference of reference-images/scenes/NAME.json:
#   tools/mitsuba/reference.sh NAME [--spp 64] [--runs 16] [--seed 0]
# Makes the venv on first use (setup.sh).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="$("$here/setup.sh" | tail -n 1)"
exec "$venv/bin/python" "$here/reference.py" "$@"
