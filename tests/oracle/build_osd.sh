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
# Tagged shapes (infinitely sharp `t crease`/`t corner`, `t hole`, `t interpolateboundary`): the tags are the
# OBJ's own, read by the oracle and by gregvox alike.
for c in catmark_cube_corner4 catmark_edgecorner catmark_edgenone catmark_hole_test1 catmark_hole_test4 \
         catmark_inf_crease0 catmark_inf_crease1 catmark_xord_boundary catmark_quadstrips catmark_fvar_bound4 \
         catmark_xord_interior; do
    "$bin" "$osd/$c.obj" "$out/$c.osd" --samples
done
"$bin" "$osd/catmark_hole_test3.obj" "$out/catmark_hole_test3_r1.osd" --refine --samples
# gregvox's own tagged cages (tests/fixtures/surface/cages/): darts, an L-crease, a sharp interior corner; a
# creased pyramid of triangles (refined once).
"$bin" "$out/cages/quads_dart.obj" "$out/quads_dart.osd" --samples
"$bin" "$out/cages/pyramid_creased.obj" "$out/pyramid_creased_r1.osd" --refine --samples
# Valence 2 and mixed faces: one uniform Catmull-Clark step by Far, then isolation 0 on the refined cage.
"$bin" "$osd/catmark_gregory_test8.obj" "$out/catmark_gregory_test8_r1.osd" --refine --samples
"$bin" "$osd/catmark_nonquads.obj" "$out/catmark_nonquads_r1.osd" --refine
# Large: f32 points, no samples (keeps the fixture under 1 MB).
"$bin" "$models/spot_quadrangulated.obj" "$out/spot_quadrangulated.osd" --f32 --limit "$out/spot_quadrangulated.limit"
# Random (ptex face, u, v) samples through Far::PatchMap (tests/surface_evaluate.rs); raise N for a longer run
# (write the files to a folder DIR of their own and run the tests with GREGVOX_SURFACE_FIXTURES=DIR).
# With --fd, the exact derivatives of OpenSubdiv's positions there (differences of EvaluateBasis on the
# sample's patch), which the normals are checked against.
for c in catmark_cube catmark_torus catmark_gregory_test6 catmark_inf_crease0 catmark_edgenone catmark_hole_test1 \
         catmark_nonquads catmark_hole_test3; do
    "$bin" "$osd/$c.obj" /dev/null --ptex 1000 "$out/$c.ptex" --fd "$out/$c.fd"
done
# Semi-sharp creases and corners (uniform and Chaikin): OpenSubdiv's RefineAdaptive(⌈s⌉) patches at random
# (ptex face, u, v); 300 samples each keeps the fixtures small.
for c in catmark_cube_creases1 catmark_cube_creases2 catmark_cubes_semisharp catmark_chaikin0 \
         catmark_chaikin1 catmark_chaikin2 catmark_tent_creases0 catmark_tent_creases1 catmark_pyramid_creases0 catmark_pyramid_creases1 \
         catmark_pyramid_creases2 catmark_torus_creases0 catmark_torus_creases1 catmark_dart_edgeonly catmark_dart_edgecorner catmark_val2_interior \
         catmark_cube_corner0 catmark_cube_corner1 catmark_cube_corner2 catmark_cube_corner3 catmark_gregory_test3 catmark_cube_creases0 catmark_cubes_infsharp catmark_edgeonly; do
    "$bin" "$osd/$c.obj" /dev/null --ptex 300 "$out/$c.ptex"
done
# --isolation 2 on cages that need none: OpenSubdiv's RefineAdaptive(2) (EVs isolated to level 2).
for c in catmark_cube catmark_gregory_test6 catmark_tent; do
    "$bin" "$osd/$c.obj" /dev/null --ptex 300 "$out/${c}_iso2.ptex" --isolation 2
done
# Feature-adaptive refinement past the uniform refinement's limit (tests/surface_adaptive.rs): the car (314
# creases of sharpness 6: RefineAdaptive(6)) and a 64² grid with a crease polyline of 9.5 and a corner of 7.25
# (RefineAdaptive(10)), sampled everywhere and on the faces along the crease.
"$bin" "$osd/catmark_car.obj" /dev/null --ptex 1000 "$out/catmark_car.ptex" --fd "$out/catmark_car.fd"
"$bin" "$out/cages/grid64_crease9.obj" /dev/null --ptex 300 "$out/grid64_crease9.ptex"
"$bin" "$out/cages/grid64_crease9.obj" /dev/null --ptex 600 "$out/grid64_crease9_near.ptex" --faces 1984 2112
# Face-varying UVs (`vt`, `t facevaryinginterpolateboundary`, CORNERS_ONLY without the tag) through Far's
# smooth face-varying patches at random (ptex face, u, v) (tests/surface_uv.rs).
for c in catmark_cube catmark_torus catmark_fvar_bound0 catmark_fvar_bound1 catmark_fvar_bound2 catmark_fvar_bound3 \
         catmark_fvar_bound4 catmark_fvar_project0 catmark_cubes_infsharp catmark_cubes_semisharp catmark_xord_interior \
         catmark_xord_boundary catmark_edgenone catmark_edgecorner catmark_hole_test1 catmark_nonquads catmark_inf_crease0 \
         catmark_gregory_test6 catmark_chaikin0 catmark_quadstrips catmark_car; do
    "$bin" "$osd/$c.obj" /dev/null --fvar 300 "$out/$c.fvar"
done
# Every rule: the shapes above with `t facevaryinginterpolateboundary N` (N = 0, 2…5) appended (cages/fvar/).
for c in catmark_cube catmark_fvar_bound0 catmark_fvar_bound1 catmark_fvar_bound2 catmark_fvar_bound3 catmark_fvar_project0 \
         catmark_xord_interior catmark_edgecorner catmark_inf_crease0; do
    for r in 0 2 3 4 5; do
        (grep -v "^t facevaryinginterpolateboundary" "$osd/$c.obj"; echo "t facevaryinginterpolateboundary 1/0/0 $r") \
            > "$out/cages/fvar/${c}_r$r.obj"
        "$bin" "$out/cages/fvar/${c}_r$r.obj" /dev/null --fvar 200 "$out/${c}_r$r.fvar"
    done
done
# Semi-sharp creases ending at a UV seam (cages from tests/oracle/gen_seam_cages.py): OpenSubdiv's dependent
# sharpness under rules 2 and 3, and Chaikin averaging across the seam.
for c in seam_crease seam_crease_s25 seam_crease_chaikin seam_crease_chaikin2; do
    for r in 1 2 3; do
        "$bin" "$out/cages/fvar/${c}_r$r.obj" /dev/null --fvar 300 "$out/${c}_r$r.fvar"
    done
done
