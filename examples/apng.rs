//! Joins PNG frames of one size (RGBA8, as gregvox writes them) into one animated PNG, each frame shown
//! `DELAY_MS`, looping: `scripts/readme_images.sh` makes the README's drag animation with it.
//!
//! ```text
//! cargo run --example apng -- OUT.png DELAY_MS FRAME.png...
//! ```
use anyhow::{bail, Context, Result};
use std::path::Path;

fn read(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut reader = png::Decoder::new(file)
        .read_info()
        .with_context(|| format!("{} is not a PNG", path.display()))?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf)?;
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        bail!("{}: RGBA8 frames only", path.display());
    }
    buf.truncate(info.buffer_size());
    Ok((info.width, info.height, buf))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        bail!("usage: apng OUT.png DELAY_MS FRAME.png...");
    }
    let delay: u16 = args[1]
        .parse()
        .context("DELAY_MS: a whole number of milliseconds")?;
    let frames = args[2..]
        .iter()
        .map(|p| read(Path::new(p)))
        .collect::<Result<Vec<_>>>()?;
    let (w, h) = (frames[0].0, frames[0].1);
    if let Some((i, _)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| (f.0, f.1) != (w, h))
    {
        bail!("{} is not {w}×{h}", args[2 + i]);
    }
    let out =
        std::fs::File::create(&args[0]).with_context(|| format!("cannot create {}", args[0]))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(out), w, h);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_animated(frames.len() as u32, 0)?;
    encoder.set_frame_delay(delay, 1000)?;
    let mut writer = encoder.write_header()?;
    for (_, _, px) in &frames {
        writer.write_image_data(px)?;
    }
    writer.finish()?;
    println!(
        "{}: {} frames of {w}×{h}, {delay} ms each",
        args[0],
        frames.len()
    );
    Ok(())
}
