//! The light-space pre-pass for directional lights' shadows in volume rendering
//! ([`ShadowSettings::light_space`](crate::ShadowSettings::light_space)): the
//! transmittance of survey eq. 10 towards one directional light, computed once per
//! image on a regular grid of nodes over the field's bounds (spacing = the shadow step)
//! and read by trilinear interpolation at every shaded sample, instead of a shadow ray
//! per sample.
//!
//! The grid is swept slice by slice along the axis `a` where the light direction `L`
//! is largest, starting at the slice nearest the light (transmittance 1: nothing lies
//! outside the bounds). A node `p` of the next slice looks back towards the light to
//! `q = p + L·h/|L_a|`, which lies exactly on the previous slice's plane:
//! `T(p) = T(q)·(1 − α(s_mid))^(|q − p|/Δs_ref)`, with `T(q)` bilinear in the
//! previous slice (1 beyond its edges) and `α(s_mid)` the classification of the value
//! at the segment's mid-point, the opacity corrected for the segment's length exactly
//! as shadow rays correct theirs. So a light along an axis gives exactly the discrete
//! product of shadow rays from the nodes; an oblique light blurs the shadow by the
//! repeated bilinear interpolation (its error is in docs/accuracy/render_effects.md).
//! The cost is one field value per node, `O(N³)` for the whole image, against one
//! shadow ray per shaded sample.

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Aabb, Field, Line};

/// Most nodes one light volume may hold (2²⁵: 128 MiB of `f32`); a finer shadow step
/// is coarsened to stay under it.
const MAX_NODES: f64 = (1u64 << 25) as f64;

/// Transmittance towards one directional light on a grid of nodes. See the module doc.
#[derive(Debug)]
pub(crate) struct LightVolume {
    min: DVec3,
    spacing: f64,
    dims: [usize; 3],
    transmittance: Vec<f32>,
    /// Field values read to build it.
    pub(crate) samples: u64,
}

impl LightVolume {
    /// Builds the volume over `bounds` for the unit direction `towards_light`, node
    /// spacing `step` (world), `alpha(value)` the classification's opacity per
    /// reference step `reference` (world). Slices are swept in order; the nodes of a
    /// slice are computed in parallel, each a function of the previous slice alone.
    pub(crate) fn build<F: Field + ?Sized>(
        field: &F,
        bounds: &Aabb,
        towards_light: DVec3,
        step: f64,
        reference: f64,
        alpha: impl Fn(f64) -> f32 + Sync,
    ) -> LightVolume {
        let size = bounds.size();
        let mut spacing = step;
        let nodes = |h: f64| size.to_array().map(|s| (s / h).ceil() as usize + 1);
        while nodes(spacing).iter().map(|&n| n as f64).product::<f64>() > MAX_NODES {
            spacing *= 1.25;
        }
        let dims = nodes(spacing);
        let l = towards_light;
        let a = if l.x.abs() >= l.y.abs() && l.x.abs() >= l.z.abs() {
            0
        } else if l.y.abs() >= l.z.abs() {
            1
        } else {
            2
        };
        // The two other axes, slice-row order: `b` fastest.
        let (b, c) = match a {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let back = l * (spacing / l[a].abs()); // from a node to its slice's neighbour towards the light
        let length = back.length();
        let exponent = length / reference;
        let (nb, nc) = (dims[b], dims[c]);
        let mut volume = LightVolume {
            min: bounds.min,
            spacing,
            dims,
            transmittance: vec![1.0; dims[0] * dims[1] * dims[2]],
            samples: 0,
        };
        // Slice order: from the light's side.
        let slices: Vec<usize> = if l[a] > 0.0 {
            (0..dims[a]).rev().collect()
        } else {
            (0..dims[a]).collect()
        };
        let mut previous = vec![1.0f32; nb * nc];
        let mut current = vec![0.0f32; nb * nc];
        for (n, &k) in slices.iter().enumerate() {
            if n == 0 {
                volume.store_slice(a, b, c, k, &previous);
                continue;
            }
            current.par_chunks_mut(nb).enumerate().for_each(|(jc, row)| {
                let mut node = DVec3::ZERO;
                node[a] = bounds.min[a] + k as f64 * spacing;
                node[b] = bounds.min[b];
                node[c] = bounds.min[c] + jc as f64 * spacing;
                let mut step_b = DVec3::ZERO;
                step_b[b] = spacing;
                let line = Line {
                    origin: node + back * 0.5,
                    step: step_b,
                };
                let mut values = vec![0.0f64; nb];
                field.values_along(&line, 0, &mut values);
                for (jb, t) in row.iter_mut().enumerate() {
                    // q in the previous slice's (b, c) node coordinates.
                    let qb = jb as f64 + back[b] / spacing;
                    let qc = jc as f64 + back[c] / spacing;
                    let t_prev = bilinear(&previous, nb, nc, qb, qc);
                    let v = values[jb];
                    let alpha = if v.is_nan() { 0.0 } else { alpha(v) };
                    let seg = if alpha <= 0.0 {
                        1.0
                    } else if alpha >= 1.0 {
                        0.0
                    } else {
                        (1.0 - alpha as f64).powf(exponent)
                    };
                    *t = (t_prev as f64 * seg) as f32;
                }
            });
            volume.samples += (nb * nc) as u64;
            volume.store_slice(a, b, c, k, &current);
            std::mem::swap(&mut previous, &mut current);
        }
        volume
    }

    fn store_slice(&mut self, a: usize, b: usize, c: usize, k: usize, slice: &[f32]) {
        let [nx, ny, _] = self.dims;
        let (nb, nc) = (self.dims[b], self.dims[c]);
        for jc in 0..nc {
            for jb in 0..nb {
                let mut ijk = [0usize; 3];
                ijk[a] = k;
                ijk[b] = jb;
                ijk[c] = jc;
                self.transmittance[ijk[0] + nx * (ijk[1] + ny * ijk[2])] = slice[jb + nb * jc];
            }
        }
    }

    /// Transmittance at world position `p`: trilinear between the nodes, clamped to
    /// the grid.
    #[inline]
    pub(crate) fn at(&self, p: DVec3) -> f32 {
        let [nx, ny, nz] = self.dims;
        let f = (p - self.min) / self.spacing;
        let mut base = [0usize; 3];
        let mut w = [0.0f64; 3];
        for (axis, n) in [nx, ny, nz].into_iter().enumerate() {
            let x = if f[axis] > 0.0 { f[axis] } else { 0.0 };
            let i = (x as usize).min(n.saturating_sub(2));
            base[axis] = i;
            w[axis] = if n < 2 { 0.0 } else { (x - i as f64).min(1.0) };
        }
        let idx = |x: usize, y: usize, z: usize| {
            self.transmittance[x.min(nx - 1) + nx * (y.min(ny - 1) + ny * z.min(nz - 1))] as f64
        };
        let [x, y, z] = base;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = lerp(idx(x, y, z), idx(x + 1, y, z), w[0]);
        let c10 = lerp(idx(x, y + 1, z), idx(x + 1, y + 1, z), w[0]);
        let c01 = lerp(idx(x, y, z + 1), idx(x + 1, y, z + 1), w[0]);
        let c11 = lerp(idx(x, y + 1, z + 1), idx(x + 1, y + 1, z + 1), w[0]);
        lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2]) as f32
    }
}

/// Bilinear interpolation in a slice of `nb × nc` nodes (`b` fastest) at node
/// coordinates `(qb, qc)`; 1 (no attenuation) beyond the slice's edges.
#[inline]
fn bilinear(slice: &[f32], nb: usize, nc: usize, qb: f64, qc: f64) -> f32 {
    let eps = 1e-9;
    if !(qb >= -eps && qc >= -eps && qb <= (nb - 1) as f64 + eps && qc <= (nc - 1) as f64 + eps) {
        return 1.0;
    }
    let (qb, qc) = (qb.clamp(0.0, (nb - 1) as f64), qc.clamp(0.0, (nc - 1) as f64));
    let (ib, ic) = (
        (qb as usize).min(nb.saturating_sub(2)),
        (qc as usize).min(nc.saturating_sub(2)),
    );
    let (wb, wc) = ((qb - ib as f64) as f32, (qc - ic as f64) as f32);
    let at = |x: usize, y: usize| slice[x.min(nb - 1) + nb * y.min(nc - 1)];
    let top = at(ib, ic) + (at(ib + 1, ic) - at(ib, ic)) * wb;
    let bottom = at(ib, ic + 1) + (at(ib + 1, ic + 1) - at(ib, ic + 1)) * wb;
    top + (bottom - top) * wc
}

#[cfg(test)]
mod tests {
    use glam::Vec4;

    use super::*;
    use crate::{LightId, RenderSettings, RenderStats, Renderer, TransferFunction, Volume};

    /// Density 1 in the slab `a ≤ x ≤ b` of the box ±4 (spacing 0.1), 0 elsewhere.
    struct Slab {
        a: f64,
        b: f64,
    }

    impl Field for Slab {
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-4.0), DVec3::splat(4.0))
        }
        fn value(&self, p: DVec3) -> f64 {
            if (self.a..=self.b).contains(&p.x) {
                1.0
            } else {
                0.0
            }
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(0.1)
        }
        fn value_range(&self, _: &Aabb) -> (f64, f64) {
            (0.0, 1.0)
        }
    }

    fn settings(direction: DVec3, light_space: bool) -> RenderSettings {
        let mut s = RenderSettings::new(4, 4);
        s.lighting.lights[0].direction = direction;
        s.lighting.shadows.casters = vec![LightId::Directional(0)];
        s.lighting.shadows.min_transmittance = 0.0;
        s.lighting.shadows.light_space = light_space;
        s
    }

    #[test]
    fn an_axis_light_gives_the_shadow_rays_product_at_the_nodes() {
        let field = Slab { a: -1.05, b: 0.62 };
        let tf = TransferFunction::new(vec![(0.0, Vec4::ZERO), (1.0, Vec4::new(1.0, 1.0, 1.0, 0.2))]).unwrap();
        let volume = Volume::new(tf.clone(), false);
        let s = settings(DVec3::X, true);
        let r = Renderer::new(&field, &volume, &s).unwrap();
        let m = r.march(&field);
        let lv = m.light_volumes[0].as_ref().expect("built");
        assert!(r.light_space_samples() > 0);
        for i in [0, 5, 17, 29, 33, 60] {
            let p = DVec3::new(-4.0 + i as f64 * 0.1, 0.3, -0.2);
            let mut stats = RenderStats::default();
            let ray = crate::shadow::transmittance(&m, &tf, p, DVec3::X, f64::INFINITY, &mut stats);
            let grid = lv.at(p);
            assert!(
                (ray - grid).abs() <= 1e-5 * ray.max(1e-3),
                "x = {}: ray {ray}, grid {grid}",
                p.x
            );
        }
        // No pre-pass without light_space, nor for a light that casts no shadows.
        let off = settings(DVec3::X, false);
        let r = Renderer::new(&field, &volume, &off).unwrap();
        assert_eq!(r.light_space_samples(), 0);
    }

    #[test]
    fn an_oblique_light_attenuates_by_the_path_through_the_slab() {
        let (a, b) = (-0.5, 0.3);
        let field = Slab { a, b };
        let tf = TransferFunction::new(vec![(0.0, Vec4::ZERO), (1.0, Vec4::new(1.0, 1.0, 1.0, 0.1))]).unwrap();
        let volume = Volume::new(tf, false);
        let dir = DVec3::new(1.0, 0.5, 0.3).normalize();
        let s = settings(dir, true);
        let r = Renderer::new(&field, &volume, &s).unwrap();
        let m = r.march(&field);
        let lv = m.light_volumes[0].as_ref().unwrap();
        // μ per world unit, and the path (b − a)/L_x through the slab.
        let mu = -(0.9f64).ln() / 0.1;
        let exact = (-mu * (b - a) / dir.x).exp();
        for p in [DVec3::new(-1.5, -1.0, -0.5), DVec3::new(-0.9, -0.4, 0.2)] {
            let t = lv.at(p) as f64;
            // Half a shadow step of path at each end of the slab.
            let tol = (mu * 0.1 / dir.x).exp();
            assert!(t <= exact * tol && t >= exact / tol, "{p}: {t} vs {exact}");
        }
        // Beyond the slab, towards the light, nothing is in the way.
        assert!((lv.at(DVec3::new(1.0, 0.0, 0.0)) - 1.0).abs() < 1e-6);
    }
}
