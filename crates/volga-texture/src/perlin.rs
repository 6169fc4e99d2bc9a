//! Improved Perlin gradient noise (Perlin 2002, survey §17.6) with the values of the
//! `noise` crate 0.9's `Perlin` (same permutation table per seed, same twelve edge
//! gradients, same quintic fade, same `2/√3` scale and clamp), evaluated faster:
//!
//! * one point: [`Perlin::value`] (what lazy fields call);
//! * a row of points along x: [`Perlin::row`]. Along a row the corner gradients of a cell
//!   are shared by every sample inside it, and after the y and z interpolations (whose
//!   weights are constant along the row) each x face of the cell is an affine function of
//!   the x fraction; a sample then costs the x fade, two affine terms and one
//!   interpolation. Values differ from the point form only by rounding (≤ 1e-15).

use glam::DVec3;
use rand::{seq::SliceRandom, SeedableRng};
use rand_xorshift::XorShiftRng;

/// `2/√3`: the `noise` crate's scale of 3D Perlin noise into \[-1, 1\].
const SCALE: f64 = 1.154_700_538_379_251_5;

/// 3D Perlin noise for one seed: values in \[-1, 1\], 0 at integer lattice points.
#[derive(Clone)]
pub struct Perlin {
    seed: u32,
    perm: [u8; 256],
}

impl std::fmt::Debug for Perlin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Perlin").field("seed", &self.seed).finish()
    }
}

/// The gradient dot product of the `noise` crate for hash `h` and offset `(x, y, z)`
/// (twelve edge directions, four of them repeated to fill 16 slots), as
/// `(gx, gy, gz)` coefficients.
#[inline(always)]
fn gradient(h: u8) -> (f64, f64, f64) {
    const G: [(f64, f64, f64); 16] = [
        (1.0, 1.0, 0.0),
        (-1.0, 1.0, 0.0),
        (1.0, -1.0, 0.0),
        (-1.0, -1.0, 0.0),
        (1.0, 0.0, 1.0),
        (-1.0, 0.0, 1.0),
        (1.0, 0.0, -1.0),
        (-1.0, 0.0, -1.0),
        (0.0, 1.0, 1.0),
        (0.0, -1.0, 1.0),
        (0.0, 1.0, -1.0),
        (0.0, -1.0, -1.0),
        (1.0, 1.0, 0.0),
        (-1.0, 1.0, 0.0),
        (0.0, -1.0, 1.0),
        (0.0, -1.0, -1.0),
    ];
    G[(h & 15) as usize]
}

/// The `noise` crate's cell corner: `trunc(x)`, minus one when `x ≤ 0` (so the
/// fraction lies in `(0, 1]`; at `x = 0` exactly the corner is −1). Coordinates beyond
/// ±2⁶² saturate instead of panicking.
#[inline(always)]
fn corner(x: f64) -> i64 {
    let t = x as i64;
    if x <= 0.0 {
        t.wrapping_sub(1)
    } else {
        t
    }
}

/// The quintic fade `6t⁵ − 15t⁴ + 10t³` on `t` clamped to \[0, 1\].
/// `floor(x)` as a cell index, saturating beyond ±2³¹.
#[inline(always)]
pub(crate) fn corner_floor(x: f64) -> i32 {
    x.floor() as i32
}

/// Perlin's quintic fade `6t⁵ − 15t⁴ + 10t³` of `t` clamped to \[0, 1\].
#[inline(always)]
pub fn fade(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline(always)]
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    b * t + a * (1.0 - t)
}

/// The corner hashes of one row's cells, kept between rows ([`Perlin::add_row_cached`]).
#[derive(Debug, Default, Clone)]
pub struct RowHashes {
    key: Option<(i64, i64, i64, i64)>,
    hashes: Vec<[u8; 4]>,
}

impl Perlin {
    /// The noise of `seed`: the permutation table is the `noise` crate's (a
    /// `XorShiftRng` seeded with `[1, 0, 0, 0, seed × 3 (little endian)]` shuffling 0..=255).
    pub fn new(seed: u32) -> Self {
        let mut real = [0u8; 16];
        real[0] = 1;
        for i in 1..4 {
            real[i * 4..i * 4 + 4].copy_from_slice(&seed.to_le_bytes());
        }
        let mut rng = XorShiftRng::from_seed(real);
        let mut perm = [0u8; 256];
        for (i, p) in perm.iter_mut().enumerate() {
            *p = i as u8;
        }
        perm.shuffle(&mut rng);
        Perlin { seed, perm }
    }

    /// The seed the permutation table was drawn with.
    pub fn seed(&self) -> u32 {
        self.seed
    }

    /// `P[P[P[x] ^ y] ^ z]` on the low 8 bits of each corner coordinate.
    #[inline(always)]
    fn hash(&self, x: i64, y: i64, z: i64) -> u8 {
        let p = &self.perm;
        let a = p[(x & 255) as usize] as usize ^ (y & 255) as usize;
        let b = p[a] as usize ^ (z & 255) as usize;
        p[b]
    }

    /// The noise at a point (unit lattice).
    pub fn value(&self, p: DVec3) -> f64 {
        let (cx, cy, cz) = (corner(p.x), corner(p.y), corner(p.z));
        let (dx, dy, dz) = (p.x - cx as f64, p.y - cy as f64, p.z - cz as f64);
        let g = |ox: i64, oy: i64, oz: i64| {
            let (gx, gy, gz) = gradient(self.hash(cx.wrapping_add(ox), cy.wrapping_add(oy), cz.wrapping_add(oz)));
            gx * (dx - ox as f64) + gy * (dy - oy as f64) + gz * (dz - oz as f64)
        };
        let (sx, sy, sz) = (fade(dx), fade(dy), fade(dz));
        let x0 = lerp(lerp(g(0, 0, 0), g(0, 0, 1), sz), lerp(g(0, 1, 0), g(0, 1, 1), sz), sy);
        let x1 = lerp(lerp(g(1, 0, 0), g(1, 0, 1), sz), lerp(g(1, 1, 0), g(1, 1, 1), sz), sy);
        (lerp(x0, x1, sx) * SCALE).clamp(-1.0, 1.0)
    }

    /// Adds `weight · noise(x_k, y, z)` to `out[k]` for `x_k = x0 + k·dx` (`dx > 0`):
    /// the row form of [`Perlin::value`], with the corner gradients of a cell computed
    /// once for all its samples. `abs` takes `|noise|` (turbulence).
    #[allow(clippy::too_many_arguments)] // the row (x0, dx, y, z) and what to add, as in the hot loop
    pub fn add_row(&self, x0: f64, dx: f64, y: f64, z: f64, weight: f64, abs: bool, out: &mut [f64]) {
        self.add_row_cached(&mut RowHashes::default(), x0, dx, y, z, weight, abs, out)
    }

    /// [`Perlin::add_row`] reusing the corner hashes of the previous row when it had the
    /// same cells (rows of a lattice finer than the noise share them: 16 rows per cell
    /// at the first octave of a 256³ fill over 16 periods).
    #[allow(clippy::too_many_arguments)]
    pub fn add_row_cached(
        &self,
        cache: &mut RowHashes,
        x0: f64,
        dx: f64,
        y: f64,
        z: f64,
        weight: f64,
        abs: bool,
        out: &mut [f64],
    ) {
        let n = out.len();
        if n == 0 {
            return;
        }
        let (cy, cz) = (corner(y), corner(z));
        let (dy, dz) = (y - cy as f64, z - cz as f64);
        let (sy, sz) = (fade(dy), fade(dz));
        let first = corner(x0);
        let last = corner(x0 + (n - 1) as f64 * dx);
        let faces = last.wrapping_sub(first).wrapping_add(2);
        if !(2..=(1 << 24)).contains(&faces) {
            // Saturated or absurd cell ranges: the point form, one sample at a time.
            for (k, o) in out.iter_mut().enumerate() {
                let v = self.value(DVec3::new(x0 + k as f64 * dx, y, z));
                *o += weight * if abs { v.abs() } else { v };
            }
            return;
        }
        let key = (first, faces, cy, cz);
        if cache.key != Some(key) {
            cache.key = Some(key);
            cache.hashes.clear();
            let p = &self.perm;
            let offsets = [(0i64, 0i64), (0, 1), (1, 0), (1, 1)];
            for f in 0..faces {
                let hx = p[(first.wrapping_add(f) & 255) as usize] as usize;
                let mut h = [0u8; 4];
                for (c, &(oy, oz)) in offsets.iter().enumerate() {
                    let yk = (cy.wrapping_add(oy) & 255) as usize;
                    let zk = (cz.wrapping_add(oz) & 255) as usize;
                    h[c] = p[(p[(hx ^ yk) & 255] as usize ^ zk) & 255] & 15;
                }
                cache.hashes.push(h);
            }
        }
        // The four (y, z) corners after the z then y interpolations have weights `w`;
        // per corner and hash, the gradient's y/z part and its x slope, pre-weighted,
        // so an x face is `Σ constant + Σ slope · (x − face)` from table look-ups.
        let w = [(1.0 - sy) * (1.0 - sz), (1.0 - sy) * sz, sy * (1.0 - sz), sy * sz];
        let offsets = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
        let mut constant = [[0.0f64; 16]; 4];
        let mut slope = [[0.0f64; 16]; 4];
        for (c, &(oy, oz)) in offsets.iter().enumerate() {
            for h in 0..16u8 {
                let (gx, gy, gz) = gradient(h);
                constant[c][h as usize] = w[c] * (gy * (dy - oy) + gz * (dz - oz));
                slope[c][h as usize] = w[c] * gx;
            }
        }
        let face = |f: usize| {
            let h = cache.hashes[f];
            let mut a = 0.0;
            let mut b = 0.0;
            for c in 0..4 {
                a += constant[c][h[c] as usize];
                b += slope[c][h[c] as usize];
            }
            (a, b)
        };
        let mut k = 0;
        let mut cell = 0usize;
        let mut near = face(0);
        while k < n && cell + 1 < faces as usize {
            let far = face(cell + 1);
            let cx = first.wrapping_add(cell as i64);
            // The samples in this cell: the corner rule makes cells [c, c + 1) for
            // c ≥ 0 and (c, c + 1] below.
            let end = cx.wrapping_add(1) as f64;
            let inclusive = end <= 0.0;
            let base = cx as f64;
            // Far face measured from x = cx + 1: its constant loses one slope.
            let (a1, b1) = (far.0 - far.1, far.1);
            let (n0a, n0b) = near;
            // `fx` lies in [0, 1] inside the cell (a rounded difference of ordered
            // values), so the fade needs no clamp.
            let sample = |fx: f64| {
                let s = fx * fx * fx * (fx * (fx * 6.0 - 15.0) + 10.0);
                (lerp(n0a + n0b * fx, a1 + b1 * fx, s) * SCALE).clamp(-1.0, 1.0)
            };
            if abs {
                while k < n {
                    let x = x0 + k as f64 * dx;
                    if x > end || (x == end && !inclusive) {
                        break;
                    }
                    out[k] += weight * sample(x - base).abs();
                    k += 1;
                }
            } else {
                while k < n {
                    let x = x0 + k as f64 * dx;
                    if x > end || (x == end && !inclusive) {
                        break;
                    }
                    out[k] += weight * sample(x - base);
                    k += 1;
                }
            }
            near = far;
            cell += 1;
        }
        // Rounding of x0 + k·dx near the last cell's end: finish by points.
        for (i, o) in out.iter_mut().enumerate().skip(k) {
            let v = self.value(DVec3::new(x0 + i as f64 * dx, y, z));
            *o += weight * if abs { v.abs() } else { v };
        }
    }
}
