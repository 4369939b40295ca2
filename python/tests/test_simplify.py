"""gregvox.simplify against `gregvox simplify` (the CLI of this checkout) on the same mesh: the same
triangles; its guarantees checked here with NumPy (closed stays closed, the Euler characteristic kept,
borders on their input vertices), its targets and its errors."""
import numpy as np
import pytest

import gregvox
from conftest import read_obj


def euler_and_boundary(F):
    """(χ, boundary edge count) of a triangle mesh, from its unique undirected edges."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return len(np.unique(F)) - len(u) + len(F), int((c == 1).sum()), int((c > 2).sum())


def test_the_bunny_keeps_its_topology_and_matches_the_cli(models, cli, tmp_path):
    V, F = gregvox.load_mesh(models / "stanford-bunny.obj")
    V2, F2, err = gregvox.simplify(V, F, ratio=0.1)
    assert V2.dtype == np.float64 and F2.dtype == np.int64 and F2.shape[1] == 3
    assert len(F2) <= len(F) // 10 and len(F2) >= len(F) // 10 - 2
    assert 0 < err < 1e-2
    chi, boundary, nonmanifold = euler_and_boundary(F)
    chi2, boundary2, nonmanifold2 = euler_and_boundary(F2)
    assert (chi2, nonmanifold2) == (chi, nonmanifold)
    assert boundary2 <= boundary
    out = tmp_path / "b.obj"
    report = cli.json("simplify", models / "stanford-bunny.obj", "--ratio", 0.1, "--out", out, "--json")
    level = report["levels"][0]
    assert level["faces"] == len(F2) and level["out"] == str(out)
    Vc, _, Fc = read_obj(out)
    assert np.array_equal(np.asarray(Fc), F2)
    assert np.allclose(Vc, V2, atol=1e-5)


def test_targets_placements_and_the_report(models):
    V, F = gregvox.load_mesh(models / "spot.obj")
    _, F_keep, rep_keep = gregvox.simplify(V, F, faces=500, placement="keep", report=True)
    _, F_opt, rep_opt = gregvox.simplify(V, F, faces=500, report=True)
    assert len(F_keep) <= 500 and len(F_opt) <= 500
    assert rep_opt["relative_error"] <= rep_keep["relative_error"]
    assert set(rep_opt) >= {"faces", "vertices", "error", "relative_error", "collapses", "passes"}
    _, F_err, rep = gregvox.simplify(V, F, error=1e-3, report=True)
    assert rep["relative_error"] <= 1e-3 and len(F_err) < len(F)
    # lock_border on a closed mesh changes nothing; on a square it keeps every border vertex.
    n = 20
    g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="xy"), -1).reshape(-1, 2)
    Vg = np.c_[g, np.zeros(len(g))].astype(float)
    i = np.arange(n)
    a = (i[None, :] + (n + 1) * i[:, None]).ravel()
    Fg = np.concatenate([np.c_[a, a + 1, a + n + 2], np.c_[a, a + n + 2, a + n + 1]])
    V3, F3, _ = gregvox.simplify(Vg, Fg, faces=0, lock_border=True)
    on_border = lambda P: (P[:, 0] % n == 0) | (P[:, 1] % n == 0)
    assert on_border(V3[np.unique(F3)]).sum() == 4 * n


def test_bad_targets_raise():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    with pytest.raises(ValueError, match="target"):
        gregvox.simplify(V, F)
    with pytest.raises(ValueError, match="ratio"):
        gregvox.simplify(V, F, ratio=2.0)
    with pytest.raises(ValueError, match="placement"):
        gregvox.simplify(V, F, ratio=0.5, placement="middle")
    with pytest.raises(ValueError):
        gregvox.simplify(V, np.array([[0, 1, 7]]), ratio=0.5)
