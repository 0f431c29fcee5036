#!/usr/bin/env bash
# Install what shatter needs to build and test, from Debian 12 packages only. Idempotent: installs
# only what is missing and says what it installs. Needs root or sudo.
#   scripts/setup.sh          build + test dependencies
#   scripts/setup.sh --fuzz   also clang-19 and its libFuzzer runtime
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build ccache pkg-config
  # core library
  libeigen3-dev libxxhash-dev
  # tools
  libcli11-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  # tests and benchmarks; independent references the tests compare against
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-meshio calculix-ccx
)
if [[ "${1:-}" == "--fuzz" ]]; then
  packages+=(clang-19 libclang-rt-19-dev)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "setup: all ${#packages[@]} packages present"
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
echo "setup: done"
