"""load_mesh, topology, subdivide, mesh_matrices, action_map and vertex_normals against the CLI on the same
files and against trimesh where it computes the same thing."""
import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

import gregvox
from conftest import cube, read_obj, tetrahedron

TRIANGLE_MODELS = ["stanford-bunny.obj", "spot.obj", "cow.obj", "teapot.obj"]


def as_trimesh(V, F):
    return trimesh.Trimesh(V, F, process=False)


@pytest.mark.parametrize("name", TRIANGLE_MODELS)
def test_load_mesh_reads_an_obj_as_written_and_as_trimesh_does(models, name):
    V, F = gregvox.load_mesh(models / name)
    v, _, f = read_obj(models / name)
    assert V.dtype == np.float64 and F.dtype == np.int64 and F.shape == (len(f), 3)
    np.testing.assert_array_equal(V, v)  # every vertex, referenced or not, in file order
    np.testing.assert_array_equal(F, f)
    # trimesh drops unreferenced vertices: compare the triangles as position triples.
    t = trimesh.load(models / name, process=False, force="mesh")
    np.testing.assert_array_equal(V[F], t.vertices[t.faces])


def test_load_mesh_gives_polygons_as_a_list_of_index_arrays(models):
    V, F = gregvox.load_mesh(models / "spot_quadrangulated.obj")
    assert isinstance(F, list) and all(f.dtype == np.int64 and f.shape == (4,) for f in F)
    _, _, faces = read_obj(models / "spot_quadrangulated.obj")
    assert [list(f) for f in F] == faces


@pytest.mark.parametrize("ext", ["stl", "ply", "off", "glb"])
def test_every_format_of_the_loader_gives_the_topology_of_the_obj(models, tmp_path, ext):
    V, F = gregvox.load_mesh(models / "spot.obj")
    path = tmp_path / f"spot.{ext}"
    as_trimesh(V, F).export(path)
    V2, F2 = gregvox.load_mesh(path)
    assert gregvox.topology(V2, F2) == gregvox.topology(V, F)
    # The same triangles in the same order; STL, PLY and glTF as trimesh writes them hold float32.
    assert F2.shape == F.shape
    np.testing.assert_allclose(V2[F2], V[F], rtol=0, atol=1e-7)


@pytest.mark.parametrize("name", TRIANGLE_MODELS + ["spot_quadrangulated.obj"])
def test_topology_is_the_cli_mesh_report(cli, models, name):
    V, F = gregvox.load_mesh(models / name)
    assert gregvox.topology(V, F) == cli.json("mesh", models / name, "--json")


@pytest.mark.parametrize("name", TRIANGLE_MODELS)
def test_topology_agrees_with_trimesh(models, name):
    V, F = gregvox.load_mesh(models / name)
    report = gregvox.topology(V, F)
    t = as_trimesh(V, F)
    assert report["faces"] == len(t.faces)
    assert report["edges"] == len(t.edges_unique)
    assert report["closed"] == t.is_watertight
    # trimesh counts each unreferenced vertex as a body and as a vertex; the report counts referenced ones.
    unreferenced = report["unreferenced_vertices"]
    assert report["components"] == t.body_count - unreferenced
    assert report["euler_characteristic"] == t.euler_number


@pytest.mark.parametrize(
    "name,scheme,levels",
    [("spot_quadrangulated.obj", "catmull-clark", 2), ("spot.obj", "loop", 1), ("cow.obj", "loop-warren", 2)],
)
def test_subdivide_writes_what_the_cli_writes(cli, models, tmp_path, name, scheme, levels):
    V, F = gregvox.load_mesh(models / name)
    V2, F2 = gregvox.subdivide(V, F, levels, scheme=scheme)
    out = tmp_path / "sub.obj"
    cli.run("subdivide", models / name, "--levels", levels, "--scheme", scheme, "--out", out)
    V3, _, F3 = read_obj(out)
    np.testing.assert_array_equal(V2, V3)  # the OBJ holds the shortest exact decimal of each f64
    assert [list(f) for f in F2] == F3


def test_subdivision_counts_agree_with_trimesh(models):
    V, F = gregvox.load_mesh(models / "spot.obj")  # closed
    V2, F2 = gregvox.subdivide(V, F, 2, scheme="loop")
    v3, f3 = trimesh.remesh.subdivide_loop(V, F, iterations=2)
    assert V2.shape == v3.shape and F2.shape == f3.shape
    # trimesh's subdivide_loop is Loop's original scheme: the same points, numbered its own way.
    distance, nearest = cKDTree(v3).query(V2)
    assert distance.max() < 1e-14 and len(np.unique(nearest)) == len(v3)
    # Catmull-Clark on a quad cage: each level adds a point per edge and per face, splits every edge in
    # two and adds four edges per quad, and makes four quads of each.
    Vq, Fq = gregvox.load_mesh(models / "spot_quadrangulated.obj")
    Vc, Fc = gregvox.subdivide(Vq, Fq, 3)
    r = gregvox.topology(Vq, Fq)
    v, e, f = r["vertices"], r["edges"], r["faces"]
    for _ in range(3):
        v, e, f = v + e + f, 2 * e + 4 * f, 4 * f
    assert (len(Vc), len(Fc)) == (v, f)
    assert gregvox.topology(Vc, Fc)["edges"] == e


def test_mesh_matrices_hold_the_faces_edges_and_adjacency_trimesh_computes(models):
    V, F = gregvox.load_mesh(models / "stanford-bunny.obj")
    m = gregvox.mesh_matrices(V, F)
    n, f = len(V), len(F)
    M, B, E = m["M"], m["B"], m["E"]
    assert M.shape == (n, f) and B.shape == (n, f) and E.shape == (n, n)
    # M[F[f, k], f] = k + 1, and nothing else.
    assert M.nnz == F.size
    for k in range(3):
        np.testing.assert_array_equal(np.asarray(M[F[:, k], np.arange(f)]).ravel(), k + 1)
    # E[i, j] = face + 1 of the half-edge i -> j.
    for k in range(3):
        i, j = F[:, k], F[:, (k + 1) % 3]
        np.testing.assert_array_equal(np.asarray(E[i, j]).ravel(), np.arange(f) + 1)
    assert E.nnz == F.size
    t = as_trimesh(V, F)
    # Vertex adjacency: the unique edges.
    A = m["adjacency"].tocoo()
    mine = {(a, b) for a, b in zip(A.row, A.col) if a < b}
    assert mine == {tuple(e) for e in t.edges_unique}
    # Dual adjacency: trimesh's face_adjacency (pairs of faces sharing an edge).
    D = m["dual_adjacency"]
    assert (D != D.T).nnz == 0
    Dc = D.tocoo()
    assert {(a, b) for a, b in zip(Dc.row, Dc.col) if a < b} == {tuple(sorted(p)) for p in t.face_adjacency}
    # Centroids: Bᵀ V / 3 = trimesh's triangle centres, and so is the centroid map.
    np.testing.assert_allclose(B.T @ V / 3, t.triangles_center, rtol=0, atol=1e-15)
    np.testing.assert_allclose(m["centroid"].T @ V, t.triangles_center, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m["edge_12"].T @ V, V[F[:, 1]] - V[F[:, 0]])
    np.testing.assert_array_equal(m["edge_13"].T @ V, V[F[:, 2]] - V[F[:, 0]])
    # Vertex -> corner map: row v lists the corners (flattened F positions) at v.
    VC = m["vertex_corners"]
    assert VC.shape == (n, F.size)
    rows, cols = VC.nonzero()
    np.testing.assert_array_equal(F.ravel()[cols], rows)


def test_action_maps_give_the_per_face_formulas(models):
    V, F = gregvox.load_mesh(models / "cow.obj")
    M = gregvox.mesh_matrices(V, F)["M"]
    e1 = gregvox.action_map(M, [-1, 1, 0]).T @ V
    e2 = gregvox.action_map(M, [-1, 0, 1]).T @ V
    np.testing.assert_array_equal(e1, V[F[:, 1]] - V[F[:, 0]])
    np.testing.assert_array_equal(e2, V[F[:, 2]] - V[F[:, 0]])
    t = as_trimesh(V, F)
    np.testing.assert_allclose(0.5 * np.linalg.norm(np.cross(e1, e2), axis=1), t.area_faces, atol=1e-15)
    # Plain product: one result per vertex, a sum over its faces (here the face counts).
    counts = gregvox.action_map(M, [1, 1, 1]) @ np.ones(len(F))
    np.testing.assert_array_equal(counts, np.bincount(F.ravel(), minlength=len(V)))
    with pytest.raises(ValueError):
        gregvox.action_map(M, [[1, 2], [3, 4]])
    with pytest.raises(ValueError):
        gregvox.action_map(M, [np.nan, 1, 0])


@pytest.mark.parametrize("name", ["stanford-bunny.obj", "spot.obj"])
def test_vertex_normals_equal_trimesh_and_the_area_weighted_sum(models, name):
    V, F = gregvox.load_mesh(models / name)
    t = as_trimesh(V, F)
    used = np.unique(F)
    angle = gregvox.vertex_normals(V, F, weighting="angle")
    np.testing.assert_allclose(angle[used], t.vertex_normals[used], atol=1e-12)
    area = gregvox.vertex_normals(V, F)
    cross = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    acc = np.zeros_like(V)
    for k in range(3):
        np.add.at(acc, F[:, k], cross)
    ref = acc[used] / np.linalg.norm(acc[used], axis=1, keepdims=True)
    np.testing.assert_allclose(area[used], ref, atol=1e-12)
    unused = np.setdiff1d(np.arange(len(V)), used)
    assert (area[unused] == 0).all() and np.isfinite(area).all()


def test_small_hand_made_meshes():
    V, F = tetrahedron()
    r = gregvox.topology(V, F)
    assert r["closed"] and r["euler_characteristic"] == 2 and r["genus"] == 0
    V, F = cube()
    r = gregvox.topology(V, F)
    assert (r["vertices"], r["faces"], r["edges"], r["closed"]) == (8, 12, 18, True)
    # Mixed polygons: one quad and one triangle.
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], float)
    F = [[0, 1, 2, 3], np.array([1, 4, 2])]
    r = gregvox.topology(V, F)
    assert r["face_order_histogram"] == {"3": 1, "4": 1} and r["boundary_edges"] == 5
    m = gregvox.mesh_matrices(V, F)
    assert m["M"].toarray().tolist() == [[1, 0], [2, 1], [3, 3], [4, 0], [0, 2]]
    np.testing.assert_allclose(m["centroid"].T @ V, [[0.5, 0.5, 0], [4 / 3, 1 / 3, 0]], atol=1e-15)
    assert m["dual_adjacency"].toarray().tolist() == [[0, 1], [1, 0]]
    assert m["adjacency"].nnz == 2 * 6
