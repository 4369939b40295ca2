//! Beziex patches (the "Beziex patch 2019" format of assets/models/beziex/SOURCES.md): loading
//! the gzip-JSON files and the f64 reference evaluator.
//!
//! A patch blends two polynomial surfaces sharing its four boundary cubics:
//! `S = (u(1−u)·Ra + v(1−v)·Rb) / (u(1−u) + v(1−v))`, Ra of bidegree (6, 3) (rows in v: the v = 0 cubic
//! elevated to degree 6, `bez00`, `bez01`, the v = 1 cubic elevated), Rb of bidegree (3, 6) (columns in u:
//! the u = 0 cubic elevated, `bez10`, `bez11`, the u = 1 cubic elevated); at the corners S = Ra.
//!
//! Invariants: a [`BeziexPatch`] stores both nets fully expanded (4 × 7 points each), the layout the GPU
//! reads (`to_gpu`: 56 vec4, Ra rows then Rb columns); every coordinate is finite (checked on load).
use crate::error::{Error, Result};
use glam::DVec3;
use std::io::Read;
use std::path::Path;

/// Threshold of the corner test (both blend weights vanish), as in the original shader.
pub const CORNER_EPS: f64 = 1e-6;

/// One Beziex patch with expanded nets.
#[derive(Clone, Debug, PartialEq)]
pub struct BeziexPatch {
    /// Ra rows j = 0..3 (v), each 7 points in u.
    pub ra: [[DVec3; 7]; 4],
    /// Rb columns i = 0..3 (u), each 7 points in v.
    pub rb: [[DVec3; 7]; 4],
    /// Drawn at half the tessellation level in the original viewer.
    pub pre_divided: bool,
}

/// Degree elevation of a cubic to degree 6 (three elevation steps).
///
/// ```
/// use gregvox::surface::beziex::elevate_cubic_to_sextic;
/// use glam::DVec3;
/// let c = [0.0, 1.0, 2.0, 3.0].map(|x| DVec3::new(x, 0.0, 0.0));
/// let e = elevate_cubic_to_sextic(&c);
/// // A straight, uniformly parametrized line stays uniform: x = 3i/6.
/// for (i, p) in e.iter().enumerate() { assert!((p.x - i as f64 * 0.5).abs() < 1e-15); }
/// ```
pub fn elevate_cubic_to_sextic(c: &[DVec3; 4]) -> [DVec3; 7] {
    let mut pts: Vec<DVec3> = c.to_vec();
    for _ in 0..3 {
        let n = pts.len(); // degree n − 1 → n
        let mut next = Vec::with_capacity(n + 1);
        next.push(pts[0]);
        for i in 1..n {
            let a = i as f64 / n as f64;
            next.push(pts[i - 1] * a + pts[i] * (1.0 - a));
        }
        next.push(pts[n - 1]);
        pts = next;
    }
    std::array::from_fn(|i| pts[i])
}

fn bernstein<const N: usize>(t: f64) -> ([f64; N], [f64; N]) {
    let n = N - 1;
    let mut b = [0.0; N];
    let mut d = [0.0; N];
    let binom =
        |k: usize| -> f64 { (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64) };
    for (k, (bk, dk)) in b.iter_mut().zip(d.iter_mut()).enumerate() {
        let c = binom(k);
        *bk = c * t.powi(k as i32) * (1.0 - t).powi((n - k) as i32);
        let left = if k > 0 {
            k as f64 * t.powi(k as i32 - 1) * (1.0 - t).powi((n - k) as i32)
        } else {
            0.0
        };
        let right = if k < n {
            (n - k) as f64 * t.powi(k as i32) * (1.0 - t).powi((n - k) as i32 - 1)
        } else {
            0.0
        };
        *dk = c * (left - right);
    }
    (b, d)
}

impl BeziexPatch {
    /// Builds a patch from the file's fields: 4 corners ((0,0), (1,0), (1,1), (0,1)) and the four 7-point rows.
    pub fn from_parts(
        corners: [DVec3; 4],
        bez00: [DVec3; 7],
        bez01: [DVec3; 7],
        bez10: [DVec3; 7],
        bez11: [DVec3; 7],
    ) -> Self {
        let [p00, p10, p11, p01] = corners;
        let v0 = elevate_cubic_to_sextic(&[p00, bez10[0], bez11[0], p10]);
        let v1 = elevate_cubic_to_sextic(&[p01, bez10[6], bez11[6], p11]);
        let u0 = elevate_cubic_to_sextic(&[p00, bez00[0], bez01[0], p01]);
        let u1 = elevate_cubic_to_sextic(&[p10, bez00[6], bez01[6], p11]);
        BeziexPatch {
            ra: [v0, bez00, bez01, v1],
            rb: [u0, bez10, bez11, u1],
            pre_divided: false,
        }
    }

    /// Position and first partials of Ra and Rb at (u, v).
    fn nets(&self, u: f64, v: f64) -> [[DVec3; 3]; 2] {
        let (b6u, d6u) = bernstein::<7>(u);
        let (b3v, d3v) = bernstein::<4>(v);
        let (b6v, d6v) = bernstein::<7>(v);
        let (b3u, d3u) = bernstein::<4>(u);
        let mut ra = [DVec3::ZERO; 3];
        let mut rb = [DVec3::ZERO; 3];
        for j in 0..4 {
            let (mut row, mut row_u) = (DVec3::ZERO, DVec3::ZERO);
            for k in 0..7 {
                row += self.ra[j][k] * b6u[k];
                row_u += self.ra[j][k] * d6u[k];
            }
            ra[0] += row * b3v[j];
            ra[1] += row_u * b3v[j];
            ra[2] += row * d3v[j];
        }
        for i in 0..4 {
            let (mut col, mut col_v) = (DVec3::ZERO, DVec3::ZERO);
            for k in 0..7 {
                col += self.rb[i][k] * b6v[k];
                col_v += self.rb[i][k] * d6v[k];
            }
            rb[0] += col * b3u[i];
            rb[1] += col * d3u[i];
            rb[2] += col_v * b3u[i];
        }
        [ra, rb]
    }

    /// Position and exact first partials (S, S_u, S_v) at (u, v) ∈ [0, 1]².
    ///
    /// ```
    /// use gregvox::surface::beziex::BeziexPatch;
    /// use glam::DVec3;
    /// // A flat patch z = 0 over the unit square: S(u, v) = (u, v, 0).
    /// let row = |y: f64| std::array::from_fn::<DVec3, 7, _>(|i| DVec3::new(i as f64 / 6.0, y, 0.0));
    /// let col = |x: f64| std::array::from_fn::<DVec3, 7, _>(|i| DVec3::new(x, i as f64 / 6.0, 0.0));
    /// let corners = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    /// let p = BeziexPatch::from_parts(corners, row(1.0 / 3.0), row(2.0 / 3.0), col(1.0 / 3.0), col(2.0 / 3.0));
    /// let (s, su, sv) = p.eval(0.25, 0.75);
    /// assert!((s - DVec3::new(0.25, 0.75, 0.0)).length() < 1e-14);
    /// assert!((su - DVec3::X).length() < 1e-13 && (sv - DVec3::Y).length() < 1e-13);
    /// ```
    pub fn eval(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        let [ra, rb] = self.nets(u, v);
        let near = |t: f64| !(CORNER_EPS..=1.0 - CORNER_EPS).contains(&t);
        if near(u) && near(v) {
            return (ra[0], ra[1], ra[2]);
        }
        let (pu, pv) = (u * (1.0 - u), v * (1.0 - v));
        let (dpu, dpv) = (1.0 - 2.0 * u, 1.0 - 2.0 * v);
        let d = pu + pv;
        let n = ra[0] * pu + rb[0] * pv;
        let nu = ra[0] * dpu + ra[1] * pu + rb[1] * pv;
        let nv = ra[2] * pu + rb[0] * dpv + rb[2] * pv;
        let inv = 1.0 / d;
        (
            n * inv,
            (nu * d - n * dpu) * (inv * inv),
            (nv * d - n * dpv) * (inv * inv),
        )
    }

    /// Unit normal as the original shader computes it: normalize(normalize(S_u) × normalize(S_v)).
    pub fn normal(&self, u: f64, v: f64) -> DVec3 {
        let (_, su, sv) = self.eval(u, v);
        su.normalize_or_zero()
            .cross(sv.normalize_or_zero())
            .normalize_or_zero()
    }

    /// The boundary cubic of edge e (0: v = 0, 1: u = 1, 2: v = 1, 3: u = 0), parameter increasing.
    pub fn boundary(&self, e: usize) -> [DVec3; 2] {
        match e {
            0 => [self.ra[0][0], self.ra[0][6]],
            1 => [self.rb[3][0], self.rb[3][6]],
            2 => [self.ra[3][0], self.ra[3][6]],
            _ => [self.rb[0][0], self.rb[0][6]],
        }
    }

    /// The 56 vec4 the GPU reads: Ra rows (4 × 7) then Rb columns (4 × 7).
    pub fn to_gpu(&self) -> [[f32; 4]; 56] {
        let mut out = [[0.0f32; 4]; 56];
        for (k, p) in self
            .ra
            .iter()
            .flatten()
            .chain(self.rb.iter().flatten())
            .enumerate()
        {
            out[k] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
        }
        out
    }
}

#[derive(serde::Deserialize)]
struct FileEdge {
    bez00: Vec<f64>,
    bez01: Vec<f64>,
    bez10: Vec<f64>,
    bez11: Vec<f64>,
}

#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct FilePatch {
    vertex: Vec<f64>,
    surface_edge: FileEdge,
    #[serde(default)]
    pre_divided: Option<serde_json::Value>,
}

#[derive(serde::Deserialize)]
struct FileModel {
    surface: Vec<FilePatch>,
}

/// Inflated bytes a `.gzjson` may reach: 64 × its compressed size, at least 64 MiB, at most 2 GiB. Real
/// models compress 3–10×; a deflate stream can reach about 1000× (a compression bomb).
pub fn inflate_limit(compressed: u64) -> u64 {
    compressed.saturating_mul(64).clamp(64 << 20, 2 << 30)
}

/// Counts the bytes read through it and fails once more than `limit` come (`hit` says why it failed).
struct Capped<'a, R> {
    inner: R,
    left: u64,
    hit: &'a std::cell::Cell<bool>,
}

impl<R: Read> Read for Capped<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // One byte past the limit is asked for, so reaching the limit exactly is not a failure.
        let want = buf
            .len()
            .min(self.left.saturating_add(1).min(usize::MAX as u64) as usize);
        let n = self.inner.read(&mut buf[..want])?;
        if n as u64 > self.left {
            self.hit.set(true);
            return Err(std::io::Error::other("inflate limit reached"));
        }
        self.left -= n as u64;
        Ok(n)
    }
}

/// Loads a `.gzjson` Beziex model (gzip-compressed JSON; plain JSON is accepted too).
///
/// Memory is bounded by the input: the JSON is parsed as it inflates (never held as text), and a stream
/// inflating past [`inflate_limit`] of its compressed size is refused as a likely compression bomb.
pub fn load_beziex(path: impl AsRef<Path>) -> Result<Vec<BeziexPatch>> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        let text = std::str::from_utf8(&bytes)
            .map_err(|_| Error::parse(path, "neither gzip nor UTF-8 JSON"))?;
        return parse_beziex(text, path);
    }
    let limit = inflate_limit(bytes.len() as u64);
    let hit = std::cell::Cell::new(false);
    let mut inflated = std::io::BufReader::with_capacity(
        1 << 16,
        Capped {
            inner: flate2::read::GzDecoder::new(&bytes[..]),
            left: limit,
            hit: &hit,
        },
    );
    // Windows tools write a UTF-8 byte-order mark; JSON parsers refuse it.
    let bom = {
        use std::io::BufRead;
        let head = inflated.fill_buf().unwrap_or(&[]);
        head.starts_with(b"\xef\xbb\xbf")
    };
    if bom {
        use std::io::BufRead;
        inflated.consume(3);
    }
    let model: std::result::Result<FileModel, _> = serde_json::from_reader(&mut inflated);
    let model = match model {
        Ok(m) => m,
        Err(_) if hit.get() => {
            return Err(Error::parse(
                path,
                format!(
                    "inflates past {limit} bytes ({}× its compressed size); refusing a likely compression bomb",
                    limit / (bytes.len() as u64).max(1)
                ),
            ))
        }
        Err(e) if e.classify() == serde_json::error::Category::Io => {
            return Err(Error::parse(
                path,
                format!("not a gzip stream of UTF-8 JSON: {e}"),
            ))
        }
        Err(e) => return Err(Error::parse(path, format!("not a Beziex model: {e}"))),
    };
    patches(model, path)
}

/// Parses Beziex JSON text; `path` names the source in errors.
pub fn parse_beziex(text: &str, path: &Path) -> Result<Vec<BeziexPatch>> {
    // Windows tools write a UTF-8 byte-order mark; JSON parsers refuse it.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let model: FileModel = serde_json::from_str(text)
        .map_err(|e| Error::parse(path, format!("not a Beziex model: {e}")))?;
    patches(model, path)
}

/// The patches of a parsed model, checked.
fn patches(model: FileModel, path: &Path) -> Result<Vec<BeziexPatch>> {
    if model.surface.is_empty() {
        return Err(Error::parse(path, "the model has no patches"));
    }
    let mut out = Vec::with_capacity(model.surface.len());
    for (k, p) in model.surface.iter().enumerate() {
        let bad = |m: &str| Error::parse(path, format!("patch {k}: {m}"));
        let pts = |v: &[f64], n: usize, what: &str| -> Result<Vec<DVec3>> {
            if v.len() != 3 * n {
                return Err(bad(&format!(
                    "{what} has {} numbers, expected {}",
                    v.len(),
                    3 * n
                )));
            }
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(bad(&format!("{what} has a non-finite coordinate ({x})")));
            }
            // The GPU evaluates in f32: a finite f64 past f32's range would become an infinity there.
            if let Some(x) = v.iter().find(|x| x.abs() > f32::MAX as f64) {
                return Err(bad(&format!(
                    "{what} has the coordinate {x:e}, past the f32 range (±3.4e38) the GPU evaluates in"
                )));
            }
            Ok(v.chunks(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect())
        };
        let c = pts(&p.vertex, 4, "vertex")?;
        let row = |v: &[f64], w: &str| -> Result<[DVec3; 7]> {
            let r = pts(v, 7, w)?;
            Ok(std::array::from_fn(|i| r[i]))
        };
        let e = &p.surface_edge;
        let mut patch = BeziexPatch::from_parts(
            [c[0], c[1], c[2], c[3]],
            row(&e.bez00, "bez00")?,
            row(&e.bez01, "bez01")?,
            row(&e.bez10, "bez10")?,
            row(&e.bez11, "bez11")?,
        );
        patch.pre_divided = matches!(&p.pre_divided, Some(serde_json::Value::String(s)) if s == "true")
            || matches!(&p.pre_divided, Some(serde_json::Value::Bool(true)));
        out.push(patch);
    }
    Ok(out)
}
