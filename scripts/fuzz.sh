#!/usr/bin/env bash
# Build the libFuzzer targets (clang-19) and run each for SECONDS from its seed corpus
# (fuzz/corpus/<target>/). Any crash fails the run; the reproducer is left in build/fuzz/findings/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$(nproc)" --target fuzzers
mkdir -p build/fuzz/findings
status=0
for bin in build/fuzz/fuzz/fuzz_*; do
  [[ -x "$bin" ]] || continue
  name=$(basename "$bin")
  corpus=fuzz/corpus/${name#fuzz_}
  work=build/fuzz/corpus_work/$name
  mkdir -p "$work"
  args=("$work")
  [[ -d "$corpus" ]] && args+=("$corpus")
  echo "fuzz: $name for ${seconds}s"
  if ! "$bin" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
      -artifact_prefix=build/fuzz/findings/"$name"- -print_final_stats=0 "${args[@]}" \
      >build/fuzz/"$name".log 2>&1; then
    echo "fuzz: $name FOUND A CRASH; see build/fuzz/$name.log and build/fuzz/findings/" >&2
    tail -40 build/fuzz/"$name".log >&2
    status=1
  fi
done
exit $status
