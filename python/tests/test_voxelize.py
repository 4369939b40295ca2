"""voxelize and Grid against the CLI on the same files (the same bits, the same files byte for byte, the
same grid contract) and against the exact generalized winding number computed here in NumPy."""
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import gregvox
from conftest import cube, tetrahedron


def winding_numbers(V, F, points, chunk=128):
    """The generalized winding number of each point (Van Oosterom & Strackee's solid angle per triangle)."""
    out = np.empty(len(points))
    tri = V[F]
    for s in range(0, len(points), chunk):
        p = points[s : s + chunk, None, None, :]
        a, b, c = (tri[None, :, k, :] - p[:, :, 0, :] for k in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum("pti,pti->pt", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("pti,pti->pt", a, b) * lc
        den += np.einsum("pti,pti->pt", b, c) * la + np.einsum("pti,pti->pt", c, a) * lb
        out[s : s + chunk] = np.arctan2(det, den).sum(axis=1) / (2 * np.pi)
    return out


def all_centres(grid):
    idx = np.indices(grid.dims).reshape(3, -1).T
    return grid.origin + (idx + 0.5) * grid.voxel_size


_winding_cache = {}


def winding_of_grid(V, F, grid, key):
    """The winding number at every voxel centre of ``grid``, computed once per mesh and grid."""
    if key not in _winding_cache:
        _winding_cache[key] = winding_numbers(V, F, all_centres(grid)).reshape(grid.dims)
    return _winding_cache[key]


@pytest.mark.parametrize("method", ["auto", "peel", "abuffer", "cpu"])
def test_a_closed_mesh_is_solid_exactly_where_its_winding_number_is_one(models, method):
    V, F = gregvox.load_mesh(models / "spot.obj")
    grid = gregvox.voxelize(V, F, res=20, method=method)
    inside = winding_of_grid(V, F, grid, "spot-20") > 0.5
    assert grid.occupancy.dtype == np.bool_ and grid.occupancy.shape == (20, 20, 20)
    assert inside.sum() > 500
    np.testing.assert_array_equal(grid.occupancy, inside)


@pytest.mark.parametrize("method", ["auto", "peel", "abuffer", "cpu"])
def test_an_open_mesh_is_exactly_its_generalized_winding_number(models, method):
    V, F = gregvox.load_mesh(models / "spot.obj")
    F = F[np.linalg.norm(V[F].mean(axis=1) - V[F].mean(axis=(0, 1)), axis=1).argsort()[200:]]  # holes
    assert not gregvox.topology(V, F)["closed"]
    w = None
    for rule, inside in (("gwn", lambda w: np.abs(w) >= 0.5), ("gwn-positive", lambda w: w >= 0.5)):
        grid = gregvox.voxelize(V, F, res=16, method=method, rule=rule)
        assert grid.report["rule"] == rule
        w = winding_of_grid(V, F, grid, "open-spot-16")
        assert ((w > 0.05) & (w < 0.95)).any()  # the holes matter
        # Every voxel, on the surface or off it: the decision is exact (no centre here is within 1e-9 of 1/2).
        assert np.abs(np.abs(w) - 0.5).min() > 1e-9
        np.testing.assert_array_equal(grid.occupancy, inside(w))


@pytest.mark.parametrize(
    "args,kwargs",
    [
        (["--res", "32"], dict(res=32)),
        (["--dims", "20,30,12"], dict(dims=(20, 30, 12))),
        (["--voxel-size", "0.05", "--pad", "2"], dict(voxel_size=0.05, pad=2)),
        (["--res", "16", "--bbox", "-0.5,-0.5,-0.5,0.5,0.5,0.5"], dict(res=16, bbox=((-0.5,) * 3, (0.5,) * 3))),
        (["--res", "24", "--fill", "surface"], dict(res=24, fill="surface")),
        (["--res", "24", "--fill", "both", "--rule", "parity"], dict(res=24, fill="both", rule="parity")),
    ],
)
def test_voxelize_gives_the_grid_and_the_files_of_the_cli(cli, models, tmp_path, args, kwargs):
    mesh = models / "cow.obj"
    V, F = gregvox.load_mesh(mesh)
    grid = gregvox.voxelize(V, F, **kwargs)
    ref = tmp_path / "cli.npy"
    report = cli.json("voxelize", mesh, *args, "--out", ref, "--json")
    np.testing.assert_array_equal(grid.occupancy, np.load(ref))
    cli_only = {"input", "res", "gregory_level", "seconds", "profile"}
    assert {k: v for k, v in report.items() if k not in cli_only} == {
        k: v for k, v in grid.report.items() if k not in ("notes", "seconds")
    }
    sidecar = json.loads((tmp_path / "cli.npy.json").read_text())
    assert list(grid.dims) == sidecar["dims"]
    np.testing.assert_array_equal(grid.origin, sidecar["origin"])
    np.testing.assert_array_equal(grid.voxel_size, sidecar["voxel_size"])
    np.testing.assert_array_equal(grid.index_to_world, np.array(sidecar["index_to_world"]).reshape(4, 4))
    # Every format the CLI writes, byte for byte (binvox only for cubic grids).
    formats = ["npy", "nrrd", "raw", "vox"] + (["binvox"] if "--res" in args else [])
    for ext in formats:
        mine = tmp_path / f"py.{ext}"
        grid.save(mine)
        theirs = tmp_path / f"cli.{ext}"
        if ext != "npy":
            cli.run("voxelize", mesh, *args, "--out", theirs)
        assert mine.read_bytes() == theirs.read_bytes(), ext
        if ext in ("npy", "raw", "vox"):
            assert (tmp_path / f"py.{ext}.json").read_bytes() == (tmp_path / f"cli.{ext}.json").read_bytes()
    grid.save(tmp_path / "packed.npy", npy_packed=True)
    cli.run("voxelize", mesh, *args, "--out", tmp_path / "cli-packed.npy", "--npy-packed")
    assert (tmp_path / "packed.npy").read_bytes() == (tmp_path / "cli-packed.npy").read_bytes()


def test_the_bunny_at_256_is_the_cli_grid(cli, models, tmp_path):
    mesh = models / "stanford-bunny.obj"
    V, F = gregvox.load_mesh(mesh)
    grid = gregvox.voxelize(V, F, res=256)
    cli.run("voxelize", mesh, "--res", "256", "--out", tmp_path / "bunny.npy")
    np.testing.assert_array_equal(grid.occupancy, np.load(tmp_path / "bunny.npy"))
    assert 0 < grid.library_seconds == grid.report["seconds"]


@pytest.mark.parametrize("name,res", [("stanford-bunny.obj", 40), ("cow.obj", 32), ("teapot.obj", 24)])
def test_the_boundary_mesh_is_watertight_oriented_and_holds_the_voxels_in_trimesh(cli, models, tmp_path, name, res):
    import trimesh

    V, F = gregvox.load_mesh(models / name)
    grid = gregvox.voxelize(V, F, res=res)
    BV, BF = grid.boundary_mesh()
    assert BF.shape[1] == 3 and BV.dtype == np.float64 and BF.dtype == np.int64
    tm = trimesh.Trimesh(BV, BF, process=False)
    assert tm.is_watertight and tm.is_winding_consistent
    cell = np.prod(grid.voxel_size)
    # Outward (positive volume), enclosing the solid voxels; split corners move 1/64 voxel at most.
    assert abs(tm.volume - grid.occupancy.sum() * cell) < 0.05 * cell * (1 + len(BV) / 8)
    # The faces lie on the voxel faces: every vertex within 1/64 voxel of a lattice point or (pinched
    # edges) of a lattice edge's midpoint.
    lattice = (BV - grid.origin) / grid.voxel_size
    half = np.abs(2 * lattice - np.round(2 * lattice)) / 2
    assert half.max() <= 1 / 64 + 1e-9
    assert ((np.abs(lattice - np.round(lattice)) > 0.25).sum(axis=1) <= 1).all()
    # The CLI's file is the same mesh, and trimesh reads it as one watertight solid.
    out = tmp_path / "b.obj"
    cli.run("voxelize", models / name, "--res", str(res), "--out", out)
    back = trimesh.load(out, process=False, force="mesh")
    assert len(back.vertices) == len(BV)
    np.testing.assert_allclose(back.vertices, BV, rtol=0, atol=1e-6 * np.abs(BV).max())
    assert back.is_watertight and back.is_winding_consistent
    grid.save(tmp_path / "py.obj")
    assert (tmp_path / "py.obj").read_bytes() == out.read_bytes()


_OPENVDB_CHECK = r"""
import json, sys
import numpy as np
import pyopenvdb as vdb
path, npy, shape = sys.argv[1], sys.argv[2], tuple(json.loads(sys.argv[3]))
g = vdb.read(path, "solid")
want = np.load(npy)
values = np.zeros(shape, dtype=bool)
g.copyToArray(values, ijk=(0, 0, 0))
active = np.zeros(shape, dtype=bool)
for it in g.citerOnValues():
    (x0, y0, z0), (x1, y1, z1) = it.min, it.max
    active[x0 : x1 + 1, y0 : y1 + 1, z0 : z1 + 1] = True
centre = [list(g.transform.indexToWorld(tuple(int(c) for c in ijk))) for ijk in [(0, 0, 0), (1, 2, 3)]]
print(json.dumps(dict(count=int(g.activeVoxelCount()), values=bool((values == want).all()),
                      active=bool((active == want).all()), name=g.name, centre=centre,
                      background=bool(g.background))))
"""


def _openvdb_python():
    """The system Python with OpenVDB's own module (Debian ``python3-openvdb``), or None."""
    exe = "/usr/bin/python3"
    ok = os.path.exists(exe) and subprocess.run([exe, "-c", "import pyopenvdb"], capture_output=True).returncode == 0
    return exe if ok else None


@pytest.mark.parametrize(
    "name,kwargs",
    [
        ("stanford-bunny.obj", dict(res=64)),
        ("cow.obj", dict(dims=(70, 33, 129))),
        ("teapot.obj", dict(voxel_size=0.05, pad=3)),
    ],
)
def test_vdb_files_read_back_in_openvdb_equal_the_grid(cli, models, tmp_path, name, kwargs):
    exe = _openvdb_python()
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("CI needs Debian's python3-openvdb (scripts/setup.sh installs it)")
        pytest.skip("OpenVDB's Python module (Debian python3-openvdb) is not installed")
    V, F = gregvox.load_mesh(models / name)
    grid = gregvox.voxelize(V, F, **kwargs)
    path, npy = tmp_path / "g.vdb", tmp_path / "g.npy"
    grid.save(path)
    np.save(npy, grid.occupancy)
    out = subprocess.run(
        [exe, "-c", _OPENVDB_CHECK, str(path), str(npy), json.dumps(list(grid.dims))],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got["count"] == int(grid.occupancy.sum()) and got["values"] and got["active"], got
    assert got["name"] == "solid" and got["background"] is False
    # VDB voxel (i, j, k) is centred where gregvox's voxel (i, j, k) is.
    for ijk, c in zip([(0, 0, 0), (1, 2, 3)], got["centre"]):
        np.testing.assert_allclose(c, (grid.index_to_world @ np.array([*ijk, 1.0]))[:3], rtol=0, atol=1e-12)
    # The CLI writes the same bytes.
    cli_args = []
    for k, v in kwargs.items():
        cli_args += [f"--{k.replace('_', '-')}", ",".join(map(str, v)) if isinstance(v, tuple) else str(v)]
    cli.run("voxelize", models / name, *cli_args, "--out", tmp_path / "cli.vdb")
    assert (tmp_path / "cli.vdb").read_bytes() == path.read_bytes()


_LEVEL_SET_CHECK = r"""
import json, sys
import numpy as np
import pyopenvdb as vdb
path, shape = sys.argv[1], tuple(json.loads(sys.argv[2]))
g = vdb.read(path, "sdf")
values = np.zeros(shape, dtype=np.float32)
g.copyToArray(values, ijk=(0, 0, 0))
active = []
for it in g.citerOnValues():
    assert it.min == it.max, "a level set has no active tiles"
    active.append([*it.min, it.value])
np.save(sys.argv[3], values)
np.save(sys.argv[4], np.array(active, dtype=np.float64))
print(json.dumps(dict(cls=g.gridClass, background=float(g.background), count=int(g.activeVoxelCount()))))
"""


def test_a_level_set_vdb_reads_back_in_openvdb_signed_by_the_grid_with_the_query_distances(cli, models, tmp_path):
    exe = _openvdb_python()
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("CI needs Debian's python3-openvdb (scripts/setup.sh installs it)")
        pytest.skip("OpenVDB's Python module (Debian python3-openvdb) is not installed")
    mesh = models / "teapot.obj"
    V, F = gregvox.load_mesh(mesh)
    grid = gregvox.voxelize(V, F, res=48)
    path = tmp_path / "ls.vdb"
    report = cli.json("voxelize", mesh, "--res", "48", "--what", "sdf", "--half-width", "2", "--out", path, "--json")
    out = subprocess.run(
        [exe, "-c", _LEVEL_SET_CHECK, str(path), json.dumps(list(grid.dims)), str(tmp_path / "v.npy"),
         str(tmp_path / "a.npy")],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    h = grid.voxel_size.max()
    assert got["cls"] == "level set" and abs(got["background"] - 2 * h) < 1e-6 * h
    assert got["count"] == report["level_set"]["active_voxels"] > 0
    values = np.load(tmp_path / "v.npy")
    # Negative exactly on the solid voxels; ±background off the band.
    np.testing.assert_array_equal(values < 0, grid.occupancy)
    active = np.load(tmp_path / "a.npy")
    ijk = active[:, :3].astype(int)
    centres = grid.origin + (ijk + 0.5) * grid.voxel_size
    sdf = gregvox.query(V, F, centres, what="sdf")["sdf"]
    np.testing.assert_allclose(active[:, 3], sdf, rtol=1e-6, atol=1e-7 * h)
    assert (np.abs(active[:, 3]) < got["background"]).all()


def test_grid_centres_and_matrix_follow_the_contract():
    V, F = cube()
    grid = gregvox.voxelize(V, F, dims=(4, 4, 4), bbox=((0, 0, 0), (1, 1, 1)))
    assert grid.occupancy.all()
    np.testing.assert_array_equal(grid.origin, [0, 0, 0])
    np.testing.assert_array_equal(grid.voxel_size, [0.25] * 3)
    c = grid.centers()
    assert c.shape == (64, 3)
    np.testing.assert_array_equal(c[0], [0.125] * 3)
    ijk1 = np.c_[np.argwhere(grid.occupancy), np.ones(64)]
    np.testing.assert_array_equal((grid.index_to_world @ ijk1.T).T[:, :3], c)
    # Indexed [x, y, z]: a slab in x only.
    grid = gregvox.voxelize(V, F, dims=(8, 4, 4), bbox=((0, 0, 0), (2, 1, 1)))
    assert grid.occupancy[:4].all() and not grid.occupancy[4:].any()


def test_arrays_of_any_layout_or_number_type_give_the_same_grid():
    V, F = tetrahedron()
    ref = gregvox.voxelize(V, F, res=12).occupancy
    variants = [
        (np.asfortranarray(V), np.asfortranarray(F)),
        (np.repeat(V, 2, axis=0)[::2], F),  # a strided view
        (V.astype(np.float32), F.astype(np.int32)),
        (V.astype(np.int64), F.astype(np.uint16)),
        (V.tolist(), F.tolist()),
        (V, [list(f) for f in F]),
    ]
    for v, f in variants:
        np.testing.assert_array_equal(gregvox.voxelize(v, f, res=12).occupancy, ref)


BAD = [
    ("V of strings", lambda V, F: (V.astype(str), F), {}),
    ("complex V", lambda V, F: (V.astype(complex), F), {}),
    ("bool V", lambda V, F: (V.astype(bool), F), {}),
    ("V (n, 2)", lambda V, F: (V[:, :2], F), {}),
    ("V (n, 3, 1)", lambda V, F: (V[:, :, None], F), {}),
    ("NaN in V", lambda V, F: (np.where(np.arange(12).reshape(4, 3) == 5, np.nan, V), F), {}),
    ("inf in V", lambda V, F: (V + np.array([0, 0, np.inf]), F), {}),
    ("index past V", lambda V, F: (V, np.where(F == 3, 4, F)), {}),
    ("negative index", lambda V, F: (V, -F), {}),
    ("float F", lambda V, F: (V, F.astype(float)), {}),
    ("F (m, 2)", lambda V, F: (V, F[:, :2]), {}),
    ("F (m, 3, 1)", lambda V, F: (V, F[:, :, None]), {}),
    ("a face of two", lambda V, F: (V, [[0, 1, 2], [0, 1]]), {}),
    ("empty V", lambda V, F: (np.zeros((0, 3)), np.zeros((0, 3), int)), {}),
    ("empty F", lambda V, F: (V, np.zeros((0, 3), int)), {}),
    ("res 0", lambda V, F: (V, F), dict(res=0)),
    ("negative res", lambda V, F: (V, F), dict(res=-4)),
    ("res and dims", lambda V, F: (V, F), dict(res=8, dims=(8, 8, 8))),
    ("two dims", lambda V, F: (V, F), dict(dims=(8, 8))),
    ("zero voxel size", lambda V, F: (V, F), dict(voxel_size=0.0)),
    ("NaN voxel size", lambda V, F: (V, F), dict(voxel_size=float("nan"))),
    ("inverted bbox", lambda V, F: (V, F), dict(res=8, bbox=((1, 1, 1), (0, 0, 0)))),
    ("bbox shape", lambda V, F: (V, F), dict(res=8, bbox=(0, 0, 0, 1, 1, 1))),
    ("unknown rule", lambda V, F: (V, F), dict(rule="majority")),
    ("unknown fill", lambda V, F: (V, F), dict(fill="hollow")),
    ("unknown method", lambda V, F: (V, F), dict(method="cuda")),
    ("a grid past the device", lambda V, F: (V, F), dict(res=200_000)),
]


@pytest.mark.parametrize("what,make,kwargs", BAD, ids=[b[0] for b in BAD])
def test_bad_input_raises_value_error_with_one_line(what, make, kwargs):
    V, F = make(*tetrahedron())
    with pytest.raises(ValueError) as e:
        gregvox.voxelize(V, F, **kwargs)
    message = str(e.value)
    assert message and "\n" not in message and "panick" not in message


def test_files_raise_os_error_and_write_nothing(tmp_path):
    with pytest.raises(OSError, match="missing.obj"):
        gregvox.load_mesh(tmp_path / "missing.obj")
    truncated = tmp_path / "cut.stl"
    truncated.write_bytes(b"\0" * 80 + (1000).to_bytes(4, "little") + b"\0" * 60)  # 1,000 triangles claimed
    with pytest.raises(ValueError, match="cut.stl"):
        gregvox.load_mesh(truncated)
    garbage = tmp_path / "garbage.obj"
    garbage.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="garbage.obj"):
        gregvox.load_mesh(garbage)
    grid = gregvox.voxelize(*tetrahedron(), res=8)
    with pytest.raises(OSError):
        grid.save(tmp_path / "no" / "such" / "folder" / "a.binvox")
    with pytest.raises(ValueError, match="format"):
        grid.save(tmp_path / "a.unknown")
    flat = gregvox.voxelize(*tetrahedron(), dims=(8, 8, 4))
    with pytest.raises(ValueError, match="binvox"):
        flat.save(tmp_path / "flat.binvox")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.stl", "garbage.obj"]


def test_a_device_that_does_not_exist_is_a_runtime_error():
    with pytest.raises(RuntimeError, match="no-such-gpu"):
        gregvox.Device("no-such-gpu")
    with pytest.raises(TypeError):
        gregvox.voxelize(*tetrahedron(), res=8, device="lavapipe")


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.parametrize("method", ["peel", "cpu"])
def test_a_thousand_voxelize_calls_keep_memory_flat(method):
    V, F = tetrahedron()
    for _ in range(50):  # warm: pipelines made, allocator pools grown
        gregvox.voxelize(V, F, res=16, method=method)
    before = rss_bytes()
    for _ in range(1000):
        grid = gregvox.voxelize(V, F, res=16, method=method)
    grown = rss_bytes() - before
    assert grid.occupancy.sum() > 0
    assert grown < 16 << 20, f"resident memory grew by {grown / 2**20:.1f} MiB over 1,000 calls"


def test_a_grid_whose_array_would_not_fit_in_memory_is_refused_before_any_work(tmp_path):
    child = tmp_path / "child.py"
    child.write_text(
        "import resource, sys\n"
        "resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))\n"
        "import numpy as np, gregvox\n"
        "V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)\n"
        "F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])\n"
        "try:\n"
        "    gregvox.voxelize(V, F, dims=(2048, 2048, 1024), method='cpu')\n"
        "except ValueError as e:\n"
        "    print(e)\n"
        "    sys.exit(3)\n"
    )
    p = subprocess.run([sys.executable, str(child)], capture_output=True, text=True)
    assert p.returncode == 3, p.stderr
    assert "2048×2048×1024" in p.stdout and "memory available" in p.stdout
    assert list(tmp_path.iterdir()) == [child]


def test_a_grid_past_the_engine_limits_names_the_limit():
    with pytest.raises(ValueError, match="between 1 and"):
        gregvox.voxelize(*tetrahedron(), dims=(100_000, 4, 4))
    with pytest.raises(ValueError, match="res=0"):
        gregvox.voxelize(*tetrahedron(), res=0)


def steps_per_second_beside(call):
    """How fast this thread counts while ``call`` runs in another thread (from its start to its end)."""
    import threading

    worker = threading.Thread(target=call)
    steps, start = 0, time.perf_counter()
    worker.start()
    while worker.is_alive():
        steps += 1
    elapsed = time.perf_counter() - start
    worker.join()
    return steps / elapsed


@pytest.mark.parametrize("method", ["peel", "cpu"])
def test_the_gil_is_released_while_the_engine_works(models, method):
    # While another thread voxelizes, this one keeps counting at about its pace beside a sleeping thread;
    # a call holding the GIL (the control: usleep through ctypes.PyDLL) stops it for the whole call.
    import ctypes

    V, F = gregvox.load_mesh(models / "stanford-bunny.obj")
    pace = steps_per_second_beside(lambda: time.sleep(0.3))
    held = steps_per_second_beside(lambda: ctypes.PyDLL(None).usleep(300_000))
    assert held < 0.2 * pace, "the control did not hold the GIL: the measure cannot tell"
    during = steps_per_second_beside(lambda: gregvox.voxelize(V, F, res=192, method=method))
    assert during > 0.4 * pace, f"{during:.0f} steps/s beside voxelize, {pace:.0f} beside a sleep"
