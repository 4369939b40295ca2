//! Specification of the exporters by round trip: `.vox` read back by the independent `dot_vox` crate
//! (single model at R = 256, a 2×2×2 scene graph at R = 300), NRRD and NPY parsed here from their published
//! layouts (headers checked line by line), all compared voxel by voxel with the source grid.
use gregvox::voxel::export::{
    binvox_bytes, npy_bytes, npy_packed_bytes, nrrd_bytes, vox_bytes, write_grid, SaveOptions,
    VOX_MODEL_MAX,
};
use gregvox::voxel::grid::{Axis, GridFrame, VoxelGrid};
use std::collections::HashSet;

/// A deterministic pattern with structure at every scale: a solid ball, a hollow in it, and hashed noise
/// (about 1 voxel in 7) so a swapped axis or an off-by-one in any chunk changes the set.
fn pattern(res: u32) -> VoxelGrid {
    pattern_in(GridFrame::cubic(res, [-1.5, 0.25, 2.0], 3.0))
}

/// The same pattern in any frame (non-cubic, anisotropic).
fn pattern_in(frame: GridFrame) -> VoxelGrid {
    let mut g = VoxelGrid::empty(frame, Axis::Y);
    let c = frame.dims[0] as f64 / 2.0;
    let [nx, ny, nz] = frame.dims;
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let d2 = (i as f64 - c * 0.8).powi(2)
                    + (j as f64 - c).powi(2)
                    + (k as f64 - c * 1.1).powi(2);
                let h = (i.wrapping_mul(73_856_093)
                    ^ j.wrapping_mul(19_349_663)
                    ^ k.wrapping_mul(83_492_791))
                    % 7;
                let ball = d2 < (0.6 * c).powi(2) && d2 > (0.2 * c).powi(2);
                if ball || h == 0 {
                    g.set(i, j, k, true);
                }
            }
        }
    }
    g
}

fn set_of(g: &VoxelGrid) -> HashSet<[u32; 3]> {
    let [nx, ny, nz] = g.frame.dims;
    let mut s = HashSet::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                if g.get(i, j, k) {
                    s.insert([i, j, k]);
                }
            }
        }
    }
    s
}

/// Grid voxels of a `.vox` file read by `dot_vox`, placed through its scene graph (world = grid − ⌊R/2⌋;
/// a model of size s at `_t` = t starts at t − ⌊s/2⌋).
fn vox_voxels(bytes: &[u8], res: u32) -> (HashSet<[u32; 3]>, usize) {
    let data = dot_vox::load_bytes(bytes).expect("dot_vox reads our .vox");
    let half = (res / 2) as i64;
    let mut out = HashSet::new();
    let mut placed = 0;
    for node in &data.scenes {
        let dot_vox::SceneNode::Transform { frames, child, .. } = node else {
            continue;
        };
        let dot_vox::SceneNode::Shape { models, .. } = &data.scenes[*child as usize] else {
            continue;
        };
        let t = frames[0].position().expect("every model's nTRN has a _t");
        for m in models {
            let model = &data.models[m.model_id as usize];
            let size = [model.size.x, model.size.y, model.size.z];
            assert!(
                size.iter().all(|&s| s <= VOX_MODEL_MAX),
                "model size {size:?}"
            );
            let lo = [t.x as i64, t.y as i64, t.z as i64]
                .iter()
                .zip(size)
                .map(|(t, s)| t - (s / 2) as i64 + half)
                .collect::<Vec<_>>();
            placed += 1;
            for v in &model.voxels {
                let p = [lo[0] + v.x as i64, lo[1] + v.y as i64, lo[2] + v.z as i64];
                assert!(p.iter().all(|&c| (0..res as i64).contains(&c)), "{p:?}");
                assert!(out.insert(p.map(|c| c as u32)), "voxel {p:?} twice");
            }
        }
    }
    (out, placed)
}

#[test]
fn vox_round_trips_through_dot_vox_at_256_in_one_model() {
    let g = pattern(256);
    let (read, models) = vox_voxels(&vox_bytes(&g), 256);
    let truth = set_of(&g);
    eprintln!(".vox 256³: {} voxels, {models} model(s)", truth.len());
    assert_eq!(models, 1, "256 per axis fits one model");
    assert!(
        read == truth,
        "{} read vs {} written",
        read.len(),
        truth.len()
    );
}

#[test]
fn vox_round_trips_through_dot_vox_at_300_in_eight_models() {
    let g = pattern(300);
    let (read, models) = vox_voxels(&vox_bytes(&g), 300);
    let truth = set_of(&g);
    eprintln!(".vox 300³: {} voxels, {models} models", truth.len());
    assert_eq!(models, 8, "300 = 256 + 44 per axis: 2×2×2 models");
    assert!(
        read == truth,
        "{} read vs {} written",
        read.len(),
        truth.len()
    );
}

#[test]
fn vox_of_an_empty_grid_is_a_valid_file_with_no_voxel() {
    let g = VoxelGrid::empty(GridFrame::cubic(300, [0.0; 3], 1.0), Axis::Z);
    let (read, models) = vox_voxels(&vox_bytes(&g), 300);
    assert_eq!((read.len(), models), (0, 1));
}

#[test]
fn nrrd_round_trips_with_x_fastest_and_the_grid_in_the_header() {
    let g = pattern(37); // not a multiple of 32: partial words
    let b = nrrd_bytes(&g);
    let split = b.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let header = std::str::from_utf8(&b[..split]).unwrap();
    let p = 3.0 / 37.0;
    let lines: Vec<&str> = header.lines().collect();
    assert_eq!(
        &lines[..6],
        [
            "NRRD0004",
            "type: uint8",
            "dimension: 3",
            "sizes: 37 37 37",
            "encoding: raw",
            "space dimension: 3"
        ]
    );
    assert_eq!(
        lines[6],
        format!("space directions: ({p},0,0) (0,{p},0) (0,0,{p})")
    );
    // NRRD places samples at nodes: the origin is voxel (0,0,0)'s centre.
    assert_eq!(
        lines[7],
        format!(
            "space origin: ({},{},{})",
            -1.5 + 0.5 * p,
            0.25 + 0.5 * p,
            2.0 + 0.5 * p
        )
    );
    let data = &b[split..];
    assert_eq!(data.len(), 37 * 37 * 37);
    assert!(data.iter().all(|&v| v <= 1));
    for (n, &v) in data.iter().enumerate() {
        let (x, y, z) = (n % 37, n / 37 % 37, n / (37 * 37));
        assert_eq!(v == 1, g.get(x as u32, y as u32, z as u32), "({x},{y},{z})");
    }
}

#[test]
fn npy_packed_round_trips_as_packed_z_bits_with_a_64_byte_aligned_header() {
    let g = pattern(37);
    let b = npy_packed_bytes(&g);
    assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert_eq!(
        (10 + hlen) % 64,
        0,
        "NPY pads the header to a multiple of 64"
    );
    let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
    assert!(header.ends_with('\n'));
    assert_eq!(
        header.trim_end(),
        "{'descr': '|u1', 'fortran_order': False, 'shape': (37, 37, 5), }"
    );
    let data = &b[10 + hlen..];
    assert_eq!(data.len(), 37 * 37 * 5);
    for x in 0..37usize {
        for y in 0..37usize {
            for z in 0..40usize {
                let bit = data[(x * 37 + y) * 5 + z / 8] >> (z % 8) & 1 == 1;
                // np.unpackbits(bitorder='little'): bit z of the row; bits past R are zero.
                assert_eq!(
                    bit,
                    z < 37 && g.get(x as u32, y as u32, z as u32),
                    "({x},{y},{z})"
                );
            }
        }
    }
}

#[test]
fn write_grid_writes_vox_with_a_sidecar_and_rejects_unknown_extensions() {
    let dir = std::env::temp_dir().join(format!("gregvox-vox-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let g = pattern(20);
    let path = dir.join("p.vox");
    write_grid(&g, &path, &SaveOptions::default()).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), vox_bytes(&g));
    let side: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("p.vox.json")).unwrap()).unwrap();
    assert_eq!(side["dims"], serde_json::json!([20, 20, 20]));
    assert_eq!(side["voxel_size"], serde_json::json!([0.15, 0.15, 0.15]));
    let err = write_grid(&g, &dir.join("p.fbx"), &SaveOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown voxel format '.fbx'"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vox_refuses_grids_past_its_4_gib_chunk_limit_with_one_clear_error() {
    // 1024³ all solid: 2^30 voxels × 4 bytes = 4 GiB > u32::MAX; refused before anything is built.
    let mut g = VoxelGrid::empty(GridFrame::cubic(1024, [0.0; 3], 1.0), Axis::Z);
    g.words.fill(u32::MAX);
    let path = std::env::temp_dir().join(format!("gregvox-big-{}.vox", std::process::id()));
    let err = write_grid(&g, &path, &SaveOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("1073741824 solid voxels do not fit a .vox file"),
        "{err}"
    );
    assert!(!path.exists());
}

/// A non-cubic grid of anisotropic voxels: dims with partial words on every axis, sizes unlike each other.
fn odd_frame() -> GridFrame {
    GridFrame {
        dims: [13, 7, 37],
        origin: [-1.5, 0.25, 2.0],
        voxel_size: [0.5, 0.125, 0.0625],
    }
}

#[test]
fn npy_is_a_plain_bool_array_indexed_x_y_z_on_a_non_cubic_grid() {
    let g = pattern_in(odd_frame());
    let b = npy_bytes(&g);
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert_eq!((10 + hlen) % 64, 0);
    let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
    assert_eq!(
        header.trim_end(),
        "{'descr': '|b1', 'fortran_order': False, 'shape': (13, 7, 37), }"
    );
    let data = &b[10 + hlen..];
    assert_eq!(data.len(), 13 * 7 * 37);
    for (n, &v) in data.iter().enumerate() {
        // C order: the last index (z) runs fastest.
        let (x, y, z) = (n / (7 * 37), n / 37 % 7, n % 37);
        assert!(v <= 1);
        assert_eq!(v == 1, g.get(x as u32, y as u32, z as u32), "({x},{y},{z})");
    }
}

#[test]
fn nrrd_of_a_non_cubic_grid_gives_each_axis_its_size_and_spacing() {
    let g = pattern_in(odd_frame());
    let b = nrrd_bytes(&g);
    let split = b.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let header = std::str::from_utf8(&b[..split]).unwrap();
    assert!(header.contains("sizes: 13 7 37\n"), "{header}");
    assert!(header.contains("space directions: (0.5,0,0) (0,0.125,0) (0,0,0.0625)\n"));
    assert!(
        header.contains("space origin: (-1.25,0.3125,2.03125)\n"),
        "{header}"
    );
    let data = &b[split..];
    assert_eq!(data.len(), 13 * 7 * 37);
    for (n, &v) in data.iter().enumerate() {
        let (x, y, z) = (n % 13, n / 13 % 7, n / (13 * 7));
        assert_eq!(v == 1, g.get(x as u32, y as u32, z as u32), "({x},{y},{z})");
    }
}

#[test]
fn every_sidecar_places_the_grid_so_index_to_world_gives_each_voxel_centre() {
    let dir = std::env::temp_dir().join(format!("gregvox-sidecar-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let g = pattern_in(odd_frame());
    for ext in ["npy", "raw", "vox"] {
        let path = dir.join(format!("g.{ext}"));
        write_grid(&g, &path, &SaveOptions::default()).unwrap();
        let side: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(format!("g.{ext}.json"))).unwrap())
                .unwrap();
        assert_eq!(side["dims"], serde_json::json!([13, 7, 37]), "{ext}");
        assert_eq!(side["voxel_size"], serde_json::json!([0.5, 0.125, 0.0625]));
        assert_eq!(side["origin"], serde_json::json!([-1.5, 0.25, 2.0]));
        let m: Vec<Vec<f64>> = serde_json::from_value(side["index_to_world"].clone()).unwrap();
        for (i, j, k) in [(0, 0, 0), (12, 6, 36), (5, 3, 20)] {
            let c = g.frame.centre(i, j, k);
            for a in 0..3 {
                let w = m[a][0] * i as f64 + m[a][1] * j as f64 + m[a][2] * k as f64 + m[a][3];
                assert!(
                    (w - c[a]).abs() <= 1e-6 * g.frame.voxel_size[a],
                    "{ext} {a}"
                );
            }
            assert_eq!(m[3], [0.0, 0.0, 0.0, 1.0]);
        }
    }
    // The raw words: ((y·X + x)·ceil(Z/32) + z/32), bit z%32.
    let raw = std::fs::read(dir.join("g.raw")).unwrap();
    let words: Vec<u32> = raw
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    assert_eq!(words.len(), 13 * 7 * 2);
    for x in 0..13 {
        for y in 0..7 {
            for z in 0..37 {
                let w = words[(y * 13 + x) * 2 + z / 32];
                assert_eq!(w >> (z % 32) & 1 == 1, g.get(x as u32, y as u32, z as u32));
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn binvox_refuses_non_cubic_grids_before_writing_anything() {
    let dir = std::env::temp_dir().join(format!("gregvox-binvox-odd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("g.binvox");
    // Anisotropic voxels, and cubic voxels in a non-cubic grid: binvox has one scale and readers disagree
    // on the axis order of unequal dims.
    let cubic_voxels = GridFrame {
        dims: [8, 4, 2],
        origin: [0.0; 3],
        voxel_size: [0.25; 3],
    };
    for frame in [odd_frame(), cubic_voxels] {
        let err = write_grid(&pattern_in(frame), &path, &SaveOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("binvox holds only cubic grids of cubic voxels"),
            "{err}"
        );
        assert!(err.contains("g.binvox"), "{err}");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            0,
            "nothing written"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vox_of_a_non_cubic_grid_past_256_splits_each_axis_into_models() {
    let frame = GridFrame {
        dims: [300, 20, 260],
        origin: [0.0; 3],
        voxel_size: [1.0, 2.0, 0.5],
    };
    let g = pattern_in(frame);
    let data = dot_vox::load_bytes(&vox_bytes(&g)).unwrap();
    // 2 × 1 × 2 chunks, every one holding voxels of the pattern's noise.
    assert_eq!(data.models.len(), 4);
    for m in &data.models {
        assert!(
            m.size.x <= VOX_MODEL_MAX && m.size.y <= VOX_MODEL_MAX && m.size.z <= VOX_MODEL_MAX
        );
    }
    let total: usize = data.models.iter().map(|m| m.voxels.len()).sum();
    assert_eq!(total as u64, g.count());
}

/// binvox data encoded voxel by voxel, straight from the format's description: x slowest, then z, y
/// fastest; (value, count) pairs, counts 1..=255.
fn binvox_reference(g: &VoxelGrid) -> Vec<u8> {
    let [nx, ny, nz] = g.frame.dims;
    let mut out = Vec::new();
    let (mut value, mut count) = (0u8, 0u32);
    for x in 0..nx {
        for z in 0..nz {
            for y in 0..ny {
                let bit = g.get(x, y, z) as u8;
                if bit == value && count < 255 {
                    count += 1;
                } else {
                    if count > 0 {
                        out.extend_from_slice(&[value, count as u8]);
                    }
                    (value, count) = (bit, 1);
                }
            }
        }
    }
    if count > 0 {
        out.extend_from_slice(&[value, count as u8]);
    }
    out
}

#[test]
fn binvox_run_lengths_by_words_equal_the_voxel_by_voxel_encoding() {
    let mut full = VoxelGrid::empty(GridFrame::cubic(96, [0.0; 3], 1.0), Axis::Z); // whole words: no bit past the grid
    full.words.fill(u32::MAX);
    // Bits past the grid's end in the last word of each column must not count.
    let mut solid_block = VoxelGrid::empty(GridFrame::cubic(45, [0.0; 3], 1.0), Axis::X);
    for i in 3..40 {
        for j in 0..45 {
            for k in 10..33 {
                solid_block.set(i, j, k, true);
            }
        }
    }
    for (name, g) in [
        ("pattern 37", pattern(37)),
        ("pattern 64", pattern(64)),
        (
            "empty 33",
            VoxelGrid::empty(GridFrame::cubic(33, [0.0; 3], 1.0), Axis::Y),
        ),
        ("full 96", full.clone()),
        ("block 45", solid_block),
    ] {
        let b = gregvox::voxel::export::binvox_bytes(&g);
        let data = &b[b.windows(5).position(|w| w == b"data\n").unwrap() + 5..];
        assert!(data == binvox_reference(&g).as_slice(), "{name}");
    }
}

#[test]
fn write_dense_xyz_is_get_at_every_voxel_whatever_the_bit_axis() {
    // Odd sizes (one partial word per column along every axis, 37 > 32 along z) and all three bit axes:
    // the dense bytes, x slowest and z fastest, must be exactly `get` voxel by voxel.
    let frame = GridFrame {
        dims: [45, 7, 37],
        ..odd_frame()
    };
    let source = pattern_in(frame);
    let [nx, ny, nz] = frame.dims;
    for axis in Axis::ALL {
        let g = source.to_axis(axis);
        let mut dense = vec![7u8; frame.voxel_count() as usize];
        g.write_dense_xyz(&mut dense);
        let mut at = 0;
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    assert_eq!(
                        dense[at],
                        g.get(i, j, k) as u8,
                        "bits along {axis:?}: voxel ({i}, {j}, {k})"
                    );
                    at += 1;
                }
            }
        }
        assert!(dense.contains(&1) && dense.contains(&0));
    }
}

#[test]
fn changing_the_bit_axis_keeps_every_voxel_between_every_pair_of_axes() {
    // Dims that are and are not multiples of 32, on every axis, so partial words and partial bands of 32
    // rows appear on each side of the 32 × 32 block transposes.
    for dims in [[13, 7, 37], [64, 33, 32], [31, 65, 96], [1, 40, 1]] {
        let frame = GridFrame {
            dims,
            origin: [0.0; 3],
            voxel_size: [1.0; 3],
        };
        let g = pattern_in(frame);
        let want = set_of(&g);
        for from in Axis::ALL {
            let a = g.to_axis(from);
            for to in Axis::ALL {
                let b = a.to_axis(to);
                assert_eq!(b.bit_axis, to);
                assert_eq!(set_of(&b), want, "{dims:?} {from:?} → {to:?}");
                // No stray bits past the column ends: the words equal those of a grid set voxel by voxel.
                let mut direct = VoxelGrid::empty(frame, to);
                for &[i, j, k] in &want {
                    direct.set(i, j, k, true);
                }
                assert_eq!(b.words, direct.words, "{dims:?} {from:?} → {to:?}");
            }
        }
    }
}

#[test]
fn the_word_encoders_write_the_bytes_of_the_per_voxel_definitions() {
    // binvox (cubic only) at sizes with partial words, runs longer than 255 and runs crossing columns and
    // x slabs; npy and nrrd on non-cubic grids with partial words on every axis.
    for res in [1u32, 31, 33, 64, 100] {
        let mut g = pattern(res);
        // A long solid stretch crossing many columns: runs past 255 that span slabs.
        for x in res / 3..res / 2 {
            for z in 0..res {
                for y in 0..res {
                    g.set(x, y, z, true);
                }
            }
        }
        let b = binvox_bytes(&g);
        let data = &b[b.windows(5).position(|w| w == b"data\n").unwrap() + 5..];
        assert_eq!(data, binvox_reference(&g).as_slice(), "binvox {res}³");
    }
    for dims in [[13, 7, 37], [64, 33, 32], [31, 65, 96], [1, 1, 1]] {
        let g = pattern_in(GridFrame {
            dims,
            origin: [0.0; 3],
            voxel_size: [1.0; 3],
        });
        let [nx, ny, nz] = dims;
        let npy = npy_bytes(&g);
        let head = npy.len() - (nx * ny * nz) as usize;
        let mut want = Vec::new();
        for x in 0..nx {
            for y in 0..ny {
                for z in 0..nz {
                    want.push(g.get(x, y, z) as u8);
                }
            }
        }
        assert_eq!(&npy[head..], want.as_slice(), "npy {dims:?}");
        let nrrd = nrrd_bytes(&g);
        let head = nrrd.len() - (nx * ny * nz) as usize;
        let mut want = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    want.push(g.get(x, y, z) as u8);
                }
            }
        }
        assert_eq!(&nrrd[head..], want.as_slice(), "nrrd {dims:?}");
    }
}

/// The stored entries of a zip archive (what `.npz` writers produce): (name, bytes).
fn zip_entries(z: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut at = 0;
    while z[at..].starts_with(&0x0403_4b50u32.to_le_bytes()) {
        let u16_at = |o: usize| u16::from_le_bytes([z[at + o], z[at + o + 1]]) as usize;
        let u32_at =
            |o: usize| u32::from_le_bytes(z[at + o..at + o + 4].try_into().unwrap()) as usize;
        assert_eq!(u16_at(8), 0, "stored");
        let (size, name_len, extra) = (u32_at(18), u16_at(26), u16_at(28));
        let name = String::from_utf8(z[at + 30..at + 30 + name_len].to_vec()).unwrap();
        let start = at + 30 + name_len + extra;
        out.push((name, z[start..start + size].to_vec()));
        at = start + size;
    }
    out
}

/// The data of a version-1 `.npy` after its header, and the header text.
fn npy_data(b: &[u8]) -> (String, &[u8]) {
    let len = u16::from_le_bytes([b[8], b[9]]) as usize;
    (
        String::from_utf8(b[10..10 + len].to_vec()).unwrap(),
        &b[10 + len..],
    )
}

#[test]
fn sparse_npz_lists_the_dense_grids_nonzeros_and_ply_their_centres() {
    let frame = odd_frame();
    let g = pattern_in(frame);
    let dir = std::env::temp_dir().join(format!("gregvox-sparse-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let npz = dir.join("g.npz");
    write_grid(&g, &npz, &SaveOptions::default()).unwrap();
    let entries = zip_entries(&std::fs::read(&npz).unwrap());
    let names: Vec<&str> = entries.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(
        names,
        ["coords.npy", "origin.npy", "voxel_size.npy", "dims.npy"]
    );
    let (head, data) = npy_data(&entries[0].1);
    assert!(
        head.contains("'<i4'") && head.contains(&format!("({}, 3)", g.count())),
        "{head}"
    );
    let coords: Vec<[u32; 3]> = data
        .chunks(12)
        .map(|c| {
            std::array::from_fn(|a| {
                i32::from_le_bytes(c[4 * a..4 * a + 4].try_into().unwrap()) as u32
            })
        })
        .collect();
    // The dense grid's nonzeros in C order (x slowest): np.argwhere(dense).
    let [nx, ny, nz] = frame.dims;
    let mut want = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                if g.get(i, j, k) {
                    want.push([i, j, k]);
                }
            }
        }
    }
    assert_eq!(coords, want);
    let f64s = |b: &[u8]| -> Vec<f64> {
        npy_data(b)
            .1
            .chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    assert_eq!(f64s(&entries[1].1), frame.origin);
    assert_eq!(f64s(&entries[2].1), frame.voxel_size);
    let dims: Vec<i32> = npy_data(&entries[3].1)
        .1
        .chunks(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(dims, frame.dims.map(|d| d as i32));
    // PLY: the same voxels' centres, as float32.
    let ply = dir.join("g.ply");
    write_grid(&g, &ply, &SaveOptions::default()).unwrap();
    let b = std::fs::read(&ply).unwrap();
    let end = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let head = String::from_utf8(b[..end].to_vec()).unwrap();
    assert!(
        head.contains(&format!("element vertex {}\n", want.len())),
        "{head}"
    );
    let xyz: Vec<f32> = b[end..]
        .chunks(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(xyz.len(), 3 * want.len());
    for (p, c) in xyz.chunks(3).zip(&want) {
        let centre = frame.centre(c[0], c[1], c[2]);
        assert_eq!(p, centre.map(|x| x as f32));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
