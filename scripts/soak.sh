#!/usr/bin/env bash
# The long soak, opt-in (CI runs the short versions):
#   - the hostile-input suite's mutations (tests/cli/test_hostile.cpp) and the random drops and
#     throws (Impacts.Soak), each ROUNDS times as many as in CI, on the release build;
#   - every libFuzzer target for FUZZ_SECONDS each.
# Usage: scripts/soak.sh [ROUNDS (default 50)] [FUZZ_SECONDS (default 300)]
# A failing mutated file is kept in build/release/tests/hostile_failures/.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-50}
fuzz_seconds=${2:-300}
scripts/setup.sh --fuzz --test
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
SHATTER_SOAK=$rounds ctest --preset release -R 'HostileInput\.MutatedFiles|Impacts\.Soak' --timeout 0 --output-on-failure
scripts/fuzz.sh "$fuzz_seconds"
echo "== soak passed: $rounds rounds, ${fuzz_seconds}s per fuzzer"
