//! `.vdb` output: read back by a reader written here from OpenVDB's layout (the Python suite reads the same
//! files with OpenVDB's own module): the active voxels are the grid's, full leaves and nodes become active
//! tiles, the transform puts VDB voxel centres on gregvox's, the offsets in the descriptor are right, and
//! the bytes are deterministic.
use gregvox::voxel::export::{write_grid, SaveOptions};
use gregvox::voxel::grid::{Axis, GridFrame, VoxelGrid};
use gregvox::voxel::vdb::vdb_bytes;
use std::collections::BTreeSet;

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        s
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        String::from_utf8(self.take(n).to_vec()).unwrap()
    }
    fn bits(&mut self, n: usize) -> Vec<usize> {
        let bytes = self.take(n / 8).to_vec();
        (0..n)
            .filter(|&i| bytes[i >> 3] >> (i & 7) & 1 == 1)
            .collect()
    }
}

/// What the file says: the active voxels, the map's name, its translation and scale.
struct Decoded {
    active: BTreeSet<[i32; 3]>,
    map: String,
    translation: [f64; 3],
    scale: [f64; 3],
    tiles: usize,
}

fn decode(bytes: &[u8]) -> Decoded {
    let mut r = Reader { b: bytes, at: 0 };
    assert_eq!(r.i64(), 0x5644_4220, "magic");
    assert_eq!(r.u32(), 224, "file version");
    r.take(8);
    assert_eq!(r.take(1), [1], "grid offsets");
    let uuid = std::str::from_utf8(r.take(36)).unwrap().to_string();
    assert_eq!(uuid.matches('-').count(), 4, "{uuid}");
    assert_eq!(r.u32(), 0, "file metadata");
    assert_eq!(r.i32(), 1, "grids");
    assert_eq!(r.string(), "solid");
    assert_eq!(r.string(), "Tree_bool_5_4_3");
    assert_eq!(r.string(), "");
    let (grid_pos, block_pos, end_pos) = (r.i64() as usize, r.i64() as usize, r.i64() as usize);
    assert_eq!(grid_pos, r.at, "grid offset");
    assert_eq!(end_pos, bytes.len(), "end offset");
    assert_eq!(r.u32(), 0, "compression");
    for _ in 0..r.u32() {
        r.string();
        r.string();
        let n = r.u32() as usize;
        r.take(n);
    }
    let map = r.string();
    let translation = [r.f64(), r.f64(), r.f64()];
    let scale = [r.f64(), r.f64(), r.f64()];
    r.take(4 * 24);
    assert_eq!(r.i32(), 1, "buffer count");
    assert_eq!(r.take(1), [0], "background");
    assert_eq!(r.u32(), 0, "root tiles");
    let children = r.u32();
    let mut active = BTreeSet::new();
    let mut tiles = 0;
    let mut leaves = Vec::new();
    let fill = |o: [i32; 3], size: i32, active: &mut BTreeSet<[i32; 3]>| {
        for x in 0..size {
            for y in 0..size {
                for z in 0..size {
                    active.insert([o[0] + x, o[1] + y, o[2] + z]);
                }
            }
        }
    };
    for _ in 0..children {
        let root = [r.i32(), r.i32(), r.i32()];
        let child5 = r.bits(32768);
        let tile5 = r.bits(32768);
        assert_eq!(r.take(1), [6]);
        let values5 = r.take(32768).to_vec();
        let at5 = |n: usize, shift: i32| [n >> 10, (n >> 5) & 31, n & 31].map(|c| c as i32 * shift);
        for &n in &tile5 {
            assert_eq!(values5[n], 1, "an active tile is true");
            let o = at5(n, 128);
            fill(
                [root[0] + o[0], root[1] + o[1], root[2] + o[2]],
                128,
                &mut active,
            );
            tiles += 1;
        }
        for &n in &child5 {
            let o = at5(n, 128);
            let base = [root[0] + o[0], root[1] + o[1], root[2] + o[2]];
            let child4 = r.bits(4096);
            let tile4 = r.bits(4096);
            assert_eq!(r.take(1), [6]);
            let values4 = r.take(4096).to_vec();
            let at4 = |m: usize| {
                let l = [m >> 8, (m >> 4) & 15, m & 15].map(|c| c as i32 * 8);
                [base[0] + l[0], base[1] + l[1], base[2] + l[2]]
            };
            for &m in &tile4 {
                assert_eq!(values4[m], 1);
                fill(at4(m), 8, &mut active);
                tiles += 1;
            }
            for &m in &child4 {
                let mask = r.bits(512);
                leaves.push((at4(m), mask));
            }
        }
    }
    assert_eq!(r.at, block_pos, "buffer offset");
    for (origin, mask) in leaves {
        assert_eq!(r.bits(512), mask, "the buffer's mask is the topology's");
        assert_eq!([r.i32(), r.i32(), r.i32()], origin, "leaf origin");
        assert_eq!(r.bits(512), mask, "active voxels are true");
        for n in mask {
            let l = [n >> 6, (n >> 3) & 7, n & 7].map(|c| c as i32);
            active.insert([origin[0] + l[0], origin[1] + l[1], origin[2] + l[2]]);
        }
    }
    assert_eq!(r.at, bytes.len(), "nothing after the last buffer");
    Decoded {
        active,
        map,
        translation,
        scale,
        tiles,
    }
}

fn solid_set(g: &VoxelGrid) -> BTreeSet<[i32; 3]> {
    let [x, y, z] = g.frame.dims;
    let mut s = BTreeSet::new();
    for i in 0..x {
        for j in 0..y {
            for k in 0..z {
                if g.get(i, j, k) {
                    s.insert([i as i32, j as i32, k as i32]);
                }
            }
        }
    }
    s
}

#[test]
fn noise_on_an_odd_anisotropic_grid_reads_back_voxel_for_voxel_with_its_placement() {
    let frame = GridFrame {
        dims: [70, 33, 139],
        origin: [-1.0, 2.0, 0.5],
        voxel_size: [0.5, 0.25, 0.125],
    };
    for axis in Axis::ALL {
        let mut g = VoxelGrid::empty(frame, axis);
        let mut s = 12345u64;
        for i in 0..70 {
            for j in 0..33 {
                for k in 0..139 {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    g.set(i, j, k, s >> 61 == 0);
                }
            }
        }
        let bytes = vdb_bytes(&g);
        let d = decode(&bytes);
        assert_eq!(d.active, solid_set(&g), "bits along {axis:?}");
        assert_eq!(d.map, "ScaleTranslateMap");
        assert_eq!(d.scale, frame.voxel_size);
        // VDB voxel (0, 0, 0) is centred on gregvox's.
        assert_eq!(d.translation, frame.centre(0, 0, 0));
        assert_eq!(
            bytes,
            vdb_bytes(&g.to_axis(Axis::Z)),
            "the same bytes whatever the bit axis"
        );
    }
}

#[test]
fn full_leaves_and_nodes_become_active_tiles_and_partial_ones_stay_leaves() {
    // 300 × 260 × 140 all solid: 128³ nodes inside become tiles of the root's child, 8³ leaves inside the
    // partial nodes become tiles, and the leaves cut by the grid's faces stay leaves.
    let frame = GridFrame::cubic(300, [0.0; 3], 3.0);
    let frame = GridFrame {
        dims: [300, 260, 140],
        ..frame
    };
    let mut g = VoxelGrid::empty(frame, Axis::Z);
    let w = frame.words_per_column(Axis::Z) as usize;
    for col in g.words.chunks_mut(w) {
        col.fill(!0);
        col[w - 1] &= (1u32 << (140 % 32)) - 1;
    }
    let bytes = vdb_bytes(&g);
    let d = decode(&bytes);
    assert_eq!(d.active.len() as u64, g.count());
    assert_eq!(d.active, solid_set(&g));
    assert_eq!(d.map, "UniformScaleTranslateMap");
    assert!(d.tiles > 4, "{} tiles", d.tiles);
    // Tiles keep the file small: far below the 204 bytes per leaf of 66,000 leaves.
    assert!(bytes.len() < 2_000_000, "{} bytes", bytes.len());
}

#[test]
fn an_empty_grid_is_a_valid_file_with_no_voxel_and_a_write_is_atomic() {
    let g = VoxelGrid::empty(GridFrame::cubic(16, [0.0; 3], 1.0), Axis::X);
    let d = decode(&vdb_bytes(&g));
    assert!(d.active.is_empty());
    let dir = std::env::temp_dir().join(format!("gregvox-vdb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("e.vdb");
    write_grid(&g, &path, &SaveOptions::default()).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), vdb_bytes(&g));
    // No sidecar: the transform is in the file.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}
