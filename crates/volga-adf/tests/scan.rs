//! The sorted candidate scan of `MeshSource::sample_among` (lists of triangle clusters
//! sorted by their boxes' gap to the cell, a scan that stops at the first gap above its
//! best and skips clusters by box and triangles by box and plane bounds) answers exactly
//! what the BVH answers: the same value bit for bit and the same carried winding integer,
//! at random points of random cells, with lists of the whole mesh and narrowed from a
//! parent's, on the unclean corpus (open, self-intersecting, overlapping, degenerate), a
//! mesh of slivers and a mesh at 1e6. The lists hold every triangle within the reach.

use glam::DVec3;
use volga_adf::{AdfSource, MeshSource};
use volga_core::Aabb;
use volga_mesh::{unclean, TriMesh};

mod common;
use common::Rng;

/// A strip of needle triangles (aspect ≈ 1e5) and exactly degenerate ones beside a
/// well-shaped fan, all close together, so thin triangles (no plane bound) compete with
/// well-shaped ones for the nearest point.
fn slivers() -> TriMesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..20 {
        let x = k as f64 * 0.05;
        let base = positions.len() as u32;
        positions.push(DVec3::new(x, 0.0, 0.0));
        positions.push(DVec3::new(x + 0.05, 0.0, 1e-6));
        positions.push(DVec3::new(x + 0.025, 1e-6, 0.0));
        positions.push(DVec3::new(x + 0.04, 0.0, 0.0)); // collinear with the first
        positions.push(DVec3::new(x, 0.3, 0.2));
        triangles.push([base, base + 1, base + 2]);
        triangles.push([base, base + 3, base + 1]);
        triangles.push([base, base + 1, base + 4]);
    }
    TriMesh::new(positions, triangles).unwrap()
}

fn check(name: &str, mesh: &TriMesh, rng: &mut Rng) {
    let source = MeshSource::new(mesh).unwrap();
    let bounds = mesh.bounds();
    let grown = Aabb::new(
        bounds.min - bounds.size() * 0.2 - DVec3::splat(1e-3),
        bounds.max + bounds.size() * 0.2 + DVec3::splat(1e-3),
    );
    let diagonal = grown.size().length();
    for cell_index in 0..40 {
        // Cells from a tenth of the box down to 1/2000 of it, around random points.
        let size = diagonal * 0.1 * (0.005f64).powf(rng.next());
        let min = rng.in_box(&grown);
        let cell = Aabb::new(min, min + DVec3::splat(size));
        let corner = source.sample(min, None);
        let reach = corner.value.abs() + size * 3f64.sqrt();
        let parent = source.candidates(&cell, reach, None).unwrap();
        assert!(parent.lower.windows(2).all(|w| w[0] <= w[1]), "{name}: sorted");
        assert_eq!(parent.lower.len(), parent.ids.len(), "{name}");
        // A child cell narrows the parent's list.
        let child = Aabb::new(min, min + DVec3::splat(size * 0.5));
        let child_reach = corner.value.abs() + size * 0.5 * 3f64.sqrt();
        let narrowed = source.candidates(&child, child_reach, Some(&parent)).unwrap();
        for (list, cell) in [(&parent, &cell), (&narrowed, &child)] {
            // The clusters of zero gap hold every triangle meeting the cell; no later one
            // holds any.
            let meets = |id: &u32| {
                let [a, b, c] = mesh.triangle(*id as usize);
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                lo.cmple(cell.max).all() && cell.min.cmple(hi).all()
            };
            let prefix = list.meeting_cell();
            let inside: Vec<u32> = source.triangles_of(prefix).collect();
            let after: Vec<u32> = source.triangles_of(&list.ids[prefix.len()..]).collect();
            assert!(!after.iter().any(meets), "{name}: cell {cell_index}");
            let listed: std::collections::HashSet<u32> = inside.iter().copied().chain(after).collect();
            let wanted = (0..mesh.triangle_count() as u32).filter(|id| meets(id));
            for id in wanted {
                assert!(inside.contains(&id), "{name}: cell {cell_index}: triangle {id}");
            }
            // Every triangle within the reach of the cell is listed.
            let reach_here = if std::ptr::eq(list, &parent) {
                reach
            } else {
                child_reach
            };
            for id in 0..mesh.triangle_count() as u32 {
                let [a, b, c] = mesh.triangle(id as usize);
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                let gap = (lo - cell.max).max(cell.min - hi).max(DVec3::ZERO).length();
                assert!(
                    gap > reach_here || listed.contains(&id),
                    "{name}: cell {cell_index}: triangle {id}"
                );
            }
            for _ in 0..12 {
                // Points inside the cell, on its corners and faces (lattice-like points).
                let p = if rng.next() < 0.3 {
                    let t = DVec3::new(
                        (rng.next() * 3.0).floor() * 0.5,
                        (rng.next() * 3.0).floor() * 0.5,
                        (rng.next() * 3.0).floor() * 0.5,
                    );
                    cell.min + t * cell.size()
                } else {
                    rng.in_box(cell)
                };
                let near_sample = source.sample(cell.min, None);
                let near = Some((cell.min, &near_sample));
                let scanned = source.sample_among(p, near, list);
                let plain = source.sample(p, near);
                assert_eq!(
                    scanned.value.to_bits(),
                    plain.value.to_bits(),
                    "{name}: cell {cell_index} at {p}: {} against {}",
                    scanned.value,
                    plain.value
                );
                assert_eq!(scanned.region, plain.region, "{name}: cell {cell_index} at {p}");
                // Without a neighbour: the scan's first bound is infinite.
                let alone = source.sample_among(p, None, list);
                assert_eq!(
                    alone.value.to_bits(),
                    source.sample(p, None).value.to_bits(),
                    "{name} at {p}"
                );
            }
        }
    }
}

#[test]
fn sorted_scans_equal_the_bvh() {
    let mut rng = Rng(0x5eed_adfb);
    let mut corpus = unclean::corpus();
    corpus.push(("slivers", slivers()));
    let sphere = unclean::uv_sphere(DVec3::ZERO, 1.0, 12, 24);
    corpus.push(("sphere at 1e6", sphere.translated(DVec3::splat(1e6))));
    corpus.push((
        "open sphere at 1e6",
        unclean::cut_where(&sphere, |p| p.z > 0.6).translated(DVec3::new(1e6, -1e6, 1e6)),
    ));
    for (name, mesh) in &corpus {
        if mesh.triangle_count() == 0 {
            continue;
        }
        check(name, mesh, &mut rng);
    }
}
