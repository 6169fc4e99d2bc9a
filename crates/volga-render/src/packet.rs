//! The packed fast path of volume rendering: a [`PackedVolume`] (per voxel the density
//! and its central-difference gradient, four `f32` side by side), so one trilinear fetch
//! of eight 16-byte corners gives a sample's value **and** gradient; the samples of a
//! ray are taken eight at a time and classified, opacity-corrected and shaded
//! (Blinn-Phong, per-ray constants) in 8 `f32` lanes, then composited in lanes too
//! (front to back as a product scan, [`composite_packet`]).
//!
//! Chosen automatically by [`Renderer::new`](crate::Renderer::new) when
//! [`packet_path_allowed`] holds for the integrator and settings (today: shaded or unlit
//! DVR with a 1D transfer function taking its colour from it) and the field packs itself
//! ([`Field::pack`]: trilinear, central-difference sampled volumes); every other field
//! (analytic fields, CVG trees, octrees, ADFs, cubic filters, analytic gradients) and
//! mode renders through the general path, except iso-surfaces, which march the same
//! packed copy cell by cell (`iso_packed.rs`).
//! [`Sampling::packed_path`](crate::Sampling::packed_path) turns it off.
//!
//! **What it changes in the image**: the lattice, skipping and early termination are the
//! general loop's; values are the same trilinear reconstruction of the same `f32`
//! densities (in `f32`), gradients the same central differences rounded to `f32` once
//! per voxel and interpolated in `f32`, and classification, opacity correction and
//! shading run in `f32`. The tests bound the difference at ≤ 1/255 per channel over many
//! random views (`tests/packed.rs`).

use glam::{DVec3, Vec3, Vec4};
use volga_core::{Aabb, Field, FieldKind, Line, PackedVolume};

use crate::integrators::March;
use crate::march::midpoint_lattice_len;
use crate::sample_walk::{non_outside_span, SampleWalk};
use crate::{CellClass, Integrator, Ray, RenderSettings, RenderStats, Shader};

/// Lights the `f32` shading handles per ray (more fall back to the general path).
pub(crate) const MAX_PACKET_LIGHTS: usize = 8;

/// The one predicate of the packed path (besides the field packing itself): the
/// settings allow it ([`Sampling::packed_path`](crate::Sampling::packed_path)), the
/// mode can use it ([`Integrator::packed_path`]), it casts no shadow rays, no point light shines
/// ([`Lighting::is_plain`](crate::Lighting::is_plain)), pre-integration is off, and at
/// most [`MAX_PACKET_LIGHTS`] directional lights shine. An effect
/// the packed loops do not implement must make this false, so such images take the
/// general path.
pub(crate) fn packet_path_allowed<I: Integrator + ?Sized>(integrator: &I, settings: &RenderSettings) -> bool {
    settings.sampling.packed_path
        && integrator.packed_path()
        && !integrator.effects(settings).shadows.enabled
        && settings.lighting.lights.len() <= MAX_PACKET_LIGHTS
        && settings.lighting.is_plain()
        && !settings.sampling.pre_integration
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

/// A 1D transfer function in `f32` for the packed loop, as tables of at most eight
/// entries: with control values `c₀ < … < c_{n−1}`, colours `q₀ … q_{n−1}` and slopes
/// `s_k = (q_{k+1} − q_k) / (c_{k+1} − c_k)`, a value `v` is clamped to `[c₀, c_{n−1}]`,
/// its segment `k` is the number of control values `c₁ … c_{n−1}` at most `v` (the
/// last, `k = n − 1`, is the constant `q_{n−1}` with slope 0), and
///
/// `tf(v) = q_k + s_k · (v − c_k)`,
///
/// the same piecewise-linear function (constant below `c₀` and from `c_{n−1}` on) as
/// [`TransferFunction::eval`](crate::TransferFunction::eval). Every lane runs the same
/// instructions whatever segment its value falls in: `n − 1` comparisons, then one
/// table look-up per quantity (in AVX2 a lane permutation, [`TransferLanes::classify_avx2`]).
/// Every control point's own value gives its colour exactly (`q_k + s_k · 0`), so a
/// value in a segment transparent at both ends is transparent exactly, as empty-space
/// skipping assumes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TransferLanes {
    /// Control points, `1 ..= MAX_LANE_POINTS`.
    points: usize,
    /// The control values (entries from `points` on repeat the last).
    value: [f32; MAX_LANE_POINTS],
    /// Per channel (RGBA): the colour at each control value.
    colour: [[f32; MAX_LANE_POINTS]; 4],
    /// Per channel: the slope of the segment starting at each control value (0 from
    /// the last on).
    slope: [[f32; MAX_LANE_POINTS]; 4],
}

impl TransferLanes {
    /// The `f32` form of sorted control points, or `None` if there are more than
    /// [`MAX_LANE_POINTS`] or a value or a segment's slope is not finite in `f32`, or
    /// two values round to one `f32` (the general path then classifies).
    pub(crate) fn new(values: &[f64], rgba: &[Vec4]) -> Option<TransferLanes> {
        let n = values.len();
        if n == 0 || n > MAX_LANE_POINTS || values.iter().any(|v| !(*v as f32).is_finite()) {
            return None;
        }
        let mut lanes = TransferLanes {
            points: n,
            value: [values[n - 1] as f32; MAX_LANE_POINTS],
            colour: [[0.0; MAX_LANE_POINTS]; 4],
            slope: [[0.0; MAX_LANE_POINTS]; 4],
        };
        for k in 0..n {
            lanes.value[k] = values[k] as f32;
            for (ch, colour) in lanes.colour.iter_mut().enumerate() {
                colour[k] = rgba[k][ch];
            }
            if k + 1 < n {
                let (lo, hi) = (values[k] as f32, values[k + 1] as f32);
                let slope = ((rgba[k + 1] - rgba[k]).as_dvec4() / (values[k + 1] - values[k])).as_vec4();
                if !(hi > lo && slope.is_finite()) {
                    return None;
                }
                for ch in 0..4 {
                    lanes.slope[ch][k] = slope[ch];
                }
            }
        }
        Some(lanes)
    }

    /// RGBA (unclamped) of eight values, per channel. NaN values classify as `c₀`.
    // Index loops over the lanes on purpose: they are what the compiler vectorizes.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn classify(&self, v: &[f32; LANES]) -> [[f32; LANES]; 4] {
        let (first, last) = (self.value[0], self.value[self.points - 1]);
        let mut rgba = [[0.0f32; LANES]; 4];
        for l in 0..LANES {
            // `f32::max` returns the other operand for NaN, as `maxps` does.
            let x = v[l].max(first).min(last);
            let mut k = 0;
            for inner in 1..self.points {
                k += (x >= self.value[inner]) as usize;
            }
            let d = x - self.value[k];
            for ch in 0..4 {
                rgba[ch][l] = self.colour[ch][k] + self.slope[ch][k] * d;
            }
        }
        rgba
    }

    /// [`TransferLanes::classify`] in AVX2 vectors, the table look-ups as lane
    /// permutations: the same operations, the same bits.
    ///
    /// # Safety
    /// As [`PackedVolume::sample_lanes_avx2`]: the CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn classify_avx2(&self, v: &[f32; LANES]) -> [[f32; LANES]; 4] {
        use std::arch::x86_64::*;
        // SAFETY: every load and store below is of an `[f32; 8]`, 32 bytes, unaligned.
        unsafe {
            let x = _mm256_loadu_ps(v.as_ptr());
            // `maxps` returns its second operand when either is NaN: NaN → `c₀`.
            let x = _mm256_max_ps(x, _mm256_set1_ps(self.value[0]));
            let x = _mm256_min_ps(x, _mm256_set1_ps(self.value[self.points - 1]));
            let mut k = _mm256_setzero_si256();
            for inner in 1..self.points {
                let at_least = _mm256_cmp_ps::<_CMP_GE_OQ>(x, _mm256_set1_ps(self.value[inner]));
                // A true comparison is all ones, −1 as an integer.
                k = _mm256_sub_epi32(k, _mm256_castps_si256(at_least));
            }
            let table = |t: &[f32; LANES]| _mm256_permutevar8x32_ps(_mm256_loadu_ps(t.as_ptr()), k);
            let d = _mm256_sub_ps(x, table(&self.value));
            let mut rgba = [[0.0f32; LANES]; 4];
            for ((out, colour), slope) in rgba.iter_mut().zip(&self.colour).zip(&self.slope) {
                let c = _mm256_add_ps(table(colour), _mm256_mul_ps(table(slope), d));
                _mm256_storeu_ps(out.as_mut_ptr(), c);
            }
            rgba
        }
    }
}

/// Samples per packet: eight consecutive samples of one ray, in `f32` lanes.
const LANES: usize = 8;

/// Blinn-Phong (survey eq. 9) in `f32` for one ray: the light directions, half vectors
/// and coefficients of the image's [`Shader`] with the view of the ray, as per-ray
/// constants of the packet loop. The same formula as [`Shader::shade`] term by term.
#[derive(Debug)]
struct RayShader32 {
    count: usize,
    light: [Vec3; MAX_PACKET_LIGHTS],
    light_colour: [Vec3; MAX_PACKET_LIGHTS],
    half: [Vec3; MAX_PACKET_LIGHTS],
    view: Vec3,
    ambient: Vec3,
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
            light: [Vec3::ZERO; MAX_PACKET_LIGHTS],
            light_colour: [Vec3::ZERO; MAX_PACKET_LIGHTS],
            half: [Vec3::ZERO; MAX_PACKET_LIGHTS],
            view: view.as_vec3(),
            ambient: p.ambient,
            diffuse: p.material.diffuse,
            specular: p.material.specular,
            shininess: p.material.shininess,
            integer_shininess: p.integer_shininess,
            min_gradient: p.min_gradient as f32,
            outward_sign: kind.outward(DVec3::ONE).x as f32,
        };
        for (k, (l, cl)) in p.lights.iter().take(MAX_PACKET_LIGHTS).enumerate() {
            s.light[k] = l.as_vec3();
            s.light_colour[k] = *cl;
            s.half[k] = crate::camera::safe_normalize(*l + view).as_vec3();
        }
        s
    }
}

/// `x^n` per lane by repeated squaring (the exponent is the same in every lane, so
/// the loop is uniform and the lanes vectorize); the algorithm of
/// [`powi`](crate::shading::powi).
#[inline(always)]
fn powi_lanes(mut x: [f32; LANES], n: i32) -> [f32; LANES] {
    // Shininess exponents are in 0..=1024 (`Shader`); unsigned halving is one shift.
    let mut n = n.max(0) as u32;
    let mut r = [1.0f32; LANES];
    loop {
        if n & 1 != 0 {
            for l in 0..LANES {
                r[l] *= x[l];
            }
        }
        n >>= 1;
        if n == 0 {
            return r;
        }
        for v in x.iter_mut() {
            *v *= *v;
        }
    }
}

/// One packet's classified and shaded samples: opacity (0 where invisible) and RGB.
#[derive(Clone, Debug)]
struct Shaded {
    alpha: [f32; LANES],
    rgb: [[f32; LANES]; 3],
}

/// The per-ray constants of the packet loop.
struct RayPackets<'a> {
    packed: &'a PackedVolume,
    tf: &'a TransferLanes,
    shader: RayShader32,
    lit: bool,
    /// Opacity correction `1 − (1 − α)^e` in the lanes: `e = ½` (the default step) as
    /// `1 − √(1 − α)` (absolute error ≤ 2⁻²⁴; the division of the cancellation-free
    /// `α / (1 + √(1 − α))` cost more than it saved), `e = 1` as is; other exponents
    /// are corrected per sample afterwards.
    half_step: bool,
    /// Index position of sample 0 and the step between samples, in `f32` (index
    /// coordinates stay below 2²⁴ with sub-voxel error ~1e-5 at 256 voxels).
    index_origin: [f32; 3],
    index_step: [f32; 3],
}

/// Cells located ahead of the packet loop ([`RayPackets::shade`]): per slot, the
/// first sample index of the packet and its cells.
struct Ahead {
    #[cfg(target_arch = "x86_64")]
    cells: [(u64, volga_core::LaneCells); 2],
}

impl RayPackets<'_> {
    /// Index positions of samples `j .. j + 8`.
    // Index loops over the lanes on purpose: they are what the compiler vectorizes.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn positions(&self, j: u64) -> [[f32; LANES]; 3] {
        let mut index_pos = [[0.0f32; LANES]; 3];
        for a in 0..3 {
            for l in 0..LANES {
                // Exact: sample indices stay below `MAX_SAMPLES_PER_RAY` = 2²⁴.
                index_pos[a][l] = self.index_origin[a] + self.index_step[a] * ((j as i32 + l as i32) as f32);
            }
        }
        index_pos
    }

    /// Samples `j .. j + 8`: values and gradients from one packed fetch each (4-wide
    /// over `[v, gx, gy, gz]`), then classification, opacity correction and shading
    /// 8-wide across the samples, every lane a function of its sample index alone.
    // Index loops over the lanes on purpose: they are what the compiler vectorizes.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn shade<const AVX2: bool>(&self, j: u64, ahead: &mut Ahead) -> Shaded {
        #[cfg(target_arch = "x86_64")]
        let (v, g) = if AVX2 {
            // The cells of this packet, located two packets ago if the ray came through
            // them (the same positions, so the same bits); then those of the packet two
            // ahead, prefetched and kept for it.
            let slot = ((j / LANES as u64) & 1) as usize;
            // SAFETY (the three blocks): `AVX2` is true only in `composite_avx2`, called
            // after `is_x86_feature_detected!("avx2")` held.
            if ahead.cells[slot].0 != j {
                ahead.cells[slot] = (j, unsafe { self.packed.cells_avx2(&self.positions(j)) });
            }
            // Sampled from the slot in place: a copy was split into scalar moves.
            let sampled = unsafe { self.packed.sample_cells_avx2(&ahead.cells[slot].1) };
            let next = j + 2 * LANES as u64;
            ahead.cells[slot] = (next, unsafe { self.packed.cells_avx2(&self.positions(next)) });
            unsafe { self.packed.prefetch_cells_avx2(&ahead.cells[slot].1) };
            sampled
        } else {
            self.packed.sample_lanes(&self.positions(j))
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (v, g) = {
            let _ = ahead;
            self.packed.sample_lanes(&self.positions(j))
        };
        // Classification: one table look-up per quantity (see `TransferLanes`).
        #[cfg(target_arch = "x86_64")]
        let rgba = if AVX2 {
            // SAFETY: as the sampling above.
            unsafe { self.tf.classify_avx2(&v) }
        } else {
            self.tf.classify(&v)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let rgba = self.tf.classify(&v);
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: as the sampling above.
            return unsafe { light_avx2(&self.shader, self.lit, self.half_step, &v, &g, &rgba) };
        }
        light(&self.shader, self.lit, self.half_step, &v, &g, &rgba)
    }
}

/// Opacity correction and shading of a packet's classified samples (`rgba` at values
/// `v`, gradients `g`): colours and opacity clamped to `[0, 1]`, NaN values invisible,
/// the opacity corrected to the half step as `1 − √(1 − α)` when `half_step` (the
/// others are corrected by the caller), then, when `lit`, Blinn-Phong with the outward
/// normal flipped towards the viewer (two-sided). A packet with no visible sample is
/// not shaded (the compositing skips invisible lanes whatever their colour).
///
/// [`light_avx2`] is the same operations in AVX2 vectors, in the same order: the same
/// bits. (Left to the compiler, this loop's vectorization changed with small edits to
/// it: the opacity correction without a division scalarized the shading, 18 % slower.)
// Index loops over the lanes on purpose: they are what the compiler vectorizes.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn light(
    sh: &RayShader32,
    lit: bool,
    half_step: bool,
    v: &[f32; LANES],
    g: &[[f32; LANES]; 3],
    rgba: &[[f32; LANES]; 4],
) -> Shaded {
    let mut out = Shaded {
        alpha: [0.0; LANES],
        rgb: [[0.0; LANES]; 3],
    };
    let mut colour = [[0.0f32; LANES]; 3];
    for l in 0..LANES {
        for ch in 0..3 {
            colour[ch][l] = rgba[ch][l].clamp(0.0, 1.0);
        }
        let a = rgba[3][l].clamp(0.0, 1.0);
        // NaN values are invisible.
        let a = if v[l].is_nan() { 0.0 } else { a };
        out.alpha[l] = if half_step && a < 1.0 {
            1.0 - (1.0 - a).sqrt()
        } else {
            a
        };
    }
    if !lit {
        out.rgb = colour;
        return out;
    }
    // A packet with no visible sample needs no shading (the compositing skips
    // invisible lanes whatever their colour).
    if !out.alpha.iter().any(|a| *a > 0.0) {
        return out;
    }
    // Blinn-Phong with the outward normal flipped towards the viewer (two-sided).
    let mut n = [[0.0f32; LANES]; 3];
    for l in 0..LANES {
        let o = [
            g[0][l] * sh.outward_sign,
            g[1][l] * sh.outward_sign,
            g[2][l] * sh.outward_sign,
        ];
        let len = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
        let ok = len.is_finite() && len > sh.min_gradient;
        let r = 1.0 / len;
        let mut q = if ok {
            [o[0] * r, o[1] * r, o[2] * r]
        } else {
            sh.view.to_array()
        };
        if q[0] * sh.view.x + q[1] * sh.view.y + q[2] * sh.view.z < 0.0 {
            q = [-q[0], -q[1], -q[2]];
        }
        for a in 0..3 {
            n[a][l] = q[a];
        }
    }
    for ch in 0..3 {
        for l in 0..LANES {
            out.rgb[ch][l] = sh.ambient[ch] * colour[ch][l];
        }
    }
    for k in 0..sh.count {
        let (ld, hd, cl) = (sh.light[k], sh.half[k], sh.light_colour[k]);
        let mut n_dot_l = [0.0f32; LANES];
        let mut n_dot_h = [0.0f32; LANES];
        for l in 0..LANES {
            // `x > 0 ? x : 0` (NaN and −0 give +0), as `maxps` does.
            let dl = n[0][l] * ld.x + n[1][l] * ld.y + n[2][l] * ld.z;
            let dh = n[0][l] * hd.x + n[1][l] * hd.y + n[2][l] * hd.z;
            n_dot_l[l] = if dl > 0.0 { dl } else { 0.0 };
            n_dot_h[l] = if dh > 0.0 { dh } else { 0.0 };
        }
        let highlight = match sh.integer_shininess {
            Some(ns) => powi_lanes(n_dot_h, ns),
            None => n_dot_h.map(|x| x.powf(sh.shininess)),
        };
        for ch in 0..3 {
            for l in 0..LANES {
                out.rgb[ch][l] +=
                    cl[ch] * colour[ch][l] * (sh.diffuse * n_dot_l[l]) + cl[ch] * (sh.specular * highlight[l]);
            }
        }
    }
    out
}

/// [`light`] in AVX2 vectors: the same operations in the same order, so the same bits
/// (`maxps`/`minps` with the value as second operand keep NaN as `f32::clamp` does).
///
/// # Safety
/// The CPU must support AVX2 (and the caller be compiled for it, as
/// [`PackedVolume::sample_lanes_avx2`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn light_avx2(
    sh: &RayShader32,
    lit: bool,
    half_step: bool,
    v: &[f32; LANES],
    g: &[[f32; LANES]; 3],
    rgba: &[[f32; LANES]; 4],
) -> Shaded {
    use std::arch::x86_64::*;
    // SAFETY (every load and store below): each is of an `[f32; 8]`, 32 bytes;
    // unaligned.
    let load = |x: &[f32; LANES]| unsafe { _mm256_loadu_ps(x.as_ptr()) };
    let store = |x: &mut [f32; LANES], y: __m256| unsafe { _mm256_storeu_ps(x.as_mut_ptr(), y) };
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    // `f32::clamp(x, 0, 1)`: `maxps`/`minps` return the second operand if either is
    // NaN (so NaN stays NaN) or both are zeros (so −0 stays −0).
    let clamp01 = |x: __m256| _mm256_min_ps(one, _mm256_max_ps(zero, x));
    let colour = [
        clamp01(load(&rgba[0])),
        clamp01(load(&rgba[1])),
        clamp01(load(&rgba[2])),
    ];
    let value = load(v);
    let a = _mm256_blendv_ps(
        clamp01(load(&rgba[3])),
        zero,
        _mm256_cmp_ps::<_CMP_UNORD_Q>(value, value),
    );
    let alpha = if half_step {
        let corrected = _mm256_sub_ps(one, _mm256_sqrt_ps(_mm256_sub_ps(one, a)));
        _mm256_blendv_ps(a, corrected, _mm256_cmp_ps::<_CMP_LT_OQ>(a, one))
    } else {
        a
    };
    let mut out = Shaded {
        alpha: [0.0; LANES],
        rgb: [[0.0; LANES]; 3],
    };
    store(&mut out.alpha, alpha);
    if !lit {
        for (o, c) in out.rgb.iter_mut().zip(colour) {
            store(o, c);
        }
        return out;
    }
    if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(alpha, zero)) == 0 {
        return out;
    }
    let sign = _mm256_set1_ps(sh.outward_sign);
    let o = [
        _mm256_mul_ps(load(&g[0]), sign),
        _mm256_mul_ps(load(&g[1]), sign),
        _mm256_mul_ps(load(&g[2]), sign),
    ];
    let dot = |x: &[__m256; 3], d: Vec3| {
        _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(x[0], _mm256_set1_ps(d.x)),
                _mm256_mul_ps(x[1], _mm256_set1_ps(d.y)),
            ),
            _mm256_mul_ps(x[2], _mm256_set1_ps(d.z)),
        )
    };
    let len = _mm256_sqrt_ps(_mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(o[0], o[0]), _mm256_mul_ps(o[1], o[1])),
        _mm256_mul_ps(o[2], o[2]),
    ));
    // Finite (`len ≥ 0` or NaN) and above the smallest gradient shaded.
    let ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LT_OQ>(len, _mm256_set1_ps(f32::INFINITY)),
        _mm256_cmp_ps::<_CMP_GT_OQ>(len, _mm256_set1_ps(sh.min_gradient)),
    );
    let r = _mm256_div_ps(one, len);
    let view = sh.view.to_array();
    // Written out per axis: `array::map` over vectors compiles to out-of-line calls of
    // the intrinsics (its closure is not compiled for AVX2).
    let pick = |c: usize| _mm256_blendv_ps(_mm256_set1_ps(view[c]), _mm256_mul_ps(o[c], r), ok);
    let q = [pick(0), pick(1), pick(2)];
    // `−q` where the normal faces away from the viewer: the sign bit flipped.
    let flip = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LT_OQ>(dot(&q, sh.view), zero),
        _mm256_set1_ps(-0.0),
    );
    let n = [
        _mm256_xor_ps(q[0], flip),
        _mm256_xor_ps(q[1], flip),
        _mm256_xor_ps(q[2], flip),
    ];
    let ambient = |c: usize| _mm256_mul_ps(_mm256_set1_ps(sh.ambient[c]), colour[c]);
    let mut rgb = [ambient(0), ambient(1), ambient(2)];
    let (diffuse, specular) = (_mm256_set1_ps(sh.diffuse), _mm256_set1_ps(sh.specular));
    for k in 0..sh.count {
        let (ld, hd, cl) = (sh.light[k], sh.half[k], sh.light_colour[k]);
        // `maxps(x, 0)`: `x > 0 ? x : 0`.
        let n_dot_l = _mm256_max_ps(dot(&n, ld), zero);
        let n_dot_h = _mm256_max_ps(dot(&n, hd), zero);
        let highlight = match sh.integer_shininess {
            Some(ns) => {
                // `powi_lanes`: repeated squaring, the same products in the same order.
                let mut e = ns.max(0) as u32;
                let (mut x, mut p) = (n_dot_h, one);
                loop {
                    if e & 1 != 0 {
                        p = _mm256_mul_ps(p, x);
                    }
                    e >>= 1;
                    if e == 0 {
                        break p;
                    }
                    x = _mm256_mul_ps(x, x);
                }
            }
            None => {
                let mut h = [0.0f32; LANES];
                store(&mut h, n_dot_h);
                load(&h.map(|x| x.powf(sh.shininess)))
            }
        };
        let spec = _mm256_mul_ps(specular, highlight);
        let diff = _mm256_mul_ps(diffuse, n_dot_l);
        for c in 0..3 {
            let cl = _mm256_set1_ps(cl[c]);
            rgb[c] = _mm256_add_ps(
                rgb[c],
                _mm256_add_ps(
                    _mm256_mul_ps(_mm256_mul_ps(cl, colour[c]), diff),
                    _mm256_mul_ps(cl, spec),
                ),
            );
        }
    }
    for (o, c) in out.rgb.iter_mut().zip(rgb) {
        store(o, c);
    }
    out
}

/// Front-to-back compositing (survey eq. 13) of the packed path: the general
/// [`Volume`](crate::Volume) loop's lattice, skipping and early termination, the
/// samples of each active cell taken in packets of eight consecutive lattice indices
/// starting at multiples of eight ([`RayPackets::shade`]; the first and last packet of
/// a cell run into its neighbours, whose transparent samples add nothing) and each
/// packet composited at once ([`composite_packet`]). A packet holds the same samples
/// whatever was skipped before it, so skipping changes no bit. Counters: every sample
/// read (a few more than the general loop, which stops each run at its cell's
/// borders), a gradient per composited visible sample.
///
/// On x86-64 CPUs with AVX2 and FMA the loop is compiled for them (8-wide `f32` lanes);
/// elsewhere the same code runs with the baseline instructions. Both evaluate the same
/// operations in the same order (no fused multiply-adds are written), so the image
/// does not depend on which runs.
pub(crate) fn composite<F: Field + ?Sized>(
    m: &March<'_, F>,
    packed: &PackedVolume,
    tf: &TransferLanes,
    ray: &Ray,
    interval: (f64, f64),
    stats: &mut RenderStats,
) -> (Vec3, f32) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA (checked just above), the one
        // requirement for calling a function compiled with those features.
        // Measured reason: see docs/BENCHMARKS.md (the packed path's AVX2 row).
        return unsafe { composite_avx2(m, packed, tf, ray, interval, stats) };
    }
    composite_lanes::<F, false>(m, packed, tf, ray, interval, stats)
}

/// [`composite_lanes`] compiled for AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn composite_avx2<F: Field + ?Sized>(
    m: &March<'_, F>,
    packed: &PackedVolume,
    tf: &TransferLanes,
    ray: &Ray,
    interval: (f64, f64),
    stats: &mut RenderStats,
) -> (Vec3, f32) {
    composite_lanes::<F, true>(m, packed, tf, ray, interval, stats)
}

#[inline(always)]
fn composite_lanes<F: Field + ?Sized, const AVX2: bool>(
    m: &March<'_, F>,
    packed: &PackedVolume,
    tf: &TransferLanes,
    ray: &Ray,
    (t0, t1): (f64, f64),
    stats: &mut RenderStats,
) -> (Vec3, f32) {
    let n = midpoint_lattice_len(t0, t1, m.step);
    // With skipping, only the samples in the box of the cells that are not Outside are
    // read (`non_outside_span`); packets stay aligned to the lattice, so no bit changes.
    let (first, last) = match m.grid {
        None => (0, n),
        Some(g) => match non_outside_span(g, ray, t0, m.step, n) {
            Some(span) => span,
            None => {
                // The ray meets Outside cells only: nothing is composited.
                stats.cells_skipped += 1;
                return (Vec3::ZERO, 0.0);
            }
        },
    };
    let transform = packed.grid().transform;
    let lit = m.shader.is_lit();
    let half_step = m.alpha_exponent == 0.5;
    let per_sample_correction = !(half_step || m.alpha_exponent == 1.0);
    let packets = RayPackets {
        packed,
        tf,
        shader: RayShader32::new(m.shader, ray.dir, m.kind),
        lit,
        half_step,
        index_origin: transform.world_to_index(ray.at(t0 + 0.5 * m.step)).as_vec3().to_array(),
        index_step: ((ray.dir * m.step) / transform.spacing()).as_vec3().to_array(),
    };
    let eta = m.early_termination_alpha;
    // Transmittance in front of the next packet, and per lane the colour it added.
    let mut transmittance = 1.0f32;
    let mut sums = [[0.0f32; LANES]; 3];
    let mut visible = 0u64;
    // The last opacity corrected by `powf` and its correction (uniform regions repeat it).
    let mut corrected = (f32::NAN, f32::NAN);
    let mut walk = m
        .grid
        .map(|g| SampleWalk::new(g, ray, t0 + 0.5 * m.step, m.step, first));
    let mut ahead = Ahead {
        #[cfg(target_arch = "x86_64")]
        cells: [(u64::MAX, Default::default()); 2],
    };
    let mut i = first;
    // Samples before `done` are composited; packets start at multiples of `LANES`.
    let mut done = 0u64;
    while i < last {
        let mut end = last;
        if let Some(w) = &mut walk {
            let (class, next) = w.class_at(i, last);
            if class != CellClass::Active {
                stats.cells_skipped += 1;
                i = next;
                continue;
            }
            end = next;
        }
        // The packets covering the active cell, aligned to the lattice (the lanes
        // before and after it belong to transparent cells or to the next active one
        // and are composited like any other), so a packet holds the same samples
        // whatever was skipped before it.
        let mut j = (i - i % LANES as u64).max(done);
        while j < end {
            let lanes = ((n - j) as usize).min(LANES);
            stats.samples += lanes as u64;
            let mut shaded = packets.shade::<AVX2>(j, &mut ahead);
            if per_sample_correction {
                for alpha in shaded.alpha.iter_mut() {
                    if *alpha > 0.0 && *alpha < 1.0 {
                        if corrected.0 != *alpha {
                            corrected = (*alpha, m.correct_alpha(*alpha));
                        }
                        *alpha = corrected.1;
                    }
                }
            }
            let step = composite_packet::<AVX2>(&shaded, lanes, transmittance, eta, &mut sums);
            transmittance = step.transmittance;
            visible += lit as u64 * step.visible as u64;
            if step.terminated {
                stats.rays_terminated_early += 1;
                stats.gradient_evaluations += visible;
                return finish(&sums, transmittance);
            }
            j += LANES as u64;
        }
        done = j;
        i = j;
    }
    stats.gradient_evaluations += visible;
    finish(&sums, transmittance)
}

/// What compositing one packet left: the transmittance behind it, how many visible
/// samples it composited, and whether the ray ended in it (early termination).
struct PacketStep {
    transmittance: f32,
    visible: u32,
    terminated: bool,
}

/// Front-to-back compositing of one packet in lanes (survey eq. 13 in its product
/// form): with `kₗ = 1 − αₗ` and `T` the transmittance in front of the packet, sample
/// `l` adds `T·k₀⋯kₗ₋₁·αₗ·cₗ` to lane `l`'s colour sum and the transmittance behind
/// the packet is `T·k₀⋯k₇`. The prefix products are a log-step scan (three rounds), so
/// the only chain from packet to packet is one product; the sequential
/// `a += (1 − a)·α` it replaces was a chain of three dependent operations per sample,
/// with a branch per lane. Invisible lanes (`α ≤ 0`, NaN, or past the ray's end, the
/// first `lanes` are on it) have `k = 1` and add exactly nothing, so a packet of them
/// leaves every sum and the transmittance as they were, bit for bit. With early
/// termination on (`eta ≤ 1`), the ray ends at the first visible sample behind which
/// the opacity `1 − T` reaches `eta`, as the sequential loop did.
///
/// [`composite_packet_avx2`] is the same operations in AVX2 vectors: the same bits.
// Index loops over the lanes on purpose: they are what the compiler vectorizes.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn composite_packet<const AVX2: bool>(
    shaded: &Shaded,
    lanes: usize,
    transmittance: f32,
    eta: f32,
    sums: &mut [[f32; LANES]; 3],
) -> PacketStep {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: `AVX2` is true only in `composite_avx2`, called after
        // `is_x86_feature_detected!("avx2")` held.
        return unsafe { composite_packet_avx2(shaded, lanes, transmittance, eta, sums) };
    }
    let mut visible = [false; LANES];
    let mut alpha = [0.0f32; LANES];
    for l in 0..LANES {
        let x = shaded.alpha[l];
        // `x > 0` is false for NaN.
        visible[l] = l < lanes && x > 0.0;
        alpha[l] = if visible[l] { x } else { 0.0 };
    }
    // Inclusive prefix products of `1 − α` (Hillis–Steele).
    let mut keep = [0.0f32; LANES];
    for l in 0..LANES {
        keep[l] = 1.0 - alpha[l];
    }
    for s in [1, 2, 4] {
        let prev = keep;
        for l in s..LANES {
            keep[l] = prev[l] * prev[l - s];
        }
    }
    // Lanes composited: all, or up to the first visible one whose opacity behind
    // reaches `eta` (checked at visible samples only, as the sequential loop did).
    let mut last = LANES;
    let mut terminated = false;
    if eta <= 1.0 {
        if let Some(l) = (0..LANES).find(|&l| visible[l] && 1.0 - transmittance * keep[l] >= eta) {
            last = l + 1;
            terminated = true;
        }
    }
    let mut count = 0u32;
    for l in 0..LANES {
        let front = if l == 0 {
            transmittance
        } else {
            transmittance * keep[l - 1]
        };
        let on = l < last && visible[l];
        let w = front * alpha[l];
        count += on as u32;
        for ch in 0..3 {
            sums[ch][l] += if on { shaded.rgb[ch][l] * w } else { 0.0 };
        }
    }
    PacketStep {
        transmittance: transmittance * keep[last - 1],
        visible: count,
        terminated,
    }
}

/// [`composite_packet`] in AVX2 vectors: the same operations in the same order (the
/// scan's shifted operand is a lane permutation with `1` shifted in, and `x·1 = x`),
/// so the same bits. The portable loop compiled to scalar code with a branch per lane.
///
/// # Safety
/// The CPU must support AVX2 (and the caller be compiled for it, as
/// [`PackedVolume::sample_lanes_avx2`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn composite_packet_avx2(
    shaded: &Shaded,
    lanes: usize,
    transmittance: f32,
    eta: f32,
    sums: &mut [[f32; LANES]; 3],
) -> PacketStep {
    use std::arch::x86_64::*;
    let one = _mm256_set1_ps(1.0);
    let zero = _mm256_setzero_ps();
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let below = |k: usize| _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(k as i32), lane));
    // Lane `l` of the result is lane `l − s` of `x` (`1` for `l < s`).
    let shift = |x: __m256, idx: __m256i, fill: i32| -> __m256 {
        let moved = _mm256_permutevar8x32_ps(x, idx);
        _mm256_blendv_ps(
            moved,
            one,
            _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(fill), lane)),
        )
    };
    let by1 = _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6);
    let by2 = _mm256_setr_epi32(0, 0, 0, 1, 2, 3, 4, 5);
    let by4 = _mm256_setr_epi32(0, 0, 0, 0, 0, 1, 2, 3);
    // SAFETY: `shaded.alpha` is an `[f32; 8]`, 32 readable bytes; unaligned load.
    let raw = unsafe { _mm256_loadu_ps(shaded.alpha.as_ptr()) };
    // Ordered `>`: false for NaN.
    let mut visible = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(raw, zero), below(lanes));
    let alpha = _mm256_and_ps(raw, visible);
    let mut keep = _mm256_sub_ps(one, alpha);
    keep = _mm256_mul_ps(keep, shift(keep, by1, 1));
    keep = _mm256_mul_ps(keep, shift(keep, by2, 2));
    keep = _mm256_mul_ps(keep, shift(keep, by4, 4));
    let t = _mm256_set1_ps(transmittance);
    let mut last = LANES;
    let mut terminated = false;
    if eta <= 1.0 {
        let behind = _mm256_sub_ps(one, _mm256_mul_ps(t, keep));
        let reached = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(behind, _mm256_set1_ps(eta)), visible);
        let bits = _mm256_movemask_ps(reached);
        if bits != 0 {
            last = bits.trailing_zeros() as usize + 1;
            terminated = true;
            visible = _mm256_and_ps(visible, below(last));
        }
    }
    // Lane 0's front is `T` itself, the others `T·keep[l − 1]`: `T·1 = T`.
    let front = _mm256_mul_ps(t, shift(keep, by1, 1));
    let w = _mm256_mul_ps(front, alpha);
    for (sum, rgb) in sums.iter_mut().zip(&shaded.rgb) {
        // SAFETY: `rgb` and `sum` are `[f32; 8]`s, 32 bytes each;
        // unaligned loads and store.
        unsafe {
            let add = _mm256_and_ps(_mm256_mul_ps(_mm256_loadu_ps(rgb.as_ptr()), w), visible);
            _mm256_storeu_ps(sum.as_mut_ptr(), _mm256_add_ps(_mm256_loadu_ps(sum.as_ptr()), add));
        }
    }
    let mut keeps = [0.0f32; LANES];
    // SAFETY: `keeps` is an `[f32; 8]`, 32 writable bytes; unaligned store.
    unsafe { _mm256_storeu_ps(keeps.as_mut_ptr(), keep) };
    PacketStep {
        transmittance: transmittance * keeps[last - 1],
        visible: _mm256_movemask_ps(visible).count_ones(),
        terminated,
    }
}

/// The ray's colour (the lanes' sums added in lane order) and opacity `1 − T`.
#[inline(always)]
fn finish(sums: &[[f32; LANES]; 3], transmittance: f32) -> (Vec3, f32) {
    let total = |ch: usize| sums[ch].iter().fold(0.0f32, |acc, x| acc + x);
    (Vec3::new(total(0), total(1), total(2)), 1.0 - transmittance)
}

#[cfg(test)]
mod tests {
    // Index loops over lanes and channels, as in the code under test.
    #![allow(clippy::needless_range_loop)]
    use super::*;
    use proptest::prelude::*;

    /// [`composite_packet`] compiled for AVX2 (what `composite_avx2` inlines).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn composite_packet_avx2_caller(
        shaded: &Shaded,
        lanes: usize,
        transmittance: f32,
        eta: f32,
        sums: &mut [[f32; LANES]; 3],
    ) -> PacketStep {
        composite_packet::<true>(shaded, lanes, transmittance, eta, sums)
    }

    /// The sequential loop the packet form replaces, in `f64`: colour, transmittance,
    /// visible samples composited and whether the ray ended; `None` if the opacity
    /// came within rounding of `eta` (where `f32` may decide either way).
    fn sequential(shaded: &Shaded, lanes: usize, transmittance: f32, eta: f32) -> Option<([f64; 3], f64, u32, bool)> {
        let (mut c, mut t, mut n) = ([0.0f64; 3], transmittance as f64, 0);
        for l in 0..lanes {
            let a = shaded.alpha[l] as f64;
            if a.is_nan() || a <= 0.0 {
                continue;
            }
            for ch in 0..3 {
                c[ch] += t * a * shaded.rgb[ch][l] as f64;
            }
            t *= 1.0 - a;
            n += 1;
            if (1.0 - t - eta as f64).abs() < 1e-5 {
                return None;
            }
            if 1.0 - t >= eta as f64 {
                return Some((c, t, n, true));
            }
        }
        Some((c, t, n, false))
    }

    /// A lane's opacity: invisible (0, negative, NaN), opaque, or in between; with a
    /// colour that is NaN where the lane is invisible (it must add nothing).
    fn lane() -> impl Strategy<Value = (f32, [f32; 3])> {
        let alpha = prop_oneof![
            Just(0.0f32),
            Just(-0.25f32),
            Just(f32::NAN),
            Just(1.0f32),
            0.0f32..1.0,
            0.0f32..0.02,
        ];
        (alpha, [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0])
            .prop_map(|(a, rgb)| (a, if a > 0.0 { rgb } else { [f32::NAN; 3] }))
    }

    fn packet() -> impl Strategy<Value = Shaded> {
        proptest::collection::vec(lane(), LANES).prop_map(|ls| {
            let mut s = Shaded {
                alpha: [0.0; LANES],
                rgb: [[0.0; LANES]; 3],
            };
            for (l, (a, rgb)) in ls.into_iter().enumerate() {
                s.alpha[l] = a;
                for ch in 0..3 {
                    s.rgb[ch][l] = rgb[ch];
                }
            }
            s
        })
    }

    /// [`TransferLanes::classify`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn classify_avx2_caller(tf: &TransferLanes, v: &[f32; LANES]) -> [[f32; LANES]; 4] {
        // SAFETY: this function is compiled for AVX2 and called only where it is present.
        unsafe { tf.classify_avx2(v) }
    }

    /// Sorted control points, 1 to 8, and values around and on them.
    fn transfer() -> impl Strategy<Value = (Vec<f64>, Vec<Vec4>, Vec<f32>)> {
        (1usize..=MAX_LANE_POINTS)
            .prop_flat_map(|n| {
                (
                    proptest::collection::vec(0.01f64..1.0, n),
                    proptest::collection::vec([0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0], n),
                    proptest::collection::vec((-0.5f32..n as f32 + 0.5, 0usize..4), LANES),
                )
            })
            .prop_map(|(gaps, colours, probes)| {
                let values: Vec<f64> = gaps
                    .iter()
                    .scan(-0.2, |x, g| {
                        *x += g;
                        Some(*x)
                    })
                    .collect();
                let rgba = colours.into_iter().map(Vec4::from_array).collect();
                // A probe is a control value itself, or a value between or beyond them,
                // or NaN.
                let v = probes
                    .iter()
                    .map(|&(at, kind)| match kind {
                        0 => values[(at.max(0.0) as usize).min(values.len() - 1)] as f32,
                        1 => f32::NAN,
                        _ => values[0] as f32 - 0.3 + at * 0.9,
                    })
                    .collect();
                (values, rgba, v)
            })
    }

    proptest! {
        /// The lanes classify as [`TransferFunction::eval`](crate::TransferFunction::eval)
        /// (to `f32` rounding; control values exactly), NaN as the first control
        /// value, and the AVX2 form gives the portable form's bits.
        #[test]
        fn transfer_lanes_classify_as_the_transfer_function((values, rgba, v) in transfer()) {
            let tf = TransferLanes::new(&values, &rgba).expect("at most eight finite points");
            let points: Vec<(f64, Vec4)> = values.iter().copied().zip(rgba.iter().copied()).collect();
            let reference = crate::TransferFunction::new(points).unwrap();
            let v: [f32; LANES] = v.try_into().unwrap();
            let got = tf.classify(&v);
            for l in 0..LANES {
                let want = if v[l].is_nan() { rgba[0] } else { reference.eval(v[l] as f64) };
                // At a control value (in `f32`), its own colour exactly.
                let want = match values.iter().position(|c| *c as f32 == v[l]) {
                    Some(k) => rgba[k],
                    None => want,
                };
                for ch in 0..4 {
                    let tol = if want == rgba[0] || rgba.contains(&want) { 0.0 } else { 1e-4 };
                    prop_assert!((got[ch][l] - want[ch]).abs() <= tol, "lane {} channel {}: {} against {} at {}", l, ch, got[ch][l], want[ch], v[l]);
                }
            }
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                // SAFETY: the CPU supports AVX2 and FMA (checked just above).
                let vector = unsafe { classify_avx2_caller(&tf, &v) };
                prop_assert_eq!(vector.map(|c| c.map(f32::to_bits)), got.map(|c| c.map(f32::to_bits)));
            }
        }
    }

    proptest! {
        /// The packet form composites what the sequential loop did (to `f32`
        /// rounding), the AVX2 form gives the portable form's bits, and a packet of
        /// invisible lanes leaves the sums and the transmittance as they were.
        #[test]
        fn a_packet_composites_as_the_sequential_loop(
            shaded in packet(),
            lanes in 1usize..=LANES,
            transmittance in prop_oneof![Just(1.0f32), 0.0f32..1.0],
            eta in prop_oneof![Just(2.0f32), Just(0.99f32), 0.0f32..1.0],
            start in [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0],
        ) {
            let mut sums = [[0.0f32; LANES]; 3];
            for ch in 0..3 {
                sums[ch][3] = start[ch];
            }
            let before = sums;
            let step = composite_packet::<false>(&shaded, lanes, transmittance, eta, &mut sums);
            let reference = sequential(&shaded, lanes, transmittance, eta);
            prop_assume!(reference.is_some());
            let (c, t, n, ended) = reference.unwrap();
            prop_assert_eq!(step.visible, n);
            prop_assert_eq!(step.terminated, ended);
            prop_assert!((step.transmittance as f64 - t).abs() <= 1e-5, "{} against {}", step.transmittance, t);
            for ch in 0..3 {
                let added: f64 = (0..LANES).map(|l| sums[ch][l] as f64 - before[ch][l] as f64).sum();
                prop_assert!((added - c[ch]).abs() <= 1e-5, "channel {}: {} against {}", ch, added, c[ch]);
            }
            if n == 0 {
                prop_assert_eq!(step.transmittance.to_bits(), transmittance.to_bits());
                prop_assert_eq!(sums.map(|s| s.map(f32::to_bits)), before.map(|s| s.map(f32::to_bits)));
            }
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                let mut vector_sums = before;
                // SAFETY: the CPU supports AVX2 and FMA (checked just above).
                let v = unsafe { composite_packet_avx2_caller(&shaded, lanes, transmittance, eta, &mut vector_sums) };
                prop_assert_eq!(v.transmittance.to_bits(), step.transmittance.to_bits());
                prop_assert_eq!((v.visible, v.terminated), (step.visible, step.terminated));
                prop_assert_eq!(vector_sums.map(|s| s.map(f32::to_bits)), sums.map(|s| s.map(f32::to_bits)));
            }
        }
    }

    /// [`light_avx2`] compiled for AVX2 (what `composite_avx2` inlines).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn light_avx2_caller(
        sh: &RayShader32,
        lit: bool,
        half_step: bool,
        v: &[f32; LANES],
        g: &[[f32; LANES]; 3],
        rgba: &[[f32; LANES]; 4],
    ) -> Shaded {
        // SAFETY: this function is compiled for AVX2, and only called where the CPU
        // supports it.
        unsafe { light_avx2(sh, lit, half_step, v, g, rgba) }
    }

    /// Lane values with the edges the shading must treat alike in both forms: zeros
    /// of both signs, NaN, infinities, huge and tiny values, and ordinary ones.
    fn edgy(range: std::ops::Range<f32>) -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => range,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => Just(1.0f32),
            1 => Just(f32::NAN),
            1 => Just(f32::INFINITY),
            1 => Just(f32::NEG_INFINITY),
            1 => Just(1e-30f32),
            1 => Just(-3e30f32),
        ]
    }

    fn unit() -> impl Strategy<Value = Vec3> {
        [-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0].prop_map(|d| {
            let d = Vec3::from_array(d);
            if d.length() > 1e-3 {
                d.normalize()
            } else {
                Vec3::Z
            }
        })
    }

    fn shader() -> impl Strategy<Value = RayShader32> {
        (
            prop::collection::vec((unit(), [0.0f32..2.0, 0.0f32..2.0, 0.0f32..2.0]), 0..=3),
            unit(),
            [0.0f32..0.5, 0.0f32..0.5, 0.0f32..0.5],
            (0.0f32..1.0, 0.0f32..1.0),
            prop_oneof![
                (0i32..=64).prop_map(|n| (n as f32, Some(n))),
                (0.5f32..64.0).prop_map(|x| (x, None))
            ],
            prop_oneof![Just(0.0f32), 0.0f32..1e-3],
            prop_oneof![Just(1.0f32), Just(-1.0f32)],
        )
            .prop_map(
                |(lights, view, ambient, (diffuse, specular), (shininess, integer), min_gradient, sign)| {
                    let mut sh = RayShader32 {
                        count: lights.len(),
                        light: [Vec3::ZERO; MAX_PACKET_LIGHTS],
                        light_colour: [Vec3::ZERO; MAX_PACKET_LIGHTS],
                        half: [Vec3::ZERO; MAX_PACKET_LIGHTS],
                        view,
                        ambient: Vec3::from_array(ambient),
                        diffuse,
                        specular,
                        shininess,
                        integer_shininess: integer,
                        min_gradient,
                        outward_sign: sign,
                    };
                    for (k, (l, c)) in lights.into_iter().enumerate() {
                        sh.light[k] = l;
                        sh.light_colour[k] = Vec3::from_array(c);
                        sh.half[k] = (l + view).normalize_or_zero();
                    }
                    sh
                },
            )
    }

    proptest! {
        /// The AVX2 shading gives the portable shading's bits, lit or not, corrected to
        /// the half step or not, over values, gradients and colours with NaN, signed
        /// zeros, infinities and out-of-range entries; and the half-step correction is
        /// `1 − (1 − α)^½` (to `f32` rounding of the result).
        #[test]
        fn the_avx2_shading_gives_the_portable_bits(
            sh in shader(),
            lit in any::<bool>(),
            half_step in any::<bool>(),
            v in prop::array::uniform8(edgy(0.0f32..1.0)),
            g in [prop::array::uniform8(edgy(-5.0f32..5.0)), prop::array::uniform8(edgy(-5.0f32..5.0)), prop::array::uniform8(edgy(-5.0f32..5.0))],
            rgba in [prop::array::uniform8(edgy(-0.5f32..1.5)), prop::array::uniform8(edgy(-0.5f32..1.5)), prop::array::uniform8(edgy(-0.5f32..1.5)), prop::array::uniform8(edgy(-0.5f32..1.5))],
        ) {
            let portable = light(&sh, lit, half_step, &v, &g, &rgba);
            for l in 0..LANES {
                let a = rgba[3][l];
                if half_step && !v[l].is_nan() && a > 0.0 && a < 1.0 {
                    let want = 1.0 - (1.0 - a as f64).sqrt();
                    prop_assert!((portable.alpha[l] as f64 - want).abs() <= 1.2e-7, "{} against {}", portable.alpha[l], want);
                }
            }
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                // SAFETY: the CPU supports AVX2 and FMA (checked just above).
                let vector = unsafe { light_avx2_caller(&sh, lit, half_step, &v, &g, &rgba) };
                prop_assert_eq!(vector.alpha.map(f32::to_bits), portable.alpha.map(f32::to_bits));
                prop_assert_eq!(vector.rgb.map(|c| c.map(f32::to_bits)), portable.rgb.map(|c| c.map(f32::to_bits)));
            }
        }
    }
}
