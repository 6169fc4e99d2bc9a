//! Re-extraction at a new iso-value without sampling again: the blocks' samples and their
//! value ranges kept as a span-space index (the survey's §3, Fig. 2: a cell, here a block
//! of 16³ cubes, is the point `(v_min, v_max)` and holds the surface at `v` exactly when
//! `v_min ≤ v ≤ v_max`; Livnat, Shen & Johnson's NOISE and Cignoni et al.'s interval trees
//! search that half-plane). The blocks are sorted by `v_min`, so the candidates for `v` are
//! a prefix found by binary search, filtered by `v_max`; a slider over iso-values then
//! meshes only the blocks the surface crosses, from memory.

use glam::IVec3;
use rayon::prelude::*;
use volga_core::Field;

use super::{block_points, finish, mesh_samples, BlockSamples, ExtractError, Extraction, Lattice, Surface};

/// A block kept by the index: its samples (raw field values) and their range.
struct Kept {
    /// Block number (x fastest): the order blocks are merged in.
    number: u64,
    lo: IVec3,
    samples: BlockSamples,
    min: f64,
    max: f64,
}

/// The blocks of an extraction lattice that may hold the surface for some iso-value in a
/// range, sampled once, with a span-space index over their value ranges.
pub struct IsoIndex<'f, F: Field + ?Sized> {
    field: &'f F,
    job: Extraction,
    lattice: Lattice,
    block_count: u64,
    /// Sorted by `min`.
    kept: Vec<Kept>,
    inward: f64,
}

impl<'f, F: Field + ?Sized> IsoIndex<'f, F> {
    /// Samples every block of `job`'s lattice whose conservative value range
    /// ([`Field::value_range`]) meets `iso_range` (inclusive), keeping its samples: at most
    /// `max_bytes` of them, or [`ExtractError::IndexTooLarge`]. `job.iso` is ignored.
    pub fn build(field: &'f F, job: &Extraction, iso_range: (f64, f64), max_bytes: u64) -> Result<Self, ExtractError> {
        let (lattice, blocks) = super::checked_lattice(job)?;
        if !(iso_range.0.is_finite() && iso_range.1.is_finite() && iso_range.0 <= iso_range.1) {
            return Err(ExtractError::Iso(if iso_range.0.is_finite() {
                iso_range.1
            } else {
                iso_range.0
            }));
        }
        let inward = field.kind().inward_sign();
        let block_count = blocks.as_u64vec3().element_product();
        let (bx, by) = (blocks.x as u64, blocks.y as u64);
        let bytes = std::sync::atomic::AtomicU64::new(0);
        let over = std::sync::atomic::AtomicBool::new(false);
        let mut kept: Vec<Kept> = (0..block_count)
            .into_par_iter()
            .filter_map(|k| {
                if over.load(std::sync::atomic::Ordering::Relaxed) {
                    return None;
                }
                let b = IVec3::new((k % bx) as i32, (k / bx % by) as i32, (k / (bx * by)) as i32);
                let (lo, hi, sample_lo) = block_points(&lattice, b, job.method);
                let box_ = volga_core::Aabb::new(lattice.world(lo), lattice.world(hi));
                let (vlo, vhi) = field.value_range(&box_);
                if vhi < iso_range.0 || vlo > iso_range.1 {
                    return None;
                }
                let samples = BlockSamples::sample(field, &lattice, sample_lo, hi);
                let (min, max) = samples
                    .values
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
                if max < iso_range.0 || min > iso_range.1 {
                    return None;
                }
                let size = samples.bytes();
                if bytes.fetch_add(size, std::sync::atomic::Ordering::Relaxed) + size > max_bytes {
                    over.store(true, std::sync::atomic::Ordering::Relaxed);
                    return None;
                }
                Some(Kept {
                    number: k,
                    lo,
                    samples,
                    min,
                    max,
                })
            })
            .collect();
        if over.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(ExtractError::IndexTooLarge { max_bytes });
        }
        kept.sort_by(|a, b| a.min.total_cmp(&b.min).then(a.number.cmp(&b.number)));
        Ok(IsoIndex {
            field,
            job: *job,
            lattice,
            block_count,
            kept,
            inward,
        })
    }

    /// Blocks kept.
    pub fn blocks(&self) -> usize {
        self.kept.len()
    }

    /// Bytes of samples kept.
    pub fn bytes(&self) -> u64 {
        self.kept.iter().map(|k| k.samples.bytes()).sum()
    }

    /// Blocks whose samples span `iso` (the candidates an extraction at `iso` meshes).
    pub fn candidates(&self, iso: f64) -> usize {
        self.candidate_ids(iso).len()
    }

    fn candidate_ids(&self, iso: f64) -> Vec<usize> {
        let end = self.kept.partition_point(|k| k.min <= iso);
        let mut ids: Vec<usize> = (0..end).filter(|&i| self.kept[i].max >= iso).collect();
        ids.sort_by_key(|&i| self.kept[i].number);
        ids
    }

    /// The surface at `iso`: identical to [`extract_surface_with`](super::extract_surface_with)
    /// of the same job at that iso-value when `iso` lies in the index's range.
    pub fn extract(&self, iso: f64) -> Result<Surface, ExtractError> {
        if !iso.is_finite() {
            return Err(ExtractError::Iso(iso));
        }
        let job = Extraction { iso, ..self.job };
        let ids = self.candidate_ids(iso);
        let outs: Vec<_> = ids
            .par_iter()
            .map(|&i| {
                let k = &self.kept[i];
                let signed = BlockSamples {
                    lo: k.samples.lo,
                    n: k.samples.n,
                    values: k.samples.values.iter().map(|v| self.inward * (v - iso)).collect(),
                    shell: k.samples.shell.clone(),
                };
                // Blocks with no sign change mesh to nothing; keep them out of the count.
                let (s_min, s_max) = signed
                    .values
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
                (s_min < 0.0 && s_max >= 0.0)
                    .then(|| mesh_samples(self.field, &self.lattice, &signed, k.lo, &job, self.inward))
            })
            .collect();
        let outs: Vec<_> = outs.into_iter().flatten().collect();
        Ok(finish(self.field, &job, outs, self.block_count))
    }
}
