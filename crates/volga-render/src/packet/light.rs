//! Blinn-Phong shading of a packet in `f32` lanes: the portable loop and its AVX2 twin
//! (the same operations in the same order, so the same bits).

use glam::{DVec3, Vec3};
use volga_core::FieldKind;

use super::{LANES, MAX_PACKET_LIGHTS};
use crate::Shader;

/// Blinn-Phong (survey eq. 9) in `f32` for one ray: the light directions, half vectors
/// and coefficients of the image's [`Shader`] with the view of the ray, as per-ray
/// constants of the packet loop. The same formula as [`Shader::shade`] term by term.
#[derive(Debug)]
pub(super) struct RayShader32 {
    pub(super) count: usize,
    pub(super) light: [Vec3; MAX_PACKET_LIGHTS],
    pub(super) light_colour: [Vec3; MAX_PACKET_LIGHTS],
    pub(super) half: [Vec3; MAX_PACKET_LIGHTS],
    pub(super) view: Vec3,
    pub(super) ambient: Vec3,
    pub(super) diffuse: f32,
    pub(super) specular: f32,
    pub(super) shininess: f32,
    pub(super) integer_shininess: Option<i32>,
    pub(super) min_gradient: f32,
    /// Multiplies the gradient into the outward direction (`−1` for densities).
    pub(super) outward_sign: f32,
}

impl RayShader32 {
    pub(super) fn new(shader: &Shader, ray_dir: DVec3, kind: FieldKind) -> RayShader32 {
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
pub(super) fn powi_lanes(mut x: [f32; LANES], n: i32) -> [f32; LANES] {
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
pub(super) struct Shaded {
    pub(super) alpha: [f32; LANES],
    pub(super) rgb: [[f32; LANES]; 3],
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
pub(super) fn light(
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
pub(super) unsafe fn light_avx2(
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
