//! Empty-space reach on the walk grid: per grid cell, the chessboard distance (in grid
//! cells) to the nearest cell that may hold the surface.
//!
//! A ray in a grid cell of reach `k ≥ 1` lies in the cube of `(2k − 1)³` grid cells
//! centred on its cell, none of which may hold the surface, so it crosses that whole cube
//! in one step: sphere tracing on the coarse grid with the chessboard metric. The bound is
//! exact (no approximation of the distance): it is the distance transform of the grid's
//! own classification of cells (conservative minimum above the iso value, or not).
//!
//! The transform is the two-pass chamfer of Rosenfeld & Pfaltz with unit weights on all 26
//! neighbours, which is exact for the chessboard (L∞) distance: the first pass in
//! increasing `x + n(y + n z)` order takes the 13 neighbours already visited, the second
//! pass in decreasing order the other 13.

/// The largest reach stored (the `u8` cap); farther cells keep this conservative value.
pub(crate) const REACH_CAP: u8 = u8::MAX;

/// The chessboard distance of every cell of an `n³` grid (index `x + n(y + n z)`) to the
/// nearest cell with `occupied` set, capped at [`REACH_CAP`]; [`REACH_CAP`] everywhere if
/// no cell is occupied.
pub(crate) fn chessboard_reach(n: usize, occupied: impl Fn(usize) -> bool) -> Vec<u8> {
    let mut reach: Vec<u8> = (0..n * n * n)
        .map(|k| if occupied(k) { 0 } else { REACH_CAP })
        .collect();
    let n = n as isize;
    // The 13 neighbours that precede a cell in index order (negative linear offset).
    let mut before = Vec::with_capacity(13);
    for dz in -1isize..=1 {
        for dy in -1isize..=1 {
            for dx in -1isize..=1 {
                if dx + n * (dy + n * dz) < 0 {
                    before.push((dx, dy, dz));
                }
            }
        }
    }
    let mut relax = |x: isize, y: isize, z: isize, sign: isize| {
        let k = (x + n * (y + n * z)) as usize;
        let mut best = reach[k];
        if best == 0 {
            return;
        }
        for &(dx, dy, dz) in &before {
            let (a, b, c) = (x + sign * dx, y + sign * dy, z + sign * dz);
            if a < 0 || b < 0 || c < 0 || a >= n || b >= n || c >= n {
                continue;
            }
            best = best.min(reach[(a + n * (b + n * c)) as usize].saturating_add(1));
        }
        reach[k] = best;
    };
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                relax(x, y, z, 1);
            }
        }
    }
    for z in (0..n).rev() {
        for y in (0..n).rev() {
            for x in (0..n).rev() {
                relax(x, y, z, -1);
            }
        }
    }
    reach
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Rng;

    /// The brute-force chessboard distance to the nearest occupied cell.
    fn brute(n: usize, occupied: &[bool], k: usize) -> u8 {
        let (x, y, z) = ((k % n) as isize, ((k / n) % n) as isize, (k / (n * n)) as isize);
        let mut best = usize::MAX;
        for (j, &o) in occupied.iter().enumerate() {
            if o {
                let (a, b, c) = ((j % n) as isize, ((j / n) % n) as isize, (j / (n * n)) as isize);
                let d = (a - x).abs().max((b - y).abs()).max((c - z).abs()) as usize;
                best = best.min(d);
            }
        }
        best.min(REACH_CAP as usize) as u8
    }

    #[test]
    fn the_two_pass_transform_equals_the_brute_force_distance() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for (n, density) in [(1usize, 2u64), (5, 3), (9, 40), (12, 400), (16, 5000), (7, u64::MAX)] {
            let occupied: Vec<bool> = (0..n * n * n).map(|_| rng.bits() % density == 0).collect();
            let reach = chessboard_reach(n, |k| occupied[k]);
            for (k, &r) in reach.iter().enumerate() {
                assert_eq!(r, brute(n, &occupied, k), "n {n}, density 1/{density}, cell {k}");
            }
        }
    }

    #[test]
    fn one_occupied_corner_gives_the_chessboard_shells_and_none_gives_the_cap() {
        let n = 6;
        let reach = chessboard_reach(n, |k| k == 0);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    assert_eq!(reach[x + n * (y + n * z)] as usize, x.max(y).max(z));
                }
            }
        }
        assert!(chessboard_reach(4, |_| false).iter().all(|&r| r == REACH_CAP));
    }
}
