#!/usr/bin/env bash
# Regenerates the README's pictures in docs/images/: 1280×720 offscreen frames of real cages (Spot's control
# mesh, Blender's Suzanne) with zebra and curvature shading, the thesis flag, the voxel scene and the
# curves, and an animated PNG of a cage vertex dragged in the window (under Xvfb, scripted mouse events).
# Needs what `scripts/setup.sh` installs (a Vulkan driver, xvfb). Writes nothing else into the checkout.
#
#   bash scripts/readme_images.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin gregvox --example apng
g=./target/release/gregvox
apng=./target/release/examples/apng
images=docs/images
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# shot NAME FRAMES ARGS...: the last of FRAMES offscreen frames at 1280×720 → docs/images/NAME.png.
shot() {
  local name=$1 frames=$2
  shift 2
  "$g" demo --offscreen --frames "$frames" --size 1280x720 --out "$work/$name" "$@" 2> "$work/$name.log" \
    || { cat "$work/$name.log"; exit 1; }
  cp "$work/$name/frame_$(printf %05d $((frames - 1))).png" "$images/$name.png"
  echo "$images/$name.png"
}

shot spot-zebra 2 --scene cage --model assets/models/spot_control_mesh.obj --deform none --shading zebra
shot spot-mean 2 --scene cage --model assets/models/spot_control_mesh.obj --deform none --shading mean
shot suzanne-gaussian 2 --scene cage --model assets/models/suzanne.obj --deform none --shading gaussian
shot flag-phong 60 --scene flag --shading phong
shot flag-zebra 60 --scene flag --shading zebra
shot voxels 40 --scene voxels
shot curves 40 --scene curves
shot cage-hud 40 --scene cage --shading mean --hud

# The drag: the built-in cage at 640×480 in a window, paused, its top middle vertex (picked at 297, 210)
# pulled up in steps, a screenshot after each.
keys="h,Space,p,press:297:210"
for y in 196 180 164 148 132 116 100 84 100 116; do
  keys="$keys,move:$((297 + (210 - y) / 10)):$y,p"
done
keys="$keys,release,p"
xvfb-run -a "$g" demo --frames 140 --size 640x480 --scene cage --keys "$keys" --out "$work/drag" \
  2> "$work/drag.log" || { cat "$work/drag.log"; exit 1; }
grep -q "picked handle" "$work/drag.log" || { cat "$work/drag.log"; echo "no vertex picked" >&2; exit 1; }
"$apng" "$images/cage-drag.png" 250 "$work"/drag/gregvox-screenshot-*.png
