#!/usr/bin/env bash
# Install what shatter needs to build and test, from Debian 12 packages only. Idempotent: installs
# only what is missing and says what it installs. Needs root or sudo.
#   scripts/setup.sh          build + test dependencies
#   scripts/setup.sh --fuzz   also clang-19 and its libFuzzer runtime
#   scripts/setup.sh --tsan   also clang-19, its TSan runtime and llvm-symbolizer (llvm-19), for the
#                             tsan preset
#   scripts/setup.sh --test   also the test tools from the npm registry: the Khronos glTF validator
#                             (tests/tools/gltf; Node.js and npm from Debian when npm is missing)
# The flags combine (scripts/test.sh passes all three).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  # toolchain
  g++ cmake ninja-build ccache pkg-config
  # layout and lint checks (scripts/format.sh, scripts/tidy.sh)
  clang-format-19 clang-tidy-19
  # core library
  libeigen3-dev libxxhash-dev zlib1g-dev
  # tools
  libcli11-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  # tests and benchmarks; independent references the tests compare against
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-meshio calculix-ccx
  # benchmark peer for the rigid world (linked into bench/ only)
  libbullet-dev
  # renderer and viewer (shatter render / shatter view): OpenGL through libepoxy, headless through
  # EGL with Mesa's software rasterizer (llvmpipe: no GPU needed), windows with GLFW, Dear ImGui
  # (with its GLFW and OpenGL 3 back ends); Xvfb for the viewer's tests
  libepoxy-dev libegl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libimgui-dev xvfb xauth
)
test_tools=0
for arg in "$@"; do
  case "$arg" in
    --fuzz) packages+=(clang-19 libclang-rt-19-dev) ;;
    --tsan) packages+=(clang-19 libclang-rt-19-dev llvm-19) ;;
    --test)
      test_tools=1
      command -v npm >/dev/null || packages+=(nodejs npm)
      ;;
    *) echo "setup: unknown option $arg (expected --fuzz, --tsan and/or --test)" >&2; exit 2 ;;
  esac
done
# Each package once (--fuzz and --tsan share clang-19).
mapfile -t packages < <(printf '%s\n' "${packages[@]}" | awk '!seen[$0]++')

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# The glTF validator, at the version package-lock.json names (after the packages: npm may be one).
install_test_tools() {
  [[ $test_tools == 1 ]] || return 0
  if [[ ! -f tests/tools/gltf/node_modules/gltf-validator/package.json ]]; then
    echo "setup: installing the glTF validator (npm ci in tests/tools/gltf)"
    (cd tests/tools/gltf && npm ci --no-audit --no-fund --silent)
  fi
}

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "setup: all ${#packages[@]} packages present"
  install_test_tools
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_test_tools
echo "setup: done"
