#!/usr/bin/env bash
# Sets a fresh Debian 12 machine up for gregvox and runs the main job.
#   bash scripts/setup.sh             install the system packages, build, run `gregvox info` and an offscreen demo
#   bash scripts/setup.sh --deps-only install the system packages only (what CI uses)
# Needs root or sudo for apt-get. Rust (cargo) must already be installed (rustup).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  mesa-vulkan-drivers libvulkan-dev vulkan-tools vulkan-validationlayers  # loader, lavapipe, validation layer
  libshaderc-dev glslang-dev spirv-tools                                  # shaderc's static libraries (build.rs)
  xvfb xauth                                                              # the windowed demo without a screen
  fonts-dejavu-core                                                       # labels of `gregvox bench`'s plots
  procps util-linux                                                       # kill and prlimit, used by the tests
  python3 python3-venv                                                    # the Python package (pip install ./python)
  python3-openvdb                                                         # OpenVDB's reader: the .vdb tests' oracle
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
[ "${1:-}" = "--deps-only" ] && exit 0

command -v cargo >/dev/null || { echo "cargo not found: install Rust with rustup first" >&2; exit 1; }
# With no GPU, Mesa's lavapipe is the device; 2 threads is fastest on 2 cores.
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
cargo build --release
./target/release/gregvox info
./target/release/gregvox demo --offscreen --scene flag --frames 60 --every 30 --size 640x360 --out out/demo/flag --profile
./target/release/gregvox demo --offscreen --scene cage --frames 60 --every 30 --size 640x360 --out out/demo/cage --profile
