#!/usr/bin/env bash
# Run clang-tidy 19 (.clang-tidy) over the library and tool sources with the compile commands of a
# configured build (default build/release; configure it first). Fails on any finding.
#   scripts/tidy.sh [BUILD_DIR] [FILE...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}
shift || true
command -v clang-tidy-19 >/dev/null || { echo "tidy: clang-tidy-19 is not installed (scripts/setup.sh)" >&2; exit 1; }
[[ -f "$build/compile_commands.json" ]] || { echo "tidy: $build/compile_commands.json missing: configure $build first" >&2; exit 1; }
if [[ $# -gt 0 ]]; then
  files=("$@")
else
  mapfile -t files < <(git ls-files --cached --others --exclude-standard -- 'src/*.cpp' 'apps/*.cpp' | sort)
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# One file per clang-tidy process, as many at once as there are cores.
if ! printf '%s\n' "${files[@]}" | xargs -P "$(nproc)" -n 1 clang-tidy-19 -p "$build" --quiet >"$log" 2>&1; then
  grep -E "(warning|error):" "$log" | sort -u >&2 || cat "$log" >&2
  echo "tidy: findings above (.clang-tidy)" >&2
  exit 1
fi
echo "tidy: ${#files[@]} files clean"
