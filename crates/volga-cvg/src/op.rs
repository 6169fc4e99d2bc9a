//! The CVG operators on densities in \[0, 1\] (survey §17.5): fuzzy (eq. 17: min, max,
//! `1 − d`, `min(dA, 1 − dB)`), algebraic (eq. 18: product, probabilistic sum,
//! `dA − dA·dB`) and blend (`w·dA + (1 − w)·dB`), with interval forms for conservative
//! bounds and the rules by which attributes combine.
//!
//! Every operator is monotone in each operand (increasing, or decreasing in `B` for the
//! differences), and each is evaluated as a chain of correctly rounded monotone steps
//! (the probabilistic sum as `1 − (1 − a)(1 − b)`), so the interval form applied to
//! the operands' bounds contains every value the point form computes, rounding included.

use glam::Vec3;

/// Attributes a spatial object carries besides its density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attributes {
    /// Linear RGB.
    pub colour: Vec3,
    /// A material id (what a renderer or exporter looks up; 0 by default).
    pub material: u16,
}

impl Default for Attributes {
    fn default() -> Self {
        Attributes {
            colour: Vec3::ONE,
            material: 0,
        }
    }
}

/// A binary CVG operator. The complement is unary: [`complement`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// Fuzzy union, `max(dA, dB)` (eq. 17).
    Union,
    /// Fuzzy intersection, `min(dA, dB)` (eq. 17).
    Intersection,
    /// Fuzzy difference, `min(dA, 1 − dB)` (eq. 17).
    Difference,
    /// Algebraic intersection, `dA·dB` (eq. 18).
    Product,
    /// Algebraic union, `dA + dB − dA·dB`, computed as `1 − (1 − dA)(1 − dB)` (eq. 18).
    ProbabilisticSum,
    /// Algebraic difference, `dA − dA·dB`, computed as `dA·(1 − dB)` (eq. 18).
    AlgebraicDifference,
    /// Blend, `w·dA + (1 − w)·dB` with `w` in \[0, 1\].
    Blend(f64),
}

/// The complement `1 − d` (eqs. 17 and 18 agree).
#[inline]
pub fn complement(d: f64) -> f64 {
    1.0 - d
}

impl Op {
    /// The operator's name in reports and scene files.
    pub fn name(self) -> &'static str {
        match self {
            Op::Union => "union",
            Op::Intersection => "intersection",
            Op::Difference => "difference",
            Op::Product => "product",
            Op::ProbabilisticSum => "probabilistic_sum",
            Op::AlgebraicDifference => "algebraic_difference",
            Op::Blend(_) => "blend",
        }
    }

    /// The density of the result.
    #[inline]
    pub fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Op::Union => a.max(b),
            Op::Intersection => a.min(b),
            Op::Difference => a.min(1.0 - b),
            Op::Product => a * b,
            Op::ProbabilisticSum => 1.0 - (1.0 - a) * (1.0 - b),
            Op::AlgebraicDifference => a * (1.0 - b),
            Op::Blend(w) => w * a + (1.0 - w) * b,
        }
    }

    /// Bounds of the result over boxes where `a ∈ [a.0, a.1]` and `b ∈ [b.0, b.1]`
    /// (operands in \[0, 1\]).
    pub fn range(self, a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
        match self {
            // Increasing in both operands.
            Op::Union | Op::Intersection | Op::Product | Op::ProbabilisticSum | Op::Blend(_) => {
                (self.apply(a.0, b.0), self.apply(a.1, b.1))
            }
            // Increasing in A, decreasing in B.
            Op::Difference | Op::AlgebraicDifference => (self.apply(a.0, b.1), self.apply(a.1, b.0)),
        }
    }

    /// How attributes combine at a point where the operands have densities `da`, `db`:
    ///
    /// * union / intersection: the attributes of the operand whose density the result
    ///   takes (the denser for union, the thinner for intersection; `A` on ties);
    /// * differences (fuzzy and algebraic): `A`'s (B only carves);
    /// * product and probabilistic sum: colour opacity-weighted,
    ///   `(dA·cA + dB·cB)/(dA + dB)` (`A`'s where both are 0), material of the denser;
    /// * blend: colour weighted by `w·dA` and `(1 − w)·dB`, material of the larger
    ///   weighted density.
    pub fn attributes(self, da: f64, a: Attributes, db: f64, b: Attributes) -> Attributes {
        match self {
            Op::Union => {
                if db > da {
                    b
                } else {
                    a
                }
            }
            Op::Intersection => {
                if db < da {
                    b
                } else {
                    a
                }
            }
            Op::Difference | Op::AlgebraicDifference => a,
            Op::Product | Op::ProbabilisticSum => weighted(da, a, db, b),
            Op::Blend(w) => weighted(w * da, a, (1.0 - w) * db, b),
        }
    }
}

fn weighted(wa: f64, a: Attributes, wb: f64, b: Attributes) -> Attributes {
    let total = wa + wb;
    if total <= 0.0 {
        return a;
    }
    Attributes {
        colour: a.colour * (wa / total) as f32 + b.colour * (wb / total) as f32,
        material: if wb > wa { b.material } else { a.material },
    }
}
