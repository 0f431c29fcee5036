#!/usr/bin/env bash
# Install what is missing, build, and run the whole test suite:
#   0. layout (.clang-format) of every C++ file; after the release build, clang-tidy (.clang-tidy)
#      over the library and tool sources;
#      the sanitizer and fuzzing builds are unity builds (CMakePresets.json), the release build is not;
#   1. release build, all tests (unit, property, cross-checks against meshio and CalculiX);
#   2. the same tests under AddressSanitizer + UBSan (clang-19);
#   3. the tests of the threaded code (labels core, fem, solve, fracture, meshing) under
#      ThreadSanitizer (clang-19), no suppressions; shatter's worker pool synchronises through
#      the standard library's mutexes and atomics, which TSan sees.
#      Left out there: CmdMesh.* (needs the CLI, not built for this stage);
#   4. every libFuzzer target for a short time (SHATTER_FUZZ_SECONDS, default 10) from its corpus
#      (long runs: scripts/soak.sh);
#   5. find_package(shatter) from a separate project against an installed copy.
# Set SHATTER_QUICK=1 to run step 1 only.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
# Each step's heading says how long the run has taken so far.
step() { echo "== $1 (at $((SECONDS / 60)) min $((SECONDS % 60)) s)"; }

scripts/setup.sh --fuzz --tsan --test

step "layout"
scripts/format.sh --check

step "release build and tests"
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs"
ctest --preset release -j "$jobs"

if [[ "${SHATTER_QUICK:-0}" == "1" ]]; then exit 0; fi

step "clang-tidy"
# The release configuration again, as a unity build, only for its compile commands: scripts/tidy.sh
# then checks each library's sources in a few translation units instead of one each.
cmake --preset release -B build/tidy -DCMAKE_UNITY_BUILD=ON >/dev/null
scripts/tidy.sh build/tidy

step "asan-ubsan build and tests"
cmake --preset asan-ubsan >/dev/null
cmake --build --preset asan-ubsan -j "$jobs"
ctest --preset asan-ubsan -j "$jobs"

step "thread sanitizer build and threaded tests"
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$jobs"
ctest --preset tsan -j "$jobs"

step "fuzzing"
scripts/fuzz.sh "${SHATTER_FUZZ_SECONDS:-10}"

step "find_package(shatter) from another project"
scripts/check_install.sh

step "all checks passed"
