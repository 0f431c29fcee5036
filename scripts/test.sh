#!/usr/bin/env bash
# Install what is missing, build, and run the whole test suite:
#   1. release build, all tests (unit, property, cross-checks against meshio and CalculiX);
#   2. the same tests under AddressSanitizer + UBSan;
#   3. every libFuzzer target for a short time (SHATTER_FUZZ_SECONDS, default 20) from its corpus;
#   4. find_package(shatter) from a separate project against an installed copy.
# Set SHATTER_QUICK=1 to run step 1 only.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

scripts/setup.sh --fuzz

echo "== release build and tests"
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs"
ctest --preset release -j "$jobs"

if [[ "${SHATTER_QUICK:-0}" == "1" ]]; then exit 0; fi

echo "== asan-ubsan build and tests"
cmake --preset asan-ubsan >/dev/null
cmake --build --preset asan-ubsan -j "$jobs"
ctest --preset asan-ubsan -j "$jobs"

echo "== fuzzing"
scripts/fuzz.sh "${SHATTER_FUZZ_SECONDS:-20}"

echo "== find_package(shatter) from another project"
scripts/check_install.sh

echo "== all checks passed"
