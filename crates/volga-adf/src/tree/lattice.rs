//! Sampling the source on a cell's 3×3×3 lattice (its 8 corners and 19 test points)
//! during a build: lattice indices, the per-subtree sample cache, and the children's
//! corners taken from their parent's lattice.

use std::sync::atomic::Ordering;

use glam::DVec3;

use super::build::Builder;
use super::corner_position;
use crate::source::{AdfSource, CellCandidates, Sample};
use crate::AdfError;

/// Samples already taken in one sequentially built subtree, by lattice point (integer
/// coordinates in half-finest-cell units from the root's minimum): a point shared by
/// sibling or cousin cells is evaluated once. Values are functions of the point alone, so
/// the cache changes the work, never the tree.
#[derive(Default)]
pub(crate) struct SampleCache {
    ///
    /// A test point is on the lattice of cells of its own depth only (at an odd multiple
    /// of their half size in one or two coordinates: every deeper cell has it as a corner,
    /// from its parent's lattice, and no shallower cell's lattice holds it), so it is
    /// looked up only by the other cells of that depth around it: one across a face
    /// centre, three around an edge midpoint. Each entry counts the lookups left and is
    /// dropped at the last, so the map holds the build's frontier, not every sample.
    pub(super) samples: rustc_hash::FxHashMap<[u32; 3], (Sample, u8)>,
    /// Sign-field values at jump leaves' corners ([`AdfSource::sign_field_at`]).
    pub(super) sign_fields: rustc_hash::FxHashMap<[u32; 3], Option<f64>>,
}

/// The 27 points of a cell's 3×3×3 lattice, index `i + 3j + 9k`, in half-cell units.
#[inline]
pub(super) fn lattice_index(i: usize, j: usize, k: usize) -> usize {
    i + 3 * j + 9 * k
}

#[inline]
fn corner_lattice(b: usize) -> usize {
    lattice_index((b & 1) * 2, ((b >> 1) & 1) * 2, ((b >> 2) & 1) * 2)
}

impl<S: AdfSource + ?Sized> Builder<'_, S> {
    pub fn eval(&self, p: DVec3, near: Option<(DVec3, &Sample)>) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample(p, near);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    pub(super) fn eval_among(
        &self,
        p: DVec3,
        near: Option<(DVec3, &Sample)>,
        candidates: &CellCandidates,
    ) -> Result<Sample, AdfError> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let s = self.source.sample_among(p, near, candidates);
        if s.value.is_finite() {
            Ok(s)
        } else {
            Err(AdfError::NonFinite(p.to_array()))
        }
    }

    /// The 27 samples of a cell's 3×3×3 lattice: its corners and its 19 test points (each
    /// given the nearest corner that knows its region), from `cache` when a neighbour
    /// took them already, among the cell's `candidates` when the source narrows.
    pub(super) fn lattice(
        &self,
        min: DVec3,
        size: f64,
        samples: &[Sample; 8],
        candidates: Option<&CellCandidates>,
        mut cache: Option<&mut SampleCache>,
    ) -> Result<[Sample; 27], AdfError> {
        let mut lattice = [None; 27];
        for b in 0..8 {
            lattice[corner_lattice(b)] = Some(samples[b]);
        }
        let half = size * 0.5;
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    let l = lattice_index(i, j, k);
                    if lattice[l].is_some() {
                        continue;
                    }
                    let p = min + DVec3::new(i as f64, j as f64, k as f64) * half;
                    // The centre is strictly inside the cell and at an odd multiple of
                    // its children's half size: no other cell's lattice holds it (its
                    // descendants get it as a corner from this lattice), so it is neither
                    // looked up nor kept.
                    let centre = l == lattice_index(1, 1, 1);
                    let mut cache_here = if centre { None } else { cache.as_deref_mut() };
                    let key = self.lattice_key(p);
                    if let Some(c) = cache_here.as_deref_mut() {
                        if let std::collections::hash_map::Entry::Occupied(mut e) = c.samples.entry(key) {
                            let (s, left) = e.get_mut();
                            lattice[l] = Some(*s);
                            *left -= 1;
                            if *left == 0 {
                                e.remove();
                            }
                            continue;
                        }
                    }
                    // The nearest corner that knows its region (the shortest carry).
                    let near = (0..8)
                        .filter(|&b| samples[b].region.is_some())
                        .map(|b| (corner_position(min, size, b), &samples[b]))
                        .min_by(|a, b| (p - a.0).length_squared().total_cmp(&(p - b.0).length_squared()));
                    let s = match candidates {
                        Some(c) => self.eval_among(p, near, c)?,
                        None => self.eval(p, near)?,
                    };
                    if let Some(c) = cache_here {
                        // Other cells of this depth sharing the point: 1 across a face
                        // centre (one coordinate on the cell's boundary), 3 around an
                        // edge midpoint (two).
                        let on_boundary = [i, j, k].iter().filter(|&&x| x != 1).count();
                        c.samples.insert(key, (s, if on_boundary == 1 { 1 } else { 3 }));
                    }
                    lattice[l] = Some(s);
                }
            }
        }
        Ok(lattice.map(|s| s.expect("every lattice point is sampled")))
    }

    /// Integer lattice coordinates of a lattice point (exact: points and origin are on
    /// the lattice of the finest cells).
    #[inline]
    pub(super) fn lattice_key(&self, p: DVec3) -> [u32; 3] {
        let k = ((p - self.lattice_origin) / self.lattice_unit).round();
        [k.x as u32, k.y as u32, k.z as u32]
    }
}

/// The corner values and minimum of child octant `o` (bits x, y, z) from the parent's
/// 3×3×3 lattice.
#[inline]
pub(crate) fn child_of<T: Copy>(min: DVec3, half: f64, o: usize, lattice: &[T; 27]) -> (DVec3, [T; 8]) {
    let (ox, oy, oz) = (o & 1, (o >> 1) & 1, (o >> 2) & 1);
    let child_min = min + DVec3::new(ox as f64, oy as f64, oz as f64) * half;
    let values =
        std::array::from_fn(|b| lattice[lattice_index(ox + (b & 1), oy + ((b >> 1) & 1), oz + ((b >> 2) & 1))]);
    (child_min, values)
}
