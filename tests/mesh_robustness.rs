//! Random polygon soups (non-manifold edges, flipped faces, pinched vertices, unreferenced vertices) run
//! through every query and both subdivision schemes: nothing panics, every result is finite, every
//! subdivision row is affine, and the counting identities hold.
use glam::DVec3;
use gregvox::mesh::{
    catmull_clark_matrix, loop_matrix, rows_sum_to_one, LoopBeta, Mesh, MeshMatrix, NormalWeighting,
};

/// A tiny deterministic generator (64-bit LCG), so failures reproduce.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

fn random_mesh(rng: &mut Lcg, triangles_only: bool) -> Mesh {
    let nv = 4 + rng.below(9) as usize;
    let positions: Vec<DVec3> = (0..nv)
        .map(|_| {
            DVec3::new(
                rng.below(1000) as f64,
                rng.below(1000) as f64,
                rng.below(1000) as f64,
            ) / 100.0
        })
        .collect();
    let nf = 1 + rng.below(12) as usize;
    let mut faces = Vec::new();
    for _ in 0..nf {
        let k = if triangles_only {
            3
        } else {
            3 + rng.below(3) as usize
        }
        .min(nv);
        let mut f: Vec<u32> = Vec::new();
        while f.len() < k {
            let v = rng.below(nv as u64) as u32;
            if !f.contains(&v) {
                f.push(v);
            }
        }
        faces.push(f);
    }
    Mesh::from_polygons(positions, &faces).unwrap()
}

#[test]
fn random_soups_never_panic_and_stay_consistent() {
    let mut rng = Lcg(0x9e3779b97f4a7c15);
    for case in 0..400 {
        let tri = case % 2 == 0;
        let mesh = random_mesh(&mut rng, tri);
        let m = MeshMatrix::from_mesh(&mesh);
        let r = m.report();
        // every half-edge belongs to exactly one undirected edge; edge uses add up to nnz(M)
        let uses = m.edge_uses();
        assert_eq!(
            uses.iter().map(|u| u.faces() as usize).sum::<usize>(),
            m.n_corners(),
            "case {case}"
        );
        assert_eq!(r.edges, m.n_edges());
        assert_eq!(
            r.euler_characteristic,
            r.referenced_vertices as i64 - r.edges as i64 + r.faces as i64
        );
        let loops: usize = m.boundary_loops().iter().map(|l| l.len()).sum();
        assert_eq!(
            loops,
            m.boundary_half_edges().len(),
            "case {case}: loops cover boundary half-edges"
        );
        for v in 0..m.n_verts() {
            let ring = m.one_ring(v);
            assert!(ring
                .iter()
                .all(|&j| (j as usize) < m.n_verts() && j as usize != v));
            let corners = (m.vertex_corners().ptr[v + 1] - m.vertex_corners().ptr[v]) as usize;
            assert!(ring.len() <= corners + 1, "case {case} v {v}");
            if m.fans(v) == 1 && r.consistently_oriented {
                // on a manifold, oriented fan the walk lists every neighbour exactly once
                let mut sorted = ring.clone();
                sorted.sort_unstable();
                assert_eq!(sorted, m.neighbours(v), "case {case} v {v}");
            }
        }
        let sv = m.s_v();
        let sf = m.s_f();
        // trace(BBᵀ) = trace(BᵀB) = nnz(M); 1ᵀBBᵀ1 = Σ_f n_f²; 1ᵀBᵀB1 = Σ_v deg(v)²
        let trace = |s: &gregvox::mesh::SparseMatrix<u32>| {
            (0..s.n_rows as usize)
                .map(|i| s.get(i, i as u32).unwrap_or(0) as usize)
                .sum::<usize>()
        };
        assert_eq!((trace(&sv), trace(&sf)), (m.n_corners(), m.n_corners()));
        let total =
            |s: &gregvox::mesh::SparseMatrix<u32>| s.val.iter().map(|&x| x as usize).sum::<usize>();
        assert_eq!(
            total(&sv),
            (0..m.n_faces())
                .map(|f| (m.face_len(f) as usize).pow(2))
                .sum::<usize>()
        );
        let vc = m.vertex_corners();
        assert_eq!(
            total(&sf),
            (0..m.n_verts())
                .map(|v| ((vc.ptr[v + 1] - vc.ptr[v]) as usize).pow(2))
                .sum::<usize>()
        );
        let ad = m.dual_adjacency();
        for f in 0..m.n_faces() {
            for &g in ad.row(f).0 {
                assert!(ad.get(g as usize, f as u32).is_some(), "A_d symmetric");
                assert!(
                    sf.get(f, g).unwrap() >= 2,
                    "adjacent faces share ≥ 2 vertices"
                );
            }
        }
        for w in [
            NormalWeighting::Area,
            NormalWeighting::Uniform,
            NormalWeighting::Angle,
        ] {
            assert!(m
                .vertex_normals(&mesh.positions, w)
                .iter()
                .all(|n| n.is_finite()));
        }
        let cc = catmull_clark_matrix(&m);
        assert!(rows_sum_to_one(&cc.s, 1e-12), "case {case}");
        assert!(cc.s.spmv(&mesh.positions).iter().all(|p| p.is_finite()));
        assert_eq!(cc.topology.n_faces(), m.n_corners());
        if tri {
            let lp = loop_matrix(&m, LoopBeta::Loop).unwrap();
            assert!(rows_sum_to_one(&lp.s, 1e-12), "case {case}");
            assert_eq!(lp.topology.n_faces(), 4 * m.n_faces());
        }
        if m.n_edges() > 0 {
            let [a, b] = m.edge_vertices(rng.below(m.n_edges() as u64) as usize);
            let (c, map) = m.collapse_edge(a, b).unwrap();
            assert_eq!(map.len(), m.n_verts());
            assert!(c.n_faces() <= m.n_faces());
        }
    }
}
