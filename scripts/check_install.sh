#!/usr/bin/env bash
# Install the release build into a temporary prefix and build examples/embed against it with
# find_package(shatter): the example uses only the public headers (include/shatter/), so this
# checks that they are installed, self-contained, and enough to mesh, solve and crack a body.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
prefix=$(mktemp -d)
build=$(mktemp -d)
trap 'rm -rf "$prefix" "$build"' EXIT
cmake --install build/release --prefix "$prefix" >/dev/null
# Only public headers are installed.
if [[ -n "$(cd "$prefix/include" && find shatter -name '*.h' | sort | comm -3 - <(cd "$root/include" && find shatter -name '*.h' | sort))" ]]; then
  echo "check_install: the installed headers differ from include/shatter/" >&2
  exit 1
fi
cmake -S examples/embed -B "$build" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" >/dev/null
"$build/embed" "$build/out"
test -f "$build/out/fragments.vtu"
# The world through the public headers: a dropped vase breaks.
cmake -S examples/drop -B "$build/drop" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build/drop" >/dev/null
"$build/drop/drop" "$root/assets/meshes/vase.msh" >/dev/null
