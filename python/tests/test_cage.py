"""Tagged cages from Python: the tags `gregvox.load_cage` reads reach the engine (the CLI of this checkout is
the oracle), evaluation at (face, u, v) equals `gregvox evaluate`, bad tags and rows are ValueErrors."""
import numpy as np
import pytest

import gregvox
from conftest import read_obj


def test_load_cage_reads_opensubdivs_tags(models):
    V, F, tags = gregvox.load_cage(models / "opensubdiv" / "catmark_edgenone.obj")
    assert V.shape == (64, 3)
    assert tags["boundary"] == "none"
    assert tags["creases"].shape == (18, 2) and (tags["crease_sharpness"] == 10).all()
    assert tags["corners"].shape == (1,)
    _, _, plain = gregvox.load_cage(models / "opensubdiv" / "catmark_cube.obj")
    assert plain["creases"].shape == (0, 2) and plain["boundary"] == "edge-only"


def test_a_tagged_surface_is_the_cli_tessellation(cli, models, tmp_path):
    cage = models / "opensubdiv" / "catmark_hole_test1.obj"
    V, F, tags = gregvox.load_cage(cage)
    s = gregvox.GregorySurface(V, F, **tags)
    assert s.patch_count == 5  # one face is a hole
    P, N = s.evaluate(3)
    out = tmp_path / "cli.obj"
    cli.run("tessellate", cage, "--level", 3, "--no-weld", "--out", out)
    v, vn, f = read_obj(out)
    np.testing.assert_array_equal(P.reshape(-1, 3), v.astype(np.float32))
    # Without the tags the hole is drawn: the tags reached the engine.
    assert gregvox.GregorySurface(V, F).patch_count == 6


def test_creases_change_the_surface_and_semi_sharp_ones_refine_it(models):
    V, F, _ = gregvox.load_cage(models / "opensubdiv" / "catmark_cube.obj")
    smooth, _ = gregvox.GregorySurface(V, F).evaluate(2)
    edges = np.array([[0, 1], [1, 3], [3, 2], [2, 0]])
    sharp, _ = gregvox.GregorySurface(V, F, creases=edges).evaluate(2)
    assert not np.array_equal(smooth, sharp)
    # Semi-sharp (2.0): two levels, 16 patches a face; the same as the cage file's own tags.
    semi = gregvox.GregorySurface(V, F, creases=[[0, 1], [1, 3]], crease_sharpness=2.0)
    assert semi.patch_count == 96
    Vc, Fc, tags = gregvox.load_cage(models / "opensubdiv" / "catmark_cube_creases0.obj")
    from_file = gregvox.GregorySurface(Vc, Fc, **tags)
    assert from_file.patch_count == 96
    # isolation: more levels than the cage needs, never fewer.
    assert gregvox.GregorySurface(V, F, isolation=1).patch_count == 24
    with pytest.raises(ValueError, match="isolation 1 is below"):
        gregvox.GregorySurface(Vc, Fc, isolation=1, **tags)
    with pytest.raises(ValueError, match="not an edge"):
        gregvox.GregorySurface(V, F, creases=[[0, 7]])
    with pytest.raises(ValueError, match="boundary"):
        gregvox.GregorySurface(V, F, boundary="sideways")


def _read_npz(path):
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def test_evaluate_at_is_the_cli_evaluation(cli, models, tmp_path):
    cage = models / "opensubdiv" / "catmark_nonquads.obj"
    V, F, tags = gregvox.load_cage(cage)
    rng = np.random.default_rng(7)
    n_ptex = sum(1 if len(f) == 4 else len(f) for f in F)
    fuv = np.column_stack([rng.integers(0, n_ptex, 300), rng.random(300), rng.random(300)]).astype(float)
    ours = gregvox.evaluate_at(V, F, fuv, **tags, isolation=2)
    np.save(tmp_path / "fuv.npy", fuv)
    cli.run("evaluate", cage, "--at", tmp_path / "fuv.npy", "--out", tmp_path / "p.npz", "--isolation", 2)
    theirs = _read_npz(tmp_path / "p.npz")
    # catmark_nonquads has UVs (vt): "uv" (N, 2) beside the six (N, 3) arrays.
    assert set(theirs) == set(ours) == {"position", "du", "dv", "duu", "duv", "dvv", "uv"}
    for k in ours:
        assert ours[k].shape == (300, 2 if k == "uv" else 3) and ours[k].dtype == np.float64
        np.testing.assert_array_equal(ours[k], theirs[k])
    # The derivatives are those of the positions (central differences, away from the quadrant seams).
    inner = fuv.copy()
    inner[:, 1:] = 0.1 + 0.3 * inner[:, 1:]
    h = 1e-6
    p = gregvox.evaluate_at(V, F, inner, **tags)
    fd = (gregvox.evaluate_at(V, F, inner + [0, h, 0], **tags)["position"]
          - gregvox.evaluate_at(V, F, inner - [0, h, 0], **tags)["position"]) / (2 * h)
    np.testing.assert_allclose(fd, p["du"], atol=1e-6)


def test_evaluate_at_refines_feature_adaptively_past_the_surfaces_limit(cli, models, tmp_path):
    # OpenSubdiv's catmark_car: 314 creases of sharpness 6, whose uniform refinement would make 6.4 M
    # patches. evaluate_at refines only around the creases and equals `gregvox evaluate`; a GregorySurface
    # grids every ptex face over those patches, as `gregvox tessellate` does, and moves with its cage.
    cage = models / "opensubdiv" / "catmark_car.obj"
    V, F, tags = gregvox.load_cage(cage)
    s = gregvox.GregorySurface(V, F, **tags)
    assert s.patch_count == len(F)
    P, _ = s.evaluate(2)
    cli.run("tessellate", cage, "--level", 2, "--no-weld", "--out", tmp_path / "car.obj")
    v, _, _ = read_obj(tmp_path / "car.obj")
    np.testing.assert_array_equal(P.reshape(-1, 3), v.astype(np.float32))
    # Moving the cage keeps its feature-adaptive patches: the same grids as a surface built on the moved cage.
    moved = V * 1.1 + np.array([0.3, -0.2, 0.1])
    s.set_cage(moved)
    P2, _ = s.evaluate(2)
    P3, _ = gregvox.GregorySurface(moved, F, **tags).evaluate(2)
    np.testing.assert_array_equal(P2, P3)
    assert not np.array_equal(P2, P)
    with pytest.raises(ValueError, match="must have shape"):
        s.set_cage(V[:-1])
    rng = np.random.default_rng(3)
    fuv = np.column_stack([rng.integers(0, len(F), 200), rng.random(200), rng.random(200)]).astype(float)
    ours = gregvox.evaluate_at(V, F, fuv, **tags)
    np.save(tmp_path / "fuv.npy", fuv)
    cli.run("evaluate", cage, "--at", tmp_path / "fuv.npy", "--out", tmp_path / "p.npz")
    theirs = _read_npz(tmp_path / "p.npz")
    np.testing.assert_array_equal(ours["position"], theirs["position"])
    assert np.isfinite(ours["du"]).all()


def test_bad_rows_are_value_errors(models):
    V, F, tags = gregvox.load_cage(models / "opensubdiv" / "catmark_hole_test1.obj")
    with pytest.raises(ValueError, match="row 1.*hole"):
        gregvox.evaluate_at(V, F, [[0, 0.5, 0.5], [1, 0.5, 0.5]], **tags)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        gregvox.evaluate_at(V, F, [[0, 0.5, 1.5]], **tags)
    with pytest.raises(ValueError, match="whole number"):
        gregvox.evaluate_at(V, F, [[0.5, 0.5, 0.5]], **tags)
    with pytest.raises(ValueError, match="shape"):
        gregvox.evaluate_at(V, F, [0, 0.5, 0.5], **tags)


def test_uvs_follow_the_surface_as_the_cli_writes_them(cli, models, tmp_path):
    cage = models / "opensubdiv" / "catmark_fvar_bound1.obj"
    V, F, tags = gregvox.load_cage(cage)
    assert tags["uvs"].shape[1] == 2 and tags["uv_rule"] == 1
    assert np.asarray(tags["uv_faces"]).shape == np.asarray(F).shape
    s = gregvox.GregorySurface(V, F, **tags)
    assert s.has_uv
    P, N, UV = s.evaluate(3, uvs=True)
    assert UV.shape == P.shape[:3] + (2,) and UV.dtype == np.float32
    # The CLI's unwelded OBJ carries the same vt, bit for bit.
    out = tmp_path / "cli.obj"
    cli.run("tessellate", cage, "--level", 3, "--no-weld", "--out", out)
    vt = np.array([[float(x) for x in l.split()[1:3]] for l in out.read_text().splitlines() if l.startswith("vt ")])
    np.testing.assert_array_equal(UV.reshape(-1, 2), vt.astype(np.float32))
    # evaluate_at: the same UVs in float64 at the grid's parameters, and "uv" only with UVs.
    fuv = np.array([[p, i / 3, j / 3] for p in range(s.patch_count) for j in range(4) for i in range(4)])
    r = gregvox.evaluate_at(V, F, fuv, **tags)
    np.testing.assert_allclose(r["uv"], UV.reshape(-1, 2), atol=1e-6)
    assert "uv" not in gregvox.evaluate_at(V, F, fuv)
    with pytest.raises(ValueError, match="no UVs"):
        gregvox.GregorySurface(V, F).evaluate(2, uvs=True)
    # The rule changes the UVs at the UV boundary: linear-all (5) is bilinear inside every face.
    lin = gregvox.evaluate_at(V, F, fuv, **{**tags, "uv_rule": 5})["uv"]
    assert not np.allclose(lin, r["uv"])
    with pytest.raises(ValueError, match="uv_rule"):
        gregvox.evaluate_at(V, F, fuv, **{**tags, "uv_rule": 7})
    with pytest.raises(ValueError, match="out of range"):
        gregvox.evaluate_at(V, F, fuv, **{**tags, "uvs": tags["uvs"][:3]})
    with pytest.raises(ValueError, match="one value index per corner"):
        gregvox.evaluate_at(V, F, fuv, **{**tags, "uv_faces": np.asarray(tags["uv_faces"])[:, :3]})
