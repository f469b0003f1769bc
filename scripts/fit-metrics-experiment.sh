#!/usr/bin/env bash
# The fitting-metric experiment of docs/fitting.md ("Which metric looks right"): the four
# RGL files of ../shared/data/rgl (read in place) and eight MERL tables tabulated from Ngan
# et al.'s published He fits (MERL's 3-degree retro-reflection gap, no noise; Ashikhmin-
# Shirley for black-obsidian and red-specular-plastic, whose published He fits have
# eta = 1, i.e. no specular reflection at all), fitted with
# four models under each metric (the image metric under builtin:studio and builtin:sunset),
# compared by their image errors under two held-out maps (courtyard, interior).
#
#   bash scripts/fit-metrics-experiment.sh [WORK_DIR]     (default /tmp/lobe-metric-study)
#
# Uses the built binary (cargo build --release -p lobe-cli first). Resumable: reports in
# WORK_DIR/out/fits are reused. Takes about 15 minutes on 2 cores.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
lobe="$root/target/release/lobe"
data="${LOBE_DATA:-$root/../shared/data}"
work="${1:-/tmp/lobe-metric-study}"
mkdir -p "$work/tables"
export LOBE_DATA="$data"
for m in pink-fabric:he alum-bronze:he nickel:he blue-fabric:he gold-metallic-paint:he \
         white-diffuse-bball:he black-obsidian:ashikhmin-shirley red-specular-plastic:ashikhmin-shirley; do
    [ -f "$work/tables/${m%%:*}.binary" ] ||
        nice -n 10 "$lobe" tabulate -q --ngan "${m%%:*}" --model "${m#*:}" --retro-exclusion 3 -o "$work/tables/${m%%:*}.binary"
done
nice -n 10 "$lobe" fit compare-metrics "$data"/rgl/*.bsdf "$work"/tables/*.binary \
    --models cook-torrance,ward,lafortune,blinn-phong \
    --metrics eq1,log,cube-root,image \
    --test-env "$data/envmaps/courtyard.exr" --test-env "$data/envmaps/interior.exr" \
    --resolution 2 --size 128 --spp 256 -o "$work/out"
