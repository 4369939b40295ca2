"""GregorySurface against `gregvox tessellate --no-weld` on the same cages: the same GPU path, the same bits."""
import numpy as np
import pytest

import gregvox
from conftest import read_obj


def cli_points(cli, tmp_path, cage, level, *flags):
    out = tmp_path / "cli.obj"
    cli.run("tessellate", cage, "--level", level, "--no-weld", "--out", out, *flags)
    v, vn, f = read_obj(out)
    return v.astype(np.float32), vn.astype(np.float32), np.array(f)


@pytest.mark.parametrize("name,level", [("spot_quadrangulated.obj", 8), ("spot_quadrangulated.obj", 3), ("suzanne.obj", 5)])
def test_evaluate_is_bit_for_bit_the_cli_tessellation(cli, models, tmp_path, name, level):
    V, F = gregvox.load_mesh(models / name)
    s = gregvox.GregorySurface(V, F)
    P, N = s.evaluate(level)
    n = level + 1
    assert P.dtype == np.float32 and P.shape == (s.patch_count, n, n, 3) and N.shape == P.shape
    v, vn, f = cli_points(cli, tmp_path, models / name, level)
    np.testing.assert_array_equal(P.reshape(-1, 3), v)
    np.testing.assert_array_equal(N.reshape(-1, 3), vn)
    np.testing.assert_array_equal(s.indices(level), f)
    np.testing.assert_allclose(np.linalg.norm(N, axis=-1), 1, atol=1e-6)


def test_exact_tangents_are_the_cli_exact_tangents(cli, models, tmp_path):
    V, F = gregvox.load_mesh(models / "spot_quadrangulated.obj")
    P, N = gregvox.GregorySurface(V, F, tangents="exact").evaluate(4)
    v, vn, _ = cli_points(cli, tmp_path, models / "spot_quadrangulated.obj", 4, "--tangents", "exact")
    np.testing.assert_array_equal(P.reshape(-1, 3), v)
    np.testing.assert_array_equal(N.reshape(-1, 3), vn)
    P0, _ = gregvox.GregorySurface(V, F).evaluate(4)
    assert not np.array_equal(P, P0)  # the option reached the engine


def test_set_cage_re_evaluates_the_moved_cage(cli, models, tmp_path):
    V, F = gregvox.load_mesh(models / "spot_quadrangulated.obj")
    s = gregvox.GregorySurface(V, F)
    P0, _ = s.evaluate(6)
    rng = np.random.default_rng(7)
    moved = V + rng.normal(scale=0.01, size=V.shape)
    s.set_cage(moved)
    P1, N1 = s.evaluate(6)
    assert not np.array_equal(P0, P1)
    path = tmp_path / "moved.obj"
    with open(path, "w") as out:
        out.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in moved.tolist())
        out.writelines("f " + " ".join(str(i + 1) for i in f) + "\n" for f in F)
    v, vn, _ = cli_points(cli, tmp_path, path, 6)
    np.testing.assert_array_equal(P1.reshape(-1, 3), v)
    np.testing.assert_array_equal(N1.reshape(-1, 3), vn)
    # Moving it back gives the first surface again.
    s.set_cage(V)
    np.testing.assert_array_equal(s.evaluate(6)[0], P0)


def test_the_corners_of_each_patch_lie_on_the_limit_surface_of_a_flat_cage():
    # A flat 3 × 3 grid of quads: every patch is flat, z = 0, inside the cage's square.
    g = np.array([[x, y, 0.0] for y in range(4) for x in range(4)])
    F = [[y * 4 + x, y * 4 + x + 1, (y + 1) * 4 + x + 1, (y + 1) * 4 + x] for y in range(3) for x in range(3)]
    P, N = gregvox.GregorySurface(g, F).evaluate(4)
    assert P.shape == (9, 5, 5, 3)
    assert np.abs(P[..., 2]).max() == 0
    np.testing.assert_allclose(np.abs(N[..., 2]), 1, atol=1e-6)
    assert P[..., :2].min() >= 0 and P[..., :2].max() <= 3


def test_a_triangle_cage_is_refined_once_into_quads(models):
    V, F = gregvox.load_mesh(models / "spot.obj")
    s = gregvox.GregorySurface(V, F)
    assert s.patch_count == 3 * len(F)


BAD = [
    ("level 0", lambda s, V: s.evaluate(0)),
    ("level 65", lambda s, V: s.evaluate(65)),
    ("indices level 0", lambda s, V: s.indices(0)),
    ("cage of another size", lambda s, V: s.set_cage(V[:-1])),
    ("cage (n, 2)", lambda s, V: s.set_cage(V[:, :2])),
    ("NaN cage", lambda s, V: s.set_cage(np.where(V == V[0, 0], np.nan, V))),
    ("string cage", lambda s, V: s.set_cage(V.astype(str))),
]


@pytest.mark.parametrize("what,call", BAD, ids=[b[0] for b in BAD])
def test_bad_calls_raise_value_error(models, what, call):
    V, F = gregvox.load_mesh(models / "spot_quadrangulated.obj")
    s = gregvox.GregorySurface(V, F)
    with pytest.raises(ValueError) as e:
        call(s, V)
    assert "\n" not in str(e.value)
    assert s.evaluate(2)[0].shape == (s.patch_count, 3, 3, 3)  # still usable


def test_bad_cages_raise_value_error():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    with pytest.raises(ValueError, match="tangents"):
        gregvox.GregorySurface(V, [[0, 1, 2, 3]], tangents="bezier")
    with pytest.raises(ValueError):
        gregvox.GregorySurface(V, [[0, 1, 2, 7]])
    with pytest.raises(ValueError):
        gregvox.GregorySurface(np.full((4, 3), np.nan), [[0, 1, 2, 3]])


def test_a_surface_keeps_its_device_and_finish_refuses_while_it_lives():
    dev = gregvox.Device()
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    s = gregvox.GregorySurface(V, [[0, 1, 2, 3]], device=dev)
    with pytest.raises(RuntimeError, match="still used"):
        dev.finish()
    assert s.evaluate(2)[0].shape == (1, 3, 3, 3)
    del s
    dev.finish()
    with pytest.raises(RuntimeError, match="closed"):
        gregvox.voxelize(V, [[0, 1, 2]], res=4, device=dev)
