//! Worley's cellular texture (survey §17.6): the distances F1 ≤ F2 from a point to the
//! nearest and second-nearest feature points, one feature point per unit cell at a
//! hashed position inside it.
//!
//! The search is exact: the 3×3×3 cells around the point are searched first; while F2
//! is larger than the distance from the point to the outside of the block searched, the
//! block grows by one cell (a feature point beyond it is farther than that distance).

use glam::{DVec3, IVec3};

use crate::perlin::corner_floor;

/// Feature points of one seed at `frequency` per world unit.
#[derive(Debug, Clone, Copy)]
pub struct Worley {
    seed: u32,
    frequency: f64,
}

/// A 64-bit mix of a cell and the seed (SplitMix64's finaliser).
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Worley {
    /// The feature points of `seed`, `frequency` cells per world unit.
    pub fn new(seed: u32, frequency: f64) -> Self {
        Worley { seed, frequency }
    }

    /// The feature point of cell `c` (cell space).
    pub fn feature_point(&self, c: IVec3) -> DVec3 {
        let key =
            (c.x as u32 as u64) ^ ((c.y as u32 as u64) << 21) ^ ((c.z as u32 as u64) << 42) ^ ((self.seed as u64) << 7);
        let h = mix(key ^ mix(c.z as i64 as u64 ^ 0x9e37_79b9_7f4a_7c15));
        let unit = |bits: u64| (bits & 0x1f_ffff) as f64 / (1u64 << 21) as f64;
        c.as_dvec3() + DVec3::new(unit(h), unit(h >> 21), unit(h >> 42))
    }

    fn search(&self, q: DVec3, cell: IVec3, reach: i32) -> (f64, f64) {
        let (mut f1, mut f2) = (f64::INFINITY, f64::INFINITY);
        for dz in -reach..=reach {
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    let d = self.feature_point(cell + IVec3::new(dx, dy, dz)).distance_squared(q);
                    if d < f1 {
                        f2 = f1;
                        f1 = d;
                    } else if d < f2 {
                        f2 = d;
                    }
                }
            }
        }
        (f1.sqrt(), f2.sqrt())
    }

    /// `(F1, F2)` at a world point, in cell units (divide by `frequency` for world units).
    pub fn f1_f2(&self, world_pos: DVec3) -> (f64, f64) {
        let q = world_pos * self.frequency;
        let cell = IVec3::new(corner_floor(q.x), corner_floor(q.y), corner_floor(q.z));
        let frac = q - cell.as_dvec3();
        let inner = frac.min(DVec3::ONE - frac).min_element();
        // A face neighbour's point is within √6 < 3 of q, so reach 3 always settles it.
        let mut reach = 1;
        loop {
            let r = self.search(q, cell, reach);
            if r.1 <= inner + reach as f64 || reach >= 3 {
                return r;
            }
            reach += 1;
        }
    }
}
