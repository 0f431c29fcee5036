#!/usr/bin/env bash
# Build the libFuzzer targets (clang-19) and run each for SECONDS from its seed corpus
# (fuzz/corpus/<target>/). Any crash fails the run; the reproducer is left in build/fuzz/findings/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$(nproc)" --target fuzzers
mkdir -p build/fuzz/findings
# One target per core at a time (each fuzzer is single-threaded); each still fuzzes for SECONDS.
fuzz_one() {
  local bin=$1 name corpus work
  name=$(basename "$bin")
  corpus=fuzz/corpus/${name#fuzz_}
  work=build/fuzz/corpus_work/$name
  mkdir -p "$work"
  local args=("$work")
  [[ -d "$corpus" ]] && args+=("$corpus")
  "$bin" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
    -artifact_prefix=build/fuzz/findings/"$name"- -print_final_stats=0 "${args[@]}" \
    >build/fuzz/"$name".log 2>&1
}
bins=()
for bin in build/fuzz/fuzz/fuzz_*; do [[ -x "$bin" ]] && bins+=("$bin"); done
status=0
at_once=$(nproc)
for ((i = 0; i < ${#bins[@]}; i += at_once)); do
  batch=("${bins[@]:i:at_once}")
  pids=()
  for bin in "${batch[@]}"; do
    echo "fuzz: $(basename "$bin") for ${seconds}s"
    fuzz_one "$bin" &
    pids+=($!)
  done
  for k in "${!batch[@]}"; do
    if ! wait "${pids[k]}"; then
      name=$(basename "${batch[k]}")
      echo "fuzz: $name FOUND A CRASH; see build/fuzz/$name.log and build/fuzz/findings/" >&2
      tail -40 build/fuzz/"$name".log >&2
      status=1
    fi
  done
done
exit $status
