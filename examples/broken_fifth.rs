//! Writes the folders of `gregvox bench --suite batch`'s table `batch_broken_fifth` (100 UV spheres; in
//! `broken/` every fifth has a quarter of its triangles removed or is an unwelded noisy soup), to time
//! or profile one model of them alone.
//!
//!     cargo run --release --example broken_fifth -- target/broken-fifth
use gregvox::bench::batch::sphere_folder;
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or_else(|| anyhow::anyhow!("usage: broken_fifth OUT_DIR"))?,
    );
    sphere_folder(&out.join("closed"), 100, false)?;
    let broken = sphere_folder(&out.join("broken"), 100, true)?;
    println!("{}: closed/ and broken/ ({broken} broken)", out.display());
    Ok(())
}
