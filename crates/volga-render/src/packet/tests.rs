// Index loops over lanes and channels, as in the code under test.
#![allow(clippy::needless_range_loop)]
use super::light::*;
use super::transfer_lanes::MAX_LANE_POINTS;
use super::*;
use glam::Vec4;
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
    (alpha, [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0]).prop_map(|(a, rgb)| (a, if a > 0.0 { rgb } else { [f32::NAN; 3] }))
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
        if crate::test_cpu::avx2_fma("TransferLanes::classify_avx2 vs classify") {
            // SAFETY: the CPU supports AVX2 and FMA (`avx2_fma` checked).
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
        if crate::test_cpu::avx2_fma("composite_packet_avx2 vs composite_packet") {
            let mut vector_sums = before;
            // SAFETY: the CPU supports AVX2 and FMA (`avx2_fma` checked).
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
        if crate::test_cpu::avx2_fma("light_avx2 vs light") {
            // SAFETY: the CPU supports AVX2 and FMA (`avx2_fma` checked).
            let vector = unsafe { light_avx2_caller(&sh, lit, half_step, &v, &g, &rgba) };
            prop_assert_eq!(vector.alpha.map(f32::to_bits), portable.alpha.map(f32::to_bits));
            prop_assert_eq!(vector.rgb.map(|c| c.map(f32::to_bits)), portable.rgb.map(|c| c.map(f32::to_bits)));
        }
    }
}
