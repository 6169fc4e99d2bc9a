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

use glam::{DVec3, Vec3};
use volga_core::{Aabb, Field, FieldKind, Line};

use crate::packed::PackedVolume;

use crate::integrators::March;
use crate::march::midpoint_lattice_len;
use crate::sample_walk::{non_outside_span, SampleWalk};
use crate::{CellClass, Integrator, Ray, RenderSettings, RenderStats};

mod light;
#[cfg(test)]
mod tests;
mod transfer_lanes;

#[cfg(target_arch = "x86_64")]
use light::light_avx2;
use light::{light, RayShader32, Shaded};
pub(crate) use transfer_lanes::TransferLanes;

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

/// Samples per packet: eight consecutive samples of one ray, in `f32` lanes.
const LANES: usize = 8;

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
    cells: [(u64, crate::packed::LaneCells); 2],
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
