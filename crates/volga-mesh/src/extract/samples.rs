//! A block's samples: the field's values on its lattice points, read straight from a
//! volume's voxels when the lattice is their centres, with the voxels around the block
//! that give the gradient (normals) without asking the field again.

use glam::{DVec3, IVec3};
use volga_core::Field;

use super::{corner, Lattice};

/// Field values on lattice points `lo ..= lo + n − 1`, x fastest.
pub(super) struct BlockSamples {
    pub lo: IVec3,
    pub n: IVec3,
    pub values: Vec<f64>,
    /// When the lattice points are the voxel centres of a trilinear field whose gradient is
    /// central differences: the voxels of points `lo − 1 ..= lo + n` (one more on every
    /// side, x fastest), which give that gradient at any point of the block's cubes.
    pub shell: Option<VoxelShell>,
}

/// The voxels around a block, for its gradients (see [`BlockSamples::shell`]).
#[derive(Clone)]
pub(super) struct VoxelShell {
    voxels: std::sync::Arc<[f32]>,
    /// The voxel spacing (world units per index step).
    spacing: DVec3,
}

impl BlockSamples {
    /// Samples `field` on lattice points `lo ..= hi`, rows along x through the batch path
    /// (`values_along`: a sampled field reads its bricks once per row).
    pub fn sample<F: Field + ?Sized>(field: &F, lattice: &Lattice, lo: IVec3, hi: IVec3) -> BlockSamples {
        let n = hi - lo + 1;
        if let Some((values, shell)) = voxel_centre_values(field, lattice, lo, n) {
            return BlockSamples { lo, n, values, shell };
        }
        let mut values = vec![0.0f64; (n.x * n.y * n.z) as usize];
        let step = DVec3::new(lattice.cell, 0.0, 0.0);
        for (k, row) in values.chunks_exact_mut(n.x as usize).enumerate() {
            let (y, z) = (k as i32 % n.y, k as i32 / n.y);
            let line = volga_core::Line {
                origin: lattice.world(IVec3::new(0, lo.y + y, lo.z + z)),
                step,
            };
            field.values_along(&line, lo.x as u64, row);
        }
        BlockSamples {
            lo,
            n,
            values,
            shell: None,
        }
    }

    /// The field's gradient (central differences of the trilinear reconstruction, as
    /// `Sampled` computes it) at `local + f` (the block's lattice coordinates, `f` in
    /// `[0, 1]³`), from the shell; `None` without one.
    pub fn gradient(&self, local: IVec3, f: DVec3) -> Option<DVec3> {
        let shell = self.shell.as_ref()?;
        let m = self.n + 2;
        let at = |p: IVec3| shell.voxels[((p.x + 1) + m.x * ((p.y + 1) + m.y * (p.z + 1))) as usize] as f64;
        let mut g = DVec3::ZERO;
        for c in 0..8 {
            let k = corner(c);
            let w = (if k.x == 1 { f.x } else { 1.0 - f.x })
                * (if k.y == 1 { f.y } else { 1.0 - f.y })
                * (if k.z == 1 { f.z } else { 1.0 - f.z });
            if w == 0.0 {
                continue;
            }
            let p = local + k;
            let d = DVec3::new(
                at(p + IVec3::X) - at(p - IVec3::X),
                at(p + IVec3::Y) - at(p - IVec3::Y),
                at(p + IVec3::Z) - at(p - IVec3::Z),
            );
            g += w * d;
        }
        Some(g / (2.0 * shell.spacing))
    }

    /// Bytes held (values, shell and bookkeeping).
    pub fn bytes(&self) -> u64 {
        self.values.len() as u64 * 8 + self.shell.as_ref().map_or(0, |s| s.voxels.len() as u64 * 4) + 64
    }

    /// The values turned to the inward-signed space of `iso` (inside `≥ 0`).
    pub fn signed(mut self, inward: f64, iso: f64) -> BlockSamples {
        for v in &mut self.values {
            *v = inward * (*v - iso);
        }
        self
    }
}

/// The field's values on lattice points `lo .. lo + n` read straight from its voxels, when
/// the field is a voxel grid reconstructed by an interpolating filter (nearest or
/// trilinear, which equal the voxel's value at its centre) and the lattice points are its
/// voxel centres (same spacing, origin on a centre): what a volume's own extraction lattice
/// is. `None` otherwise (the points are then sampled through the field).
fn voxel_centre_values<F: Field + ?Sized>(
    field: &F,
    lattice: &Lattice,
    lo: IVec3,
    n: IVec3,
) -> Option<(Vec<f64>, Option<VoxelShell>)> {
    let voxels = field.voxels()?;
    if !matches!(
        voxels.filter,
        volga_core::Filter::Trilinear | volga_core::Filter::Nearest
    ) {
        return None;
    }
    let transform = voxels.source.block_grid().transform;
    let cell = lattice.cell;
    if (transform.spacing() - DVec3::splat(cell)).abs().max_element() > 1e-12 * cell {
        return None;
    }
    let index_origin = transform.world_to_index(lattice.origin);
    let rounded = index_origin.round();
    if (index_origin - rounded).abs().max_element() > 1e-9 || !rounded.abs().cmplt(DVec3::splat(1e9)).all() {
        return None;
    }
    let first = rounded.as_ivec3() + lo;
    // Gradients from the voxels too when they are central differences of the trilinear
    // reconstruction: one more voxel on every side.
    let with_shell = voxels.filter == volga_core::Filter::Trilinear
        && voxels.gradient == volga_core::GradientMethod::CentralDifference;
    if !with_shell {
        let index_box = volga_core::IndexBox::new(first, first + n);
        let mut f32s = vec![0.0f32; (n.x * n.y * n.z) as usize];
        voxels.source.read_block(&index_box, &mut f32s);
        return Some((f32s.into_iter().map(f64::from).collect(), None));
    }
    let m = n + 2;
    let index_box = volga_core::IndexBox::new(first - 1, first + n + 1);
    let mut f32s = vec![0.0f32; (m.x * m.y * m.z) as usize];
    voxels.source.read_block(&index_box, &mut f32s);
    let mut values = Vec::with_capacity((n.x * n.y * n.z) as usize);
    for z in 1..=n.z {
        for y in 1..=n.y {
            let row = (m.x * (y + m.y * z)) as usize;
            values.extend(f32s[row + 1..row + 1 + n.x as usize].iter().map(|&v| f64::from(v)));
        }
    }
    let shell = VoxelShell {
        voxels: f32s.into(),
        spacing: transform.spacing(),
    };
    Some((values, Some(shell)))
}

/// Where world point `p` lies on the lattice edge `pa → pb` (`pb − pa` in `{0, 1}³`): the
/// fractions along each axis from `pa`, for [`BlockSamples::gradient`].
#[inline]
pub(super) fn edge_fraction(lattice: &Lattice, pa: IVec3, pb: IVec3, p: DVec3) -> DVec3 {
    let (wa, wb) = (lattice.world(pa), lattice.world(pb));
    let d = wb - wa;
    let t = ((p - wa).dot(d) / d.length_squared()).clamp(0.0, 1.0);
    (pb - pa).as_dvec3() * t
}
