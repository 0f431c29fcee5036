#!/usr/bin/env bash
# Install the release build into a temporary prefix and build a small consumer project against it
# with find_package(shatter).
set -euo pipefail
cd "$(dirname "$0")/.."
prefix=$(mktemp -d)
consumer=$(mktemp -d)
trap 'rm -rf "$prefix" "$consumer"' EXIT
cmake --install build/release --prefix "$prefix" >/dev/null
cat >"$consumer/CMakeLists.txt" <<'CM'
cmake_minimum_required(VERSION 3.25)
project(consumer LANGUAGES CXX)
find_package(shatter REQUIRED)
add_executable(consumer main.cpp)
target_link_libraries(consumer PRIVATE shatter::shatter)
CM
cat >"$consumer/main.cpp" <<'CPP'
#include <cstdio>
#include "shatter/mesh/generate.h"
int main() {
  const shatter::TetMesh m = shatter::make_box_mesh({.cells = {2, 2, 2}});
  std::printf("consumer: %d tets, volume %.3f\n", m.num_tets(), shatter::total_volume(m));
  return m.num_tets() == 48 ? 0 : 1;
}
CPP
cmake -S "$consumer" -B "$consumer/build" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$consumer/build" >/dev/null
"$consumer/build/consumer"
