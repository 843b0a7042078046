#!/usr/bin/env bash
# Renders the Mitsuba scenes Lightlab imports with both programs and z-tests them pixel by pixel
# (benches/peers/mitsuba_compare.py); each scene's compare.json is copied to results/mitsuba-compare/.
#   pip install mitsuba numpy && bash benches/peers/mitsuba_scenes.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q -p lightlab-cli
shared=../shared/mitsuba-scenes
mkdir -p results/mitsuba-compare
status=0
run() {
  local scene=$1; shift
  local name; name=$(basename "$scene" .xml)
  python3 benches/peers/mitsuba_compare.py "$scene" --out "/tmp/mitsuba-compare/$name" "$@" \
    > "/tmp/mitsuba-compare-$name.log" 2>&1 || status=1
  cp "/tmp/mitsuba-compare/$name/compare.json" "results/mitsuba-compare/$name.json"
  ./target/release/lightlab compare "/tmp/mitsuba-compare/$name/lightlab.exr" \
    "/tmp/mitsuba-compare/$name/mitsuba.exr" --variance-b "/tmp/mitsuba-compare/$name/mitsuba-variance.exr" \
    | sed "s/^/$name: /" || true
}
run "$shared/cbox.xml" --spp 256 --passes 32
run "$shared/simple.xml" --spp 256 --passes 32
run scenes/mitsuba/materials.xml --spp 2048 --passes 64
run benches/peers/envmap-spheres.xml --spp 512 --passes 32
run scenes/mitsuba/textures.xml --spp 512 --passes 32
exit $status
