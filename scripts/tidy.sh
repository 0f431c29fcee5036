#!/usr/bin/env bash
# Run clang-tidy 19 (.clang-tidy) over the library and tool sources with the compile commands of a
# configured build (default build/release; configure it first). Fails on any finding.
#   scripts/tidy.sh [BUILD_DIR] [FILE...]
# Without FILEs: every source under src/ and apps/. When BUILD_DIR was configured with
# -DCMAKE_UNITY_BUILD=ON (as the test script does), each of its unity files is checked as one
# translation unit: a library's sources then share one parse of Eigen and the standard library, about
# three times faster than one source at a time. The sources they include are checked as if they were
# headers (HeaderFilterRegex names src/ and apps/), and a source in no unity file is checked alone.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}
shift || true
command -v clang-tidy-19 >/dev/null || { echo "tidy: clang-tidy-19 is not installed (scripts/setup.sh)" >&2; exit 1; }
[[ -f "$build/compile_commands.json" ]] || { echo "tidy: $build/compile_commands.json missing: configure $build first" >&2; exit 1; }
if [[ $# -gt 0 ]]; then
  files=("$@")
else
  mapfile -t sources < <(git ls-files --cached --others --exclude-standard -- 'src/*.cpp' 'apps/*.cpp' | sort)
  # Unity files of the library and tool targets, and the sources they include.
  mapfile -t files < <(find "$build/src" "$build/apps" -path '*/Unity/unity_*.cxx' 2>/dev/null | sort)
  declare -A covered=()
  if [[ ${#files[@]} -gt 0 ]]; then
    while IFS= read -r included; do covered[$included]=1; done < <(
      sed -n 's/^#include "\(.*\)"$/\1/p' "${files[@]}" | while IFS= read -r p; do realpath --relative-to=. "$p"; done)
  fi
  for s in "${sources[@]}"; do [[ -n "${covered[$s]:-}" ]] || files+=("$s"); done
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# Bytes of project source in a translation unit (a unity file's are those of what it includes).
weight() {
  if [[ $1 == *.cxx ]]; then
    sed -n 's/^#include "\(.*\)"$/\1/p' "$1" | xargs -d '\n' cat | wc -c
  else
    wc -c <"$1"
  fi
}
# One translation unit per clang-tidy process, as many at once as there are cores; the largest
# first, so that the last to finish is a short one.
if ! for f in "${files[@]}"; do printf '%s\t%s\n' "$(weight "$f")" "$f"; done | sort -rn | cut -f2- |
  xargs -d '\n' -P "$(nproc)" -n 1 clang-tidy-19 -p "$build" --quiet >"$log" 2>&1; then
  grep -E "(warning|error):" "$log" | sort -u >&2 || cat "$log" >&2
  echo "tidy: findings above (.clang-tidy)" >&2
  exit 1
fi
echo "tidy: ${#files[@]} translation units clean"
