"""gregvox.query against the exact winding number computed here in NumPy and against `gregvox query` (the
CLI of this checkout) on the same points: the same answers, whatever the dtype of the points."""
import numpy as np
import pytest

import gregvox
from conftest import cube
from test_voxelize import winding_numbers


def open_box():
    """The unit cube without its top (two triangles removed): an open mesh, w fractional inside."""
    V, F = cube()
    keep = [i for i, t in enumerate(F) if not all(V[t][:, 2] == 1)]
    return V, F[keep]


def points(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.3, 1.3, size=(n, 3))


def test_winding_and_occupancy_equal_the_exact_sum_on_an_open_box():
    V, F = open_box()
    P = points(2000)
    out = gregvox.query(V, F, P, what=("winding", "occupancy"))
    ref = winding_numbers(V, F, P)
    assert out["winding"].dtype == np.float64 and out["occupancy"].dtype == np.bool_
    assert np.abs(out["winding"] - ref).max() <= 1e-6
    clear = np.abs(np.abs(ref) - 0.5) > 1e-6
    assert np.array_equal(out["occupancy"][clear], (np.abs(ref) >= 0.5)[clear])
    # Inside the box, below its missing top, w lies strictly between 0 and 1 (the open top subtends the rest).
    inside = np.all((P > 0.05) & (P < 0.95), axis=1)
    assert np.all((out["winding"][inside] > 0) & (out["winding"][inside] < 1))


def test_distances_are_signed_by_occupancy_and_float32_points_give_the_same_answers():
    V, F = cube()
    P = points(500, seed=1)
    out = gregvox.query(V, F, P, what="sdf,udf,occupancy,closest")
    assert out["sdf"].dtype == np.float32 and out["udf"].dtype == np.float32
    assert np.array_equal(np.abs(out["sdf"]), out["udf"])
    assert np.array_equal(out["sdf"] < 0, out["occupancy"] & (out["udf"] > 0))
    # The cube's distance by hand: outside, the distance to the box; inside, to the nearest face.
    d_out = np.linalg.norm(np.maximum(np.maximum(-P, P - 1), 0), axis=1)
    d_in = np.minimum(P, 1 - P).min(axis=1)
    inside = np.all((P > 0) & (P < 1), axis=1)
    expect = np.where(inside, d_in, d_out)
    assert np.abs(out["udf"] - expect).max() <= 1e-6
    assert np.abs(np.linalg.norm(out["closest"] - P, axis=1) - expect).max() <= 1e-6
    tri = V[F[out["face"]]]
    on = np.einsum("nk,nki->ni", out["barycentric"], tri)
    assert np.abs(on - out["closest"]).max() <= 1e-12
    positive = gregvox.query(V, F, P.astype(np.float32), what=["sdf"], sdf_sign="inside-positive")
    same = gregvox.query(V, F, P.astype(np.float32).astype(np.float64), what=["sdf"])
    assert np.array_equal(positive["sdf"], -same["sdf"])


def test_distances_searched_on_the_device_are_the_cpus():
    V, F = open_box()
    P = points(2000, seed=4)
    what = "sdf,udf,closest"
    cpu = gregvox.query(V, F, P, what=what)
    dev = gregvox.query(V, F, P, what=what, device=gregvox.default_device())
    assert sorted(cpu) == sorted(dev)
    for k in cpu:
        assert np.array_equal(cpu[k], dev[k]), k
    with pytest.raises(TypeError):
        gregvox.query(V, F, P, what="udf", device="gpu")


def test_the_cli_gives_the_same_arrays(cli, tmp_path):
    V, F = open_box()
    P = points(300, seed=2)
    np.save(tmp_path / "p.npy", P)
    obj = tmp_path / "box.obj"
    obj.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in V) + "".join(f"f {a+1} {b+1} {c+1}\n" for a, b, c in F))
    cli.run("query", obj, "--points", tmp_path / "p.npy", "--what", "winding,occupancy,sdf", "--out", tmp_path / "q.npz")
    z = np.load(tmp_path / "q.npz")
    out = gregvox.query(V, F, P, what=("winding", "occupancy", "sdf"))
    for name in ("winding", "occupancy", "sdf"):
        assert np.array_equal(z[name], out[name]), name


def test_bad_input_raises_value_error():
    V, F = cube()
    with pytest.raises(ValueError, match="shape"):
        gregvox.query(V, F, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="not finite"):
        gregvox.query(V, F, np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(ValueError, match="what"):
        gregvox.query(V, F, np.zeros((1, 3)), what=["volume"])
    with pytest.raises(ValueError, match="rule"):
        gregvox.query(V, F, np.zeros((1, 3)), rule="parity")
