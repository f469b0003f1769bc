#!/usr/bin/env bash
# Rebuilds docs/gallery/: every figure kind lobe draws and the study report's pages as a
# browser shows them (headless Chromium screenshots), from the default study and the RGL
# files in ../shared/data (or LOBE_DATA). docs/gallery.md shows and explains them.
#
#   scripts/gallery.sh [STUDY_DIR]    # default out/gallery-study (the study resumes there)
#
# Needs chromium (Debian's package) and about 6 minutes on 2 cores for a fresh study.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${LOBE_DATA:-../shared/data}
study=${1:-out/gallery-study}
rgl="$data/rgl/paper_white_rgb.bsdf"
[ -f "$rgl" ] || { echo "gallery: $rgl not found; set LOBE_DATA to the shared data folder" >&2; exit 2; }
command -v chromium >/dev/null || { echo "gallery: chromium not found (apt-get install chromium)" >&2; exit 2; }
cargo build --release -q -p lobe-cli
lobe=target/release/lobe
"$lobe" study -o "$study"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
out=docs/gallery
mkdir -p "$out"

# The study's figures (Figure 14, Figure 5, a polar plot, lobe contours, a microfacet map).
cp "$study/figures/figure14.png" "$out/figure14-errors.png"
cp "$study/figures/figure5.png" "$out/figure5-multilobe.png"
cp "$study/figures/vch_golden_yellow_rgb-polar-30.png" "$out/polar.png"
cp "$study/figures/vch_golden_yellow_rgb-lobes-30.png" "$out/lobe-contours.png"
cp "$study/microfacet/cc_ibiza_sunset_rgb.png" "$out/microfacet-estimate.png"

# The figure commands.
report="$study/fits/paper_white_rgb.fit.json"
"$lobe" figure spheres -q --material "{\"type\": \"rgl\", \"file\": \"$rgl\"}" --report "$report" \
  --models ashikhmin-shirley,cook-torrance,ward,blinn-phong --env builtin:sunset -o "$out/spheres.png"
"$lobe" figure lobes -q --theta-i 45 --exponent 20 -o "$work/lobes.png"
cp "$work/lobes.png" "$out/figure7-lobes.png"
"$lobe" microfacet synth satin -q -o "$work/satin" >/dev/null
cp "$work/satin/satin-truth.png" "$out/satin-truth.png"
cp "$work/satin/satin-estimate.png" "$out/satin-estimate.png"
"$lobe" tradeoff "$rgl" -q --resolution 3 --size 64 --spp 16 --reference-spp 128 -o "$work/tradeoff" >/dev/null
cp "$work/tradeoff.png" "$out/tradeoff.png"
renders="$study/renders/paper_white_rgb/sunset"
"$lobe" compare "$renders/blinn-phong.exr" "$renders/measured.exr" --heatmap "$out/compare-heatmap.png" >/dev/null

# The report's pages, as a reader's browser shows their first screen.
shot() {
  chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size="$2" \
    --force-device-scale-factor=0.75 --screenshot="$out/$3" "file://$(realpath "$1")" >/dev/null 2>&1
}
shot "$study/index.html" 1400,1900 report-index.png
shot "$study/materials/paper_white_rgb.html" 1400,1900 report-material.png
ls -l "$out"
