#!/usr/bin/env bash
# Install what is missing, build the `shatter` tool, and run the main job on the bundled default:
# the paper's china vase dropped 1 m onto a stone floor, where it shatters (`shatter run`). Then a
# rendering of the same drop without a display, a static analysis that cracks a glass bar, and the
# teddy-bear asset meshed. Results go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target shatter_cli -j "$(nproc)"
shatter=build/release/bin/shatter
mkdir -p out

echo
echo "== shatter run --out out/vase_drop      (scenes/vase_drop.json: the vase dropped 1 m)"
"$shatter" run --out out/vase_drop

echo
echo "== shatter render --out out/vase_render --fps 15 --size 960x540 --camera 35,25,1.4 --target 0,0.3,0      (the same drop, drawn without a display)"
"$shatter" render --out out/vase_render --fps 15 --size 960x540 --camera 35,25,1.4 --target 0,0.3,0

echo
echo "== shatter inspect examples/glass_bar/bar.vtk"
"$shatter" inspect examples/glass_bar/bar.vtk

echo
echo "== shatter static examples/glass_bar/bar.vtk --case examples/glass_bar/case.json --fracture --out out/glass_bar"
"$shatter" static examples/glass_bar/bar.vtk --case examples/glass_bar/case.json --fracture --out out/glass_bar

echo
echo "== shatter mesh --shape assets/shapes/teddy.json -o out/teddy.vtu"
"$shatter" mesh --shape assets/shapes/teddy.json -o out/teddy.vtu

echo
echo "Results are in out/: open out/vase_drop/scene.pvd (the drop, frame by frame; colour by \"body\"),"
echo "out/glass_bar/fragments.vtu or out/teddy.vtu in ParaView; out/vase_drop/events.jsonl lists every impact."
echo "out/vase_render/frame_*.png are the drop's frames (render.mp4 too when ffmpeg is installed)."
echo "With a display, $shatter view opens the vase drop in the viewer, with the hammer and the other tools."
