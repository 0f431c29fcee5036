#!/usr/bin/env bash
# Demo meshes from assets/shapes/*.json (docs/meshing.md): `shatter mesh --method auto`, i.e. the
# structured meshers for box-CSG shapes and single revolutions, isosurface stuffing for the rest.
#   scripts/make_assets.sh [FACTOR] [SHATTER]
# FACTOR 1 (default) writes assets/meshes/<name>.msh (MSH 4.1 binary) for the shapes whose mesh is
# small enough to keep in the repository, and a table of counts and quality on stdout; FACTOR 10 or
# 100 writes about that many times more tets, for every shape, to build/assets/x<FACTOR>/.
# Output bytes depend only on the shape files and the build (any thread count).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
factor="${1:-1}"
shatter="${2:-$root/build/release/bin/shatter}"
[ -x "$shatter" ] || { echo "make_assets.sh: no shatter executable at $shatter (build first, or pass it)" >&2; exit 2; }
if [ "$factor" = 1 ]; then out="$root/assets/meshes"; else out="$root/build/assets/x$factor"; fi
mkdir -p "$out"
# Meshes kept in the repository (each < 300 KB).
committed="blob bowl cinder_block column plate teddy vase wall_slab"
printf '%-14s %-9s %9s %9s %8s %8s %10s\n' shape method tets h_m min_deg max_deg vol_err_%
for shape in "$root"/assets/shapes/*.json; do
  name="$(basename "$shape" .json)"
  if [ "$factor" = 1 ] && [[ " $committed " != *" $name "* ]]; then continue; fi
  report="$("$shatter" mesh --shape "$shape" --refine "$factor" --binary --json -o "$out/$name.msh" 2>/dev/null)"
  python3 - "$name" "$report" <<'PY'
import json, sys
j = json.loads(sys.argv[2])
err = 100 * j["volume_error"] if "volume_error" in j else float("nan")
print(f'{sys.argv[1]:<14} {j["method"]:<9} {j["tets"]:>9} {j["edge_length"]:>9.4f} {j["dihedral_deg"]["min"]:>8.2f} '
      f'{j["dihedral_deg"]["max"]:>8.2f} {err:>10.3f}')
PY
done
