//! `CappedWinding`: the capped inside test equals the brute-force winding number on every
//! mesh of the unclean corpus, at random points and at dyadic lattice points (where cap
//! planes and mesh planes pass through samples), and carrying `I` along segments agrees
//! with computing it afresh.

use glam::DVec3;
use volga_mesh::{unclean, Bvh, CappedWinding};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn capped_inside_equals_the_winding_number_and_carries_agree() {
    for (name, mesh) in unclean::corpus() {
        let capped = CappedWinding::new(&mesh);
        let bvh = Bvh::build(&mesh);
        let b = mesh.bounds();
        let size = b.size().max(DVec3::splat(1e-3));
        let mut rng = Rng(99);
        let (mut carried, mut undecided) = (0, 0);
        for k in 0..1500 {
            let raw = b.min - size * 0.1 + DVec3::new(rng.next(), rng.next(), rng.next()) * size * 1.2;
            // Every other point on a dyadic lattice of the mesh's scale.
            let p = if k % 2 == 0 {
                raw
            } else {
                (raw / size.max_element() * 32.0).round() / 32.0 * size.max_element()
            };
            if bvh.closest(p).unwrap().distance == 0.0 {
                continue; // on the mesh: no side
            }
            let exact = bvh.winding_number_exact(p);
            if (exact - 0.5).abs() < 1e-9 {
                continue;
            }
            let (inside, integer, _) = capped.inside_with(p, None);
            assert_eq!(inside, exact >= 0.5, "{name} at {p}: w = {exact}");
            // Carry I to a nearby point along an axis (or a diagonal) and compare.
            let axis = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE][k % 4];
            let q = p + axis * size.max_element() * ((rng.next() * 8.0).floor() - 4.0) / 64.0;
            if let (Some(i), (_, Some(j), _)) = (integer, capped.inside_with(q, None)) {
                match capped.integer_along(p, i, q) {
                    Some(c) => {
                        assert_eq!(c, j, "{name}: carry {p} → {q}");
                        carried += 1;
                    }
                    None => undecided += 1,
                }
            }
        }
        assert!(carried > undecided, "{name}: {carried} carried, {undecided} undecided");
    }
}
