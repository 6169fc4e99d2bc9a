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

/// `caps_range_over_ball` bounds the caps' winding number at every point of the ball:
/// checked against the caps' exact winding number at points spread over balls of many
/// sizes, near the holes and away from them.
#[test]
fn the_caps_range_over_a_ball_holds_at_every_point_of_it() {
    let (mut proven, mut asked) = (0, 0);
    for (name, mesh) in unclean::corpus() {
        let caps = volga_mesh::cap_triangles(&mesh);
        if caps.is_empty() {
            continue;
        }
        let capped = CappedWinding::new(&mesh);
        let cap_mesh = volga_mesh::TriMesh {
            positions: caps.iter().flatten().copied().collect(),
            triangles: (0..caps.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
        };
        let cap_bvh = Bvh::build(&cap_mesh);
        let b = mesh.bounds();
        let size = b.size().max_element().max(1e-3);
        let mut rng = Rng(7);
        for k in 0..300 {
            // Centres over the mesh's box and near cap corners; radii from 1e-4 to 0.3 of it.
            let centre = if k % 2 == 0 {
                b.min - 0.1 * size + DVec3::new(rng.next(), rng.next(), rng.next()) * 1.2 * size
            } else {
                let corner = caps[(rng.next() * caps.len() as f64) as usize % caps.len()][k % 3];
                corner + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * 0.2 * size
            };
            let radius = size * 1e-4 * 3000f64.powf(rng.next());
            asked += 1;
            let Some((lo, hi)) = capped.caps_range_over_ball(centre, radius) else {
                continue;
            };
            proven += 1;
            for _ in 0..20 {
                let d = DVec3::new(rng.next(), rng.next(), rng.next()) * 2.0 - 1.0;
                let x = centre + d.normalize_or_zero() * radius * rng.next().cbrt();
                let w = cap_bvh.winding_number_exact(x);
                assert!(
                    lo - 1e-12 <= w && w <= hi + 1e-12,
                    "{name}: w_C = {w} at {x}, outside [{lo}, {hi}] over the ball at {centre} of radius {radius}"
                );
            }
        }
    }
    assert!(proven * 3 > asked, "{proven} of {asked} balls bounded");
}
