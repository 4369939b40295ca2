//! Point samplers for dataset recipes (Occupancy Networks, DeepSDF, IF-Net): uniform in a box, on the
//! surface (area-weighted, with the triangles' normals), and near the surface (surface samples moved by
//! Gaussian offsets of a given σ per axis). Seeded: the same seed gives the same points on every platform
//! ([`crate::geom::random::SplitMix64`]).
//!
//! Cost: the area table O(T), then O(log T) per surface sample (a binary search of the cumulative areas);
//! uniform samples O(1). Zero-area triangles are never drawn; a mesh of zero total area gives an error at
//! the caller (`api::query::sample`).
use crate::geom::random::SplitMix64;

/// `n` points uniform in the box [lo, hi].
pub fn uniform(lo: [f64; 3], hi: [f64; 3], n: usize, rng: &mut SplitMix64) -> Vec<[f64; 3]> {
    (0..n)
        .map(|_| std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * rng.unit()))
        .collect()
}

fn cross(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// The cumulative areas of `triangles` (the last entry is the total).
pub fn area_table(triangles: &[[[f64; 3]; 3]]) -> Vec<f64> {
    let mut total = 0.0;
    triangles
        .iter()
        .map(|t| {
            let n = cross(
                std::array::from_fn(|a| t[1][a] - t[0][a]),
                std::array::from_fn(|a| t[2][a] - t[0][a]),
            );
            total += 0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            total
        })
        .collect()
}

/// `n` points on the surface, area-weighted, with the unit normals of their triangles (right-hand rule).
/// `table` is [`area_table`] of `triangles`, with a positive total.
pub fn surface(
    triangles: &[[[f64; 3]; 3]],
    table: &[f64],
    n: usize,
    rng: &mut SplitMix64,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let total = *table.last().unwrap_or(&0.0);
    let mut points = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    for _ in 0..n {
        let target = rng.unit() * total;
        // The first triangle whose cumulative area exceeds the target (never a zero-area one).
        let i = table.partition_point(|&c| c <= target).min(table.len() - 1);
        let t = triangles[i];
        let (mut u, mut v) = (rng.unit(), rng.unit());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        points.push(std::array::from_fn(|a| {
            t[0][a] + u * (t[1][a] - t[0][a]) + v * (t[2][a] - t[0][a])
        }));
        let nrm = cross(
            std::array::from_fn(|a| t[1][a] - t[0][a]),
            std::array::from_fn(|a| t[2][a] - t[0][a]),
        );
        let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
        normals.push(nrm.map(|x| x / len));
    }
    (points, normals)
}

/// `n` points near the surface: area-weighted surface samples, each coordinate moved by a normal variate
/// of standard deviation `sigma`.
pub fn near(
    triangles: &[[[f64; 3]; 3]],
    table: &[f64],
    sigma: f64,
    n: usize,
    rng: &mut SplitMix64,
) -> Vec<[f64; 3]> {
    let (points, _) = surface(triangles, table, n, rng);
    points
        .into_iter()
        .map(|p| p.map(|x| x + sigma * rng.normal()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_follow_area_and_offsets_follow_sigma() {
        // Two triangles, areas 1 and 3: about a quarter of the samples on the first.
        let tris = [
            [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 5.0], [3.0, 0.0, 5.0], [0.0, 2.0, 5.0]],
        ];
        let table = area_table(&tris);
        assert_eq!(table, [1.0, 4.0]);
        let mut rng = SplitMix64(1);
        let (p, n) = surface(&tris, &table, 20_000, &mut rng);
        let first = p.iter().filter(|q| q[2] == 0.0).count() as f64 / 20_000.0;
        assert!((first - 0.25).abs() < 0.02, "{first}");
        assert!(n.iter().all(|m| m == &[0.0, 0.0, 1.0]));
        let near = near(&tris, &table, 0.01, 20_000, &mut SplitMix64(2));
        let dz: Vec<f64> = near
            .iter()
            .map(|q| if q[2] > 2.5 { q[2] - 5.0 } else { q[2] })
            .collect();
        let sd = (dz.iter().map(|x| x * x).sum::<f64>() / dz.len() as f64).sqrt();
        assert!((sd - 0.01).abs() < 0.0005, "{sd}");
        // Reproducible.
        assert_eq!(surface(&tris, &table, 5, &mut SplitMix64(1)).0, p[..5]);
    }
}
