#!/usr/bin/env bash
# Render the pictures and the animation of the README and docs/viewer.md with `shatter render` and
# `shatter view` (under Xvfb), from the bundled scenes. Needs a release build (build/release) and,
# for the animation, ffmpeg.
#   scripts/render_docs.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}
shatter="$build/bin/shatter"
images=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One frame of a scene at a time (the last frame written), copied to docs/images.
still() {  # name scene time view camera target
  "$shatter" render "$2" --out "$tmp/$1" --time "$3" --fps 2 --size 960x540 --view "$4" --camera "$5" \
    --target "$6" --no-marks --no-mp4 >/dev/null
  cp "$(ls "$tmp/$1"/frame_*.png | tail -1)" "$images/$1.png"
  echo "wrote $images/$1.png"
}
still render_vase scenes/vase_drop_x10.json 1.2 material 35,30,1.1 0,0.1,0
still render_blocks scenes/block_on_block.json 1.5 material 40,25,1.5 0,0.2,0
still render_teddy scenes/teddy_drops.json 5.0 material 30,20,1.2 0.55,0.12,-0.15
still render_stress scenes/block_on_block.json 0.5 stress 40,20,1.5 0,0.2,0
still render_shelf scenes/shelf_of_vases.json 3.0 material 25,20,2.6 0,0.5,0
still render_wall scenes/wall_and_ball.json 1.2 material 35,18,3.0 0,0.35,0
still render_soft scenes/soft_landing.json 0.5 material 20,18,2.2 0,0.1,-0.1

# The viewer after a hammer blow on the vase, paused in the air.
cat >"$tmp/script.json" <<JSON
[
  {"frame": 0, "action": "pause"},
  {"frame": 1, "action": "tool", "tool": "hammer", "impulse": 5, "speed": 10},
  {"frame": 2, "action": "click", "body": "vase"},
  {"frame": 2, "action": "play"},
  {"frame": 9, "action": "pause"},
  {"frame": 10, "action": "screenshot", "path": "$images/view_hammer.png"},
  {"frame": 11, "action": "quit"}
]
JSON
xvfb-run -a -s "-screen 0 1280x720x24" "$shatter" view scenes/vase_drop.json --size 1280x720 --fixed-step \
  --no-vsync --msaa 4 --script "$tmp/script.json" >/dev/null
echo "wrote $images/view_hammer.png"

# The animation: the finely meshed vase dropped from 1 m, 15 frames a second, as a GIF.
if command -v ffmpeg >/dev/null; then
  "$shatter" render scenes/vase_drop_x10.json --out "$tmp/anim" --time 1.6 --fps 15 --size 480x270 \
    --camera 35,25,1.4 --target 0,0.3,0 --no-marks --no-mp4 >/dev/null
  ffmpeg -y -loglevel error -framerate 15 -i "$tmp/anim/frame_%06d.png" \
    -vf "split[a][b];[a]palettegen=max_colors=128[p];[b][p]paletteuse=dither=bayer" "$images/vase_drop.gif"
  echo "wrote $images/vase_drop.gif"
else
  echo "ffmpeg not installed: no animation" >&2
fi
