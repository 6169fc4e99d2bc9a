//! The packed fast path: volumes sampled from a [`PackedVolume`] (per voxel the density
//! and its central-difference gradient, four `f32` side by side), so one trilinear fetch
//! of eight 16-byte corners gives a sample's value **and** gradient; volume rendering
//! then classifies, shades (Blinn-Phong in `f32`, per-ray constants) and composites in a
//! fused loop without calls per sample.
//!
//! Chosen automatically by [`Renderer::new`](crate::Renderer::new) when
//! [`packet_path_allowed`] holds for the integrator and settings and the field packs
//! itself ([`Field::pack`]: trilinear, central-difference sampled volumes); every other
//! field (analytic fields, CVG trees, octrees, ADFs, cubic filters, analytic gradients)
//! renders through the general path. [`Sampling::packed_path`](crate::Sampling::packed_path)
//! turns it off.
//!
//! **What it changes in the image**: sample positions, lattices, skipping and iso hits
//! are those of the general path bit for bit (values are the same `f64` trilinear
//! reconstruction of the same `f32` densities); gradients are the same central
//! differences rounded to `f32` once per voxel and interpolated in `f32`, and volume
//! rendering classifies, corrects opacity and shades in `f32`. The tests bound the
//! difference at ≤ 1/255 per channel over many random views.

use glam::{DVec3, Vec3, Vec3A, Vec4};
use volga_core::{Aabb, Field, FieldKind, Line, PackedVolume};

use crate::integrators::March;
use crate::march::{index_after, midpoint_lattice_len, BATCH};
use crate::{CellClass, Integrator, Ray, RenderSettings, RenderStats, Shader};

/// Lights the `f32` shading handles per ray (more fall back to the general path).
pub(crate) const MAX_PACKET_LIGHTS: usize = 8;

/// The one predicate of the packed path (besides the field packing itself): the
/// settings allow it ([`Sampling::packed_path`](crate::Sampling::packed_path)), the
/// mode can use it ([`Integrator::packed_path`]), it casts no shadow rays, and at most
/// [`MAX_PACKET_LIGHTS`] lights shine (all directional: the only kind today). An effect
/// the packed loops do not implement must make this false, so such images take the
/// general path.
pub(crate) fn packet_path_allowed<I: Integrator + ?Sized>(integrator: &I, settings: &RenderSettings) -> bool {
    settings.sampling.packed_path
        && integrator.packed_path()
        && !integrator.effects(settings).shadows.enabled
        && settings.lighting.lights.len() <= MAX_PACKET_LIGHTS
}

/// A field sampled through its [`PackedVolume`]: values (the same bits as the field's
/// trilinear reconstruction) and gradients from the packed copy, everything else from
/// the field. What the renderer renders when the packed path is taken.
pub(crate) struct PackedField<'a, F: ?Sized> {
    pub(crate) field: &'a F,
    pub(crate) packed: &'a PackedVolume,
}

impl<F: Field + ?Sized> Field for PackedField<'_, F> {
    fn bounds(&self) -> Aabb {
        self.field.bounds()
    }
    fn kind(&self) -> FieldKind {
        self.field.kind()
    }
    fn background(&self) -> f64 {
        self.field.background()
    }
    #[inline]
    fn value(&self, world_pos: DVec3) -> f64 {
        self.packed.value(world_pos)
    }
    /// In index space like [`volga_core::Sampled::values_along`]: the same bits.
    #[inline]
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        let transform = &self.packed.grid().transform;
        let index_origin = transform.world_to_index(line.origin);
        let index_step = line.step / transform.spacing();
        for (k, v) in out.iter_mut().enumerate() {
            *v = self
                .packed
                .value_at_index(index_origin + index_step * (first + k as u64) as f64);
        }
    }
    #[inline]
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        self.packed.gradient(world_pos)
    }
    fn gradients_at(&self, world_pos: &[DVec3], out: &mut [DVec3]) {
        for (g, p) in out.iter_mut().zip(world_pos) {
            *g = self.packed.gradient(*p);
        }
    }
    fn gradient_step(&self) -> DVec3 {
        self.field.gradient_step()
    }
    fn packed(&self) -> Option<&PackedVolume> {
        Some(self.packed)
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        self.field.value_range(world_box)
    }
    fn has_colour(&self) -> bool {
        self.field.has_colour()
    }
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        self.field.colour(world_pos)
    }
    fn sample_spacing(&self) -> f64 {
        self.field.sample_spacing()
    }
}

/// Most control points [`TransferLanes`] takes (more classify on the general path).
const MAX_LANE_POINTS: usize = 8;

/// A 1D transfer function in `f32` for the packed loop: `n + 1` segments, the first and
/// last constant (below the first and from the last control value on), so a value's
/// segment is the number of control values `≤` it (two 4-wide compares) and its RGBA
/// one lerp, without branches.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TransferLanes {
    /// The control values, padded with +∞ (never `≤` a value).
    values: [Vec4; 2],
    /// Per segment: start value, 1 / width, RGBA at the start, RGBA change over it.
    start: [f32; MAX_LANE_POINTS + 1],
    inv_width: [f32; MAX_LANE_POINTS + 1],
    rgba: [Vec4; MAX_LANE_POINTS + 1],
    delta: [Vec4; MAX_LANE_POINTS + 1],
}

impl TransferLanes {
    /// The `f32` form of sorted control points, or `None` if there are more than
    /// [`MAX_LANE_POINTS`] or a value or a segment's inverse width is not finite in
    /// `f32` (the general path then classifies).
    pub(crate) fn new(values: &[f64], rgba: &[Vec4]) -> Option<TransferLanes> {
        let n = values.len();
        if n == 0 || n > MAX_LANE_POINTS || values.iter().any(|v| !(*v as f32).is_finite()) {
            return None;
        }
        let mut padded = [f32::INFINITY; 8];
        for (p, v) in padded.iter_mut().zip(values) {
            *p = *v as f32;
        }
        let mut lanes = TransferLanes {
            values: [Vec4::from_slice(&padded[..4]), Vec4::from_slice(&padded[4..])],
            start: [0.0; MAX_LANE_POINTS + 1],
            inv_width: [0.0; MAX_LANE_POINTS + 1],
            rgba: [rgba[n - 1]; MAX_LANE_POINTS + 1],
            delta: [Vec4::ZERO; MAX_LANE_POINTS + 1],
        };
        lanes.rgba[0] = rgba[0];
        for k in 1..n {
            let inv = (1.0 / (values[k] - values[k - 1])) as f32;
            if !inv.is_finite() {
                return None;
            }
            lanes.start[k] = values[k - 1] as f32;
            lanes.inv_width[k] = inv;
            lanes.rgba[k] = rgba[k - 1];
            lanes.delta[k] = rgba[k] - rgba[k - 1];
        }
        Some(lanes)
    }

    /// RGBA at `v` (not NaN), within `f32` rounding of
    /// [`TransferFunction::eval`](crate::TransferFunction::eval).
    #[inline(always)]
    pub(crate) fn eval(&self, v: f32) -> Vec4 {
        let s = Vec4::splat(v);
        let k = (self.values[0].cmple(s).bitmask().count_ones() + self.values[1].cmple(s).bitmask().count_ones())
            as usize;
        let k = k.min(MAX_LANE_POINTS);
        let f = ((v - self.start[k]) * self.inv_width[k]).clamp(0.0, 1.0);
        (self.rgba[k] + self.delta[k] * f).clamp(Vec4::ZERO, Vec4::ONE)
    }
}

/// Blinn-Phong (survey eq. 9) in `f32` for one ray: the light directions, half vectors
/// and coefficients of the image's [`Shader`] with the view of the ray. The same
/// formula as [`Shader::shade`] term by term.
struct RayShader32 {
    count: usize,
    light: [Vec3A; MAX_PACKET_LIGHTS],
    light_colour: [Vec3A; MAX_PACKET_LIGHTS],
    half: [Vec3A; MAX_PACKET_LIGHTS],
    view: Vec3A,
    ambient: Vec3A,
    diffuse: f32,
    specular: f32,
    shininess: f32,
    integer_shininess: Option<i32>,
    min_gradient: f32,
    /// Multiplies the gradient into the outward direction (`−1` for densities).
    outward_sign: f32,
}

impl RayShader32 {
    fn new(shader: &Shader, ray_dir: DVec3, kind: FieldKind) -> RayShader32 {
        let p = shader.parts();
        let view = -ray_dir;
        let mut s = RayShader32 {
            count: p.lights.len().min(MAX_PACKET_LIGHTS),
            light: [Vec3A::ZERO; MAX_PACKET_LIGHTS],
            light_colour: [Vec3A::ZERO; MAX_PACKET_LIGHTS],
            half: [Vec3A::ZERO; MAX_PACKET_LIGHTS],
            view: view.as_vec3().into(),
            ambient: p.ambient.into(),
            diffuse: p.material.diffuse,
            specular: p.material.specular,
            shininess: p.material.shininess,
            integer_shininess: p.integer_shininess,
            min_gradient: p.min_gradient as f32,
            outward_sign: kind.outward(DVec3::ONE).x as f32,
        };
        for (k, (l, cl)) in p.lights.iter().take(MAX_PACKET_LIGHTS).enumerate() {
            s.light[k] = l.as_vec3().into();
            s.light_colour[k] = (*cl).into();
            s.half[k] = crate::camera::safe_normalize(*l + view).as_vec3().into();
        }
        s
    }

    #[inline(always)]
    fn shade(&self, colour: Vec3A, gradient: Vec3A) -> Vec3A {
        let outward = gradient * self.outward_sign;
        let len = outward.length();
        let mut n = if len.is_finite() && len > self.min_gradient {
            outward * len.recip()
        } else {
            self.view
        };
        if n.dot(self.view) < 0.0 {
            n = -n;
        }
        let mut r = self.ambient * colour;
        for k in 0..self.count {
            let n_dot_l = n.dot(self.light[k]).max(0.0);
            let n_dot_h = n.dot(self.half[k]).max(0.0);
            let highlight = match self.integer_shininess {
                Some(ns) => crate::shading::powi(n_dot_h, ns),
                None => n_dot_h.powf(self.shininess),
            };
            let cl = self.light_colour[k];
            r += cl * colour * (self.diffuse * n_dot_l) + cl * (self.specular * highlight);
        }
        r
    }
}

/// Front-to-back compositing (survey eq. 13) of the packed path: the general
/// [`Volume`](crate::Volume) loop's lattice, skipping and early termination, with each
/// sample's value and gradient from one packed fetch, classification by
/// [`TransferLanes`], opacity correction and shading in `f32`. Counters as the general
/// loop counts them (samples per run of at most [`BATCH`]; a gradient per composited
/// visible sample).
pub(crate) fn composite<F: Field + ?Sized>(
    m: &March<'_, F>,
    packed: &PackedVolume,
    tf: &TransferLanes,
    ray: &Ray,
    (t0, t1): (f64, f64),
    stats: &mut RenderStats,
) -> (Vec3, f32) {
    let n = midpoint_lattice_len(t0, t1, m.step);
    let transform = packed.grid().transform;
    let index_origin = transform.world_to_index(ray.at(t0 + 0.5 * m.step));
    let index_step = (ray.dir * m.step) / transform.spacing();
    let lit = m.shader.is_lit();
    let shader = RayShader32::new(m.shader, ray.dir, m.kind);
    let half_step = m.alpha_exponent == 0.5;
    let eta = m.early_termination_alpha;
    let mut c = Vec3A::ZERO;
    let mut a = 0.0f32;
    let mut visible = 0u64;
    // The last opacity corrected by `powf` and its correction (uniform regions repeat it).
    let mut corrected = (f32::NAN, f32::NAN);
    let mut walk = m.grid.map(|g| g.walk(ray, t0 + 0.5 * m.step));
    let mut i = 0u64;
    while i < n {
        let mut end = n;
        if let Some(w) = &mut walk {
            let t = t0 + (i as f64 + 0.5) * m.step;
            let (class, t_exit) = w.class_at(t);
            let next = index_after(t_exit, t0, m.step, 0.5, i, n);
            if class != CellClass::Active {
                stats.cells_skipped += 1;
                i = next;
                continue;
            }
            end = next;
        }
        let run_end = end.min(i + BATCH as u64);
        stats.samples += run_end - i;
        for j in i..run_end {
            let s = packed.sample4(&packed.cell_at_index(index_origin + index_step * j as f64));
            let v = s.x;
            if v.is_nan() {
                continue;
            }
            let rgba = tf.eval(v);
            let alpha = rgba.w;
            if !(alpha > 0.0) {
                continue;
            }
            // Opacity correction `1 − (1 − α)^e`: at the default step (e = ½) as
            // `α / (1 + √(1 − α))` (the same value without cancellation).
            let alpha = if alpha >= 1.0 || m.alpha_exponent == 1.0 {
                alpha
            } else if half_step {
                alpha / (1.0 + (1.0 - alpha).sqrt())
            } else {
                if corrected.0 != alpha {
                    corrected = (alpha, m.correct_alpha(alpha));
                }
                corrected.1
            };
            let colour = Vec3A::from(rgba.truncate());
            let rgb = if lit {
                visible += 1;
                shader.shade(colour, Vec3A::new(s.y, s.z, s.w))
            } else {
                colour
            };
            let w = (1.0 - a) * alpha;
            c += rgb * w;
            a += w;
            if a >= eta {
                stats.rays_terminated_early += 1;
                stats.gradient_evaluations += visible;
                return (c.into(), a);
            }
        }
        i = run_end;
    }
    stats.gradient_evaluations += visible;
    (c.into(), a)
}
