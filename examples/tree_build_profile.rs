//! Times the fractional term's tree build on the unwelded noisy soup's ribbons (347k thin triangles): the
//! fixed cost that a soup adds to every resolution. `cargo run --release --example tree_build_profile`.
use gregvox::voxel::gwn::{tree::Tree, Proxy};
use gregvox::voxel::mesh::TriMesh;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let bunny = gregvox::api::load_mesh("assets/models/stanford-bunny.obj")?;
    let soup = gregvox::voxel::stress::soup(&TriMesh::fan(&bunny), 1e-7, 5);
    let frame = gregvox::voxel::grid::GridFrame::from_points(&soup.positions, 256)?;
    let tau = gregvox::voxel::gwn::weld_tolerance(&frame);
    let proxy = Proxy::new(&soup, tau)?;
    let x = proxy.fractional(&soup, frame.origin);
    let ribbons = &x[proxy.cap.triangles.len()..];
    let mut times = Vec::new();
    for _ in 0..7 {
        let t = Instant::now();
        let tree = Tree::build(ribbons);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(tree);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{} ribbons: tree build median {:.1} ms (min {:.1})",
        ribbons.len(),
        times[3],
        times[0]
    );
    Ok(())
}
