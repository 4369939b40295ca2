#!/bin/sh
# Builds the OpenSubdiv oracle and regenerates tests/fixtures/surface/*.osd (docs/notes/gregory.md §4.3).
# Needs libosd-dev (Debian 3.5: `apt-get install -y libosd-dev`). The Rust tests only read the fixtures.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
models="$root/assets/models"
out="$root/tests/fixtures/surface"
bin="${TMPDIR:-/tmp}/osd_gregory"
mkdir -p "$out"
c++ -O2 -std=c++14 -o "$bin" "$here/osd_gregory.cpp" -losdCPU
osd="$models/opensubdiv"
# (catmark_gregory_test4 and catmark_fan are non-manifold: gregvox rejects them, so no fixture.)
for c in catmark_cube catmark_torus catmark_gregory_test0 catmark_gregory_test1 \
         catmark_gregory_test6 catmark_tent catmark_flap; do
    "$bin" "$osd/$c.obj" "$out/$c.osd" --samples
done
# Exact limit position and tangents per cage vertex (Sdc masks) for the Tangents::Exact checks.
"$bin" "$osd/catmark_cube.obj" "$out/catmark_cube.osd" --samples --limit "$out/catmark_cube.limit"
# Valence 2 and mixed faces: one uniform Catmull-Clark step by Far, then isolation 0 on the refined cage.
"$bin" "$osd/catmark_gregory_test8.obj" "$out/catmark_gregory_test8_r1.osd" --refine --samples
"$bin" "$osd/catmark_nonquads.obj" "$out/catmark_nonquads_r1.osd" --refine
# Large: f32 points, no samples (keeps the fixture under 1 MB).
"$bin" "$models/spot_quadrangulated.obj" "$out/spot_quadrangulated.osd" --f32 --limit "$out/spot_quadrangulated.limit"
