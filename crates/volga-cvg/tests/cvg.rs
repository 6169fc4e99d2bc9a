//! CVG operators: identities, the excluded-middle failures, exactness on constant
//! fields, interval bounds, lazy = baked, baking only what operators reach, voxblt.

use glam::{DVec3, IVec3, UVec3, Vec3};
use proptest::prelude::*;
use volga_core::{Aabb, Field, Grid, IndexBox, SparseVolume, Transform};
use volga_cvg::*;
use volga_shapes::{FilteredDensity, OrientedBoxFilter, Sphere};

/// A constant density over a box.
#[derive(Debug)]
struct Constant(f64, Aabb);

impl Field for Constant {
    fn bounds(&self) -> Aabb {
        self.1
    }
    fn value(&self, _: DVec3) -> f64 {
        self.0
    }
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(0.1)
    }
    fn value_range(&self, _: &Aabb) -> (f64, f64) {
        (self.0, self.0)
    }
}

fn everywhere() -> Aabb {
    Aabb::new(DVec3::splat(-10.0), DVec3::splat(10.0))
}

fn c(v: f64) -> Cvg<'static> {
    Cvg::leaf(Constant(v, everywhere()))
}

const OPS: [Op; 7] = [
    Op::Union,
    Op::Intersection,
    Op::Difference,
    Op::Product,
    Op::ProbabilisticSum,
    Op::AlgebraicDifference,
    Op::Blend(0.3),
];

#[test]
fn constant_fields_are_exact() {
    let values = [0.0, 0.125, 0.25, 0.5, 0.75, 1.0];
    for op in OPS {
        for &a in &values {
            for &b in &values {
                let t = Cvg::op(op, c(a), c(b));
                let expected = match op {
                    Op::Union => a.max(b),
                    Op::Intersection => a.min(b),
                    Op::Difference => a.min(1.0 - b),
                    Op::Product => a * b,
                    Op::ProbabilisticSum => a + b - a * b,
                    Op::AlgebraicDifference => a - a * b,
                    Op::Blend(w) => w * a + (1.0 - w) * b,
                };
                // Dyadic inputs: every form is exact in binary floating point.
                assert_eq!(t.density(DVec3::ZERO), expected, "{op:?}({a}, {b})");
                let r = t.range(&Aabb::new(DVec3::ZERO, DVec3::ONE));
                assert!(r.0 <= expected && expected <= r.1);
                if op != Op::Blend(0.3) {
                    assert_eq!(r, (expected, expected), "{op:?} range is exact on constants");
                }
            }
        }
    }
    assert_eq!(Cvg::not(c(0.25)).density(DVec3::ZERO), 0.75);
}

proptest! {
    #[test]
    fn identities(a in 0.0f64..=1.0, b in 0.0f64..=1.0) {
        let d = |t: Cvg| t.density(DVec3::ZERO);
        // Fuzzy (eq. 17): idempotent, identity elements, complement an involution,
        // De Morgan, difference = A ∩ B̄.
        prop_assert_eq!(d(Cvg::op(Op::Union, c(a), c(a))), a);
        prop_assert_eq!(d(Cvg::op(Op::Intersection, c(a), c(a))), a);
        prop_assert_eq!(d(Cvg::op(Op::Union, c(a), c(0.0))), a);
        prop_assert_eq!(d(Cvg::op(Op::Intersection, c(a), c(1.0))), a);
        prop_assert_eq!(d(Cvg::not(Cvg::not(c(a)))), 1.0 - (1.0 - a));
        prop_assert_eq!(d(Cvg::not(Cvg::op(Op::Union, c(a), c(b)))), d(Cvg::op(Op::Intersection, Cvg::not(c(a)), Cvg::not(c(b)))));
        prop_assert_eq!(d(Cvg::op(Op::Difference, c(a), c(b))), d(Cvg::op(Op::Intersection, c(a), Cvg::not(c(b)))));
        prop_assert_eq!(d(Cvg::op(Op::Union, c(a), c(b))), d(Cvg::op(Op::Union, c(b), c(a))));
        // Algebraic (eq. 18): identity and zero elements, commutativity, De Morgan,
        // difference = A·B̄.
        prop_assert_eq!(d(Cvg::op(Op::Product, c(a), c(1.0))), a);
        prop_assert_eq!(d(Cvg::op(Op::Product, c(a), c(0.0))), 0.0);
        // 1 − (1 − a) rounds: an identity up to one ulp.
        prop_assert!((d(Cvg::op(Op::ProbabilisticSum, c(a), c(0.0))) - a).abs() <= 1e-16);
        prop_assert_eq!(d(Cvg::op(Op::ProbabilisticSum, c(a), c(1.0))), 1.0);
        prop_assert_eq!(d(Cvg::op(Op::Product, c(a), c(b))), d(Cvg::op(Op::Product, c(b), c(a))));
        let dm = d(Cvg::not(Cvg::op(Op::ProbabilisticSum, c(a), c(b)))) - d(Cvg::op(Op::Product, Cvg::not(c(a)), Cvg::not(c(b))));
        prop_assert!(dm.abs() <= 1e-15);
        prop_assert_eq!(d(Cvg::op(Op::AlgebraicDifference, c(a), c(b))), d(Cvg::op(Op::Product, c(a), Cvg::not(c(b)))));
        // Blend: the end weights pick an operand.
        prop_assert_eq!(d(Cvg::op(Op::Blend(1.0), c(a), c(b))), a);
        prop_assert_eq!(d(Cvg::op(Op::Blend(0.0), c(a), c(b))), b);
    }
}

/// The survey's remark: neither family is a Boolean algebra.
#[test]
fn excluded_middle_fails() {
    let d = |t: Cvg| t.density(DVec3::ZERO);
    // Eq. 17: A ∩ Ā ≠ ∅ and A ∪ Ā ≠ everything at d = ½.
    assert_eq!(d(Cvg::op(Op::Intersection, c(0.5), Cvg::not(c(0.5)))), 0.5);
    assert_eq!(d(Cvg::op(Op::Union, c(0.5), Cvg::not(c(0.5)))), 0.5);
    // Eq. 18: A ∪ A ≠ A and A ∩ A ≠ A.
    assert_eq!(d(Cvg::op(Op::ProbabilisticSum, c(0.5), c(0.5))), 0.75);
    assert_eq!(d(Cvg::op(Op::Product, c(0.5), c(0.5))), 0.25);
    // On crisp densities (0 or 1) both families are Boolean.
    for a in [0.0, 1.0] {
        assert_eq!(d(Cvg::op(Op::Intersection, c(a), Cvg::not(c(a)))), 0.0);
        assert_eq!(d(Cvg::op(Op::ProbabilisticSum, c(a), c(a))), a);
    }
}

#[test]
fn attribute_rules() {
    let red = Attributes {
        colour: Vec3::X,
        material: 1,
    };
    let blue = Attributes {
        colour: Vec3::Z,
        material: 2,
    };
    assert_eq!(Op::Union.attributes(0.2, red, 0.7, blue), blue);
    assert_eq!(Op::Union.attributes(0.7, red, 0.7, blue), red);
    assert_eq!(Op::Intersection.attributes(0.2, red, 0.7, blue), red);
    assert_eq!(Op::Difference.attributes(0.2, red, 0.9, blue), red);
    let mix = Op::ProbabilisticSum.attributes(0.25, red, 0.75, blue);
    assert!((mix.colour - Vec3::new(0.25, 0.0, 0.75)).length() < 1e-6);
    assert_eq!(mix.material, 2);
    let blend = Op::Blend(0.5).attributes(1.0, red, 1.0, blue);
    assert!((blend.colour - Vec3::new(0.5, 0.0, 0.5)).length() < 1e-6);
}

fn sphere(center: DVec3, r: f64) -> Cvg<'static> {
    let filter = OrientedBoxFilter::for_spacing(DVec3::splat(0.1));
    Cvg::leaf(FilteredDensity::new(Sphere::new(center, r).unwrap(), filter))
}

fn radial(center: DVec3, r: f64) -> Cvg<'static> {
    Cvg::leaf(Radial::new(Core::Point(center), r, 0.1).unwrap())
}

fn cylinder(center: DVec3, axis: DVec3, r: f64, h: f64) -> Cvg<'static> {
    Cvg::leaf(
        Radial::new(
            Core::Axis {
                center,
                axis,
                half_length: h,
            },
            r,
            0.1,
        )
        .unwrap(),
    )
}

/// A random tree over spheres, fuzzy radial primitives and cylinders.
fn tree(seed: u64, depth: u32) -> Cvg<'static> {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    fn build(next: &mut dyn FnMut() -> f64, depth: u32) -> Cvg<'static> {
        let centre = DVec3::new(next() * 1.6 - 0.8, next() * 1.6 - 0.8, next() * 1.6 - 0.8);
        if depth == 0 || next() < 0.2 {
            return match (next() * 3.0) as u32 {
                0 => sphere(centre, 0.2 + next() * 0.6),
                1 => radial(centre, 0.2 + next() * 0.8),
                _ => cylinder(
                    centre,
                    DVec3::new(next() - 0.5, 1.0, next() - 0.5),
                    0.2 + next() * 0.5,
                    0.3 + next(),
                ),
            };
        }
        if next() < 0.1 {
            return Cvg::not(build(next, depth - 1));
        }
        let op = OPS[(next() * 7.0) as usize % 7];
        let op = if let Op::Blend(_) = op { Op::Blend(next()) } else { op };
        Cvg::op(op, build(next, depth - 1), build(next, depth - 1))
    }
    build(&mut next, depth)
}

fn grid(n: u32) -> Grid {
    let h = 2.4 / n as f64;
    Grid::new(
        Transform::new(DVec3::splat(-1.2 + h / 2.0), DVec3::splat(h)).unwrap(),
        UVec3::splat(n),
    )
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn interval_bounds_contain_samples(seed in any::<u64>(), cx in -1.0f64..1.0, cy in -1.0f64..1.0, cz in -1.0f64..1.0, size in 0.01f64..1.0) {
        let t = tree(seed, 3);
        let b = Aabb::new(DVec3::new(cx, cy, cz), DVec3::new(cx, cy, cz) + size);
        let (lo, hi) = t.range(&b);
        for i in 0..125 {
            let f = DVec3::new((i % 5) as f64, ((i / 5) % 5) as f64, (i / 25) as f64) / 4.0;
            let v = t.density(b.min + b.size() * f);
            prop_assert!(lo <= v && v <= hi, "{v} outside [{lo}, {hi}] in {t:?}");
        }
    }

    #[test]
    fn lazy_equals_baked(seed in any::<u64>(), probes in proptest::collection::vec((0i32..24, 0i32..24, 0i32..24), 64)) {
        let g = grid(24);
        let field = CvgField::new(tree(seed, 3), &g.world_bounds());
        let (volume, _) = bake(&field, &g, true);
        for (x, y, z) in probes {
            let ijk = IVec3::new(x, y, z);
            let p = g.transform.voxel_center(ijk);
            let lazy = if field.bounds().contains(p) { field.value(p) } else { field.background() };
            prop_assert!((volume.density.get(ijk) as f64 - lazy).abs() <= 1e-6, "{ijk}: {} vs {lazy}", volume.density.get(ijk));
            // Also where the support rule said "background": the tree agrees.
            prop_assert!((volume.density.get(ijk) as f64 - field.tree().density(p)).abs() <= 1e-6);
            let colour = volume.colour.as_ref().unwrap().get(ijk);
            // Colour is baked where the tree can differ from its background.
            if volume.density.get(ijk) != 0.0 && field.bounds().contains(p) {
                let lazy_colour = field.colour(p).unwrap();
                prop_assert!((Vec3::from(colour) - lazy_colour).length() <= 1e-6, "{ijk} {colour:?} {lazy_colour} d={} bg={} {:?}", volume.density.get(ijk), field.background(), field);
            }
        }
    }
}

#[test]
fn intersection_bakes_only_the_overlap() {
    let g = grid(48);
    let a = sphere(DVec3::new(-0.5, 0.0, 0.0), 0.6);
    let b = sphere(DVec3::new(0.5, 0.0, 0.0), 0.6);
    let overlap = a.support().intersection(&b.support());
    let t = Cvg::op(Op::Intersection, a, b);
    assert_eq!(t.support(), overlap);
    let field = CvgField::new(t, &g.world_bounds());
    let (_, stats) = bake(&field, &g, false);
    let union = CvgField::new(
        Cvg::op(
            Op::Union,
            sphere(DVec3::new(-0.5, 0.0, 0.0), 0.6),
            sphere(DVec3::new(0.5, 0.0, 0.0), 0.6),
        ),
        &g.world_bounds(),
    );
    let (_, union_stats) = bake(&union, &g, false);
    assert!(
        stats.bricks_visited * 2 < union_stats.bricks_visited,
        "{stats:?} vs {union_stats:?}"
    );
    // Differences reach only A's box.
    let d = Cvg::op(Op::Difference, sphere(DVec3::ZERO, 0.3), sphere(DVec3::X, 0.9));
    assert_eq!(d.support(), sphere(DVec3::ZERO, 0.3).support());
}

#[test]
fn voxblt_copies_and_combines() {
    let g = grid(24);
    let (src, _) = bake(&CvgField::new(sphere(DVec3::ZERO, 0.7), &g.world_bounds()), &g, false);
    let mut dst = SparseVolume::new(g, 0.0, false);
    dst.density.set(IVec3::new(3, 3, 3), 0.25);
    let block = IndexBox::new(IVec3::splat(4), IVec3::splat(20));
    let n = voxblt(&mut dst, &src, &block, IVec3::new(-4, 0, 0), BlockOp::Copy);
    assert_eq!(n, 16 * 16 * 16);
    for ijk in block.iter() {
        assert_eq!(dst.density.get(ijk - IVec3::new(4, 0, 0)), src.density.get(ijk));
    }
    // Union with itself leaves it unchanged; the algebraic sum does not.
    let before = dst.clone();
    voxblt(
        &mut dst,
        &before,
        &g.index_box(),
        IVec3::ZERO,
        BlockOp::Combine(Op::Union),
    );
    for ijk in g.index_box().iter() {
        assert_eq!(dst.density.get(ijk), before.density.get(ijk));
    }
    voxblt(
        &mut dst,
        &before,
        &g.index_box(),
        IVec3::ZERO,
        BlockOp::Combine(Op::ProbabilisticSum),
    );
    let ijk = IVec3::new(3, 3, 3);
    assert!((dst.density.get(ijk) - 0.4375).abs() < 1e-7);
    // Off-grid voxels are dropped.
    let n = voxblt(&mut dst, &src, &g.index_box(), IVec3::new(20, 0, 0), BlockOp::Copy);
    assert_eq!(n, 4 * 24 * 24);
}

#[test]
fn bake_identical_for_one_and_two_threads() {
    let g = grid(40);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let field = CvgField::new(tree(7, 4), &g.world_bounds());
                let (v, stats) = bake(&field, &g, true);
                let bits: Vec<u32> = g.index_box().iter().map(|ijk| v.density.get(ijk).to_bits()).collect();
                let colour: Vec<[u32; 3]> = g
                    .index_box()
                    .iter()
                    .map(|ijk| v.colour.as_ref().unwrap().get(ijk).map(f32::to_bits))
                    .collect();
                (bits, colour, stats)
            })
    };
    assert_eq!(run(1), run(2));
}

/// Each requirement of `Radial::new` is checked: the argument that breaks it is refused
/// with its name and value, and arguments that meet it are accepted.
#[test]
fn radial_refuses_what_its_docs_rule_out() {
    let point = Core::Point(DVec3::ZERO);
    let axis = |center: DVec3, axis: DVec3, half_length: f64| Core::Axis {
        center,
        axis,
        half_length,
    };
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = Radial::new(point, bad, 0.1).unwrap_err();
        assert!(
            err.to_string().starts_with("radius must be finite and > 0, got "),
            "{err}"
        );
        let err = Radial::new(point, 1.0, bad).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("sample_spacing must be finite and > 0, got "),
            "{err}"
        );
        let err = Radial::new(axis(DVec3::ZERO, DVec3::Y, bad), 1.0, 0.1).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("core half_length must be finite and > 0, got "),
            "{err}"
        );
        assert!(err.to_string().ends_with(&bad.to_string()), "{err}");
    }
    assert_eq!(Radial::new(point, -2.0, 0.1).unwrap_err(), CvgError::Radius(-2.0));
    assert_eq!(Radial::new(point, 1.0, 0.0).unwrap_err(), CvgError::SampleSpacing(0.0));
    let far = DVec3::new(f64::INFINITY, 0.0, 0.0);
    assert_eq!(
        Radial::new(Core::Point(far), 1.0, 0.1).unwrap_err(),
        CvgError::Center(far)
    );
    assert_eq!(
        Radial::new(axis(far, DVec3::Y, 1.0), 1.0, 0.1).unwrap_err(),
        CvgError::Center(far)
    );
    for bad in [DVec3::ZERO, DVec3::new(f64::NAN, 1.0, 0.0), DVec3::splat(1e-320)] {
        let err = Radial::new(axis(DVec3::ZERO, bad, 1.0), 1.0, 0.1).unwrap_err();
        assert!(matches!(err, CvgError::Axis(a) if a.to_array().map(f64::to_bits) == bad.to_array().map(f64::to_bits)));
        assert!(
            err.to_string()
                .starts_with("core axis must be a finite non-zero vector, got "),
            "{err}"
        );
    }
    assert_eq!(
        Radial::new(axis(DVec3::ZERO, DVec3::new(0.0, 2.0, 0.0), 0.0), 1.0, 0.1).unwrap_err(),
        CvgError::HalfLength(0.0)
    );
    assert!(Radial::new(point, 1e-9, 1e-9).is_ok());
    assert!(Radial::new(axis(DVec3::ONE, DVec3::new(0.0, 2.0, 0.0), 0.5), 1.0, 0.1).is_ok());
}
