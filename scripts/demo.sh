#!/usr/bin/env bash
# Install what is missing, build the `shatter` tool, and run the bundled example: a glass bar
# pulled past its tensile strength, solved statically, cracked and split into fragments. Also
# inspects the mesh and meshes the teddy-bear asset. Results go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target shatter_cli -j "$(nproc)"
shatter=build/release/bin/shatter
mkdir -p out

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
echo "Results are in out/: open out/glass_bar/fragments.vtu or out/teddy.vtu in ParaView."
