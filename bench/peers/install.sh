#!/bin/sh
# Installs the peers `gregvox bench` runs beside gregvox (one command, from the repository root):
#   bash bench/peers/install.sh
# - apt: libosd-dev (OpenSubdiv 3.5) and a C++ compiler, fonts-dejavu-core (plot labels); for the GPU peer
#   EGL + OpenGL through glvnd and Mesa (libegl-dev, libopengl-dev, libgl1 — libosdGPU dlopens libGL.so.1 —,
#   libegl-mesa0, libgl1-mesa-dri: llvmpipe where there is no GPU);
# - pip: libigl, trimesh, numpy, scipy, fast-simplification, pyfqmr (bench/peers/requirements.txt);
# - builds examples/meshopt_peer.rs (meshoptimizer through the meshopt crate) into target/bench-peers;
# - builds bench/peers/osd_eval_bench.cpp into target/bench-peers/osd_eval_bench and
#   bench/peers/osd_glcompute_bench.cpp into target/bench-peers/osd_glcompute_bench (where `gregvox bench`
#   looks by default; `--peers DIR` to change).
# Needs root or sudo for apt-get (skipped when the packages are already installed).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
missing=""
for p in libosd-dev g++ fonts-dejavu-core python3-pip libegl-dev libopengl-dev libgl1 libegl-mesa0 libgl1-mesa-dri; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing
fi
python3 -c "import igl, trimesh, numpy, scipy, fast_simplification, pyfqmr" 2>/dev/null ||
    python3 -m pip install --break-system-packages -r "$here/requirements.txt" ||
    python3 -m pip install -r "$here/requirements.txt"
mkdir -p "$root/target/bench-peers"
c++ -O2 -fopenmp -std=c++14 -o "$root/target/bench-peers/osd_eval_bench" "$here/osd_eval_bench.cpp" -losdCPU
c++ -O2 -fopenmp -std=c++14 -o "$root/target/bench-peers/osd_ptex_bench" "$here/osd_ptex_bench.cpp" -losdCPU
c++ -O2 -std=c++14 -o "$root/target/bench-peers/osd_glcompute_bench" "$here/osd_glcompute_bench.cpp" \
    -losdGPU -losdCPU -lEGL -lOpenGL
# The meshoptimizer peer of the simplify suite: an example of this crate (the meshopt crate compiles
# meshoptimizer's C++ source), copied where `gregvox bench` looks for peers.
cargo build --release --quiet --example meshopt_peer --manifest-path "$root/Cargo.toml"
cp "$root/target/release/examples/meshopt_peer" "$root/target/bench-peers/meshopt_peer"
echo "peers installed: target/bench-peers/osd_eval_bench, osd_ptex_bench, osd_glcompute_bench, python3 libigl + trimesh"
