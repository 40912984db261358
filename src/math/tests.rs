use super::*;

/// I0 by direct summation in f64 of the integral representation
/// I0(x) e^{-x} = (1/π) ∫_0^π e^{x (cos t - 1)} dt, with a high-order
/// trapezoid rule (exponentially convergent for periodic integrands).
fn i0e_by_quadrature(x: f64) -> f64 {
    let n = 4000;
    let mut s = 0.0;
    for k in 0..n {
        let t = std::f64::consts::PI * (k as f64 + 0.5) / n as f64;
        s += (x * (t.cos() - 1.0)).exp();
    }
    s / n as f64
}

#[test]
fn t01_i0e_matches_integral_representation() {
    for &x in &[0.0, 1e-8, 0.1, 1.0, 5.0, 12.0, 17.9, 18.1, 30.0, 100.0, 1e3] {
        let a = i0e(x);
        let b = i0e_by_quadrature(x);
        assert!(((a - b) / b).abs() < 1e-13, "x={x} i0e={a} quad={b}");
    }
}

#[test]
fn t02_i0e_continuous_at_switch() {
    let t = f64::I0_SERIES_MAX;
    let lo = i0e(t);
    let hi = i0e(f64::from_bits(t.to_bits() + 1));
    assert!(((lo - hi) / lo).abs() < 1e-14);
    let t = f32::I0_SERIES_MAX;
    let lo = i0e(t);
    let hi = i0e(f32::from_bits(t.to_bits() + 1));
    assert!(((lo - hi) / lo).abs() < 4.0 * f32::EPSILON);
}

#[test]
fn t03_log_i0_small_argument() {
    // log I0(x) = x²/4 - x⁴/64 + O(x⁶)
    let x = 1e-5_f64;
    let expect = x * x / 4.0 - x.powi(4) / 64.0;
    assert!(((log_i0(x) - expect) / expect).abs() < 1e-14);
    assert!(log_i0(0.0_f64) == 0.0);
}

#[test]
fn t04_mitsuba_i0_truncation_error() {
    // The 10-term series is exact to rounding for small x and loses
    // accuracy as x grows: documents why the exact mode exists.
    assert!(((i0_mitsuba(1.0_f64) - i0e(1.0) * 1f64.exp()) / i0_mitsuba(1.0)).abs() < 1e-15);
    let x = 10.0_f64;
    let rel = (i0_mitsuba(x) - i0e(x) * x.exp()).abs() / (i0e(x) * x.exp());
    assert!(rel > 1e-4 && rel < 1e-3, "rel={rel}");
}

#[test]
fn t05_fresnel_limits() {
    assert_eq!(fresnel_dielectric(1.0_f64, 1.0), 0.0);
    let r0 = ((1.55_f64 - 1.0) / (1.55 + 1.0)).powi(2);
    assert!((fresnel_dielectric(1.0_f64, 1.55) - r0).abs() < 1e-15);
    assert_eq!(fresnel_dielectric(0.0_f64, 1.55), 1.0);
    // Total internal reflection from inside.
    assert_eq!(fresnel_dielectric(-0.1_f64, 1.55), 1.0);
}

#[test]
fn t06_gauss_legendre_exact_for_polynomials() {
    for n in [1, 2, 5, 8, 16, 33] {
        let (x, w) = gauss_legendre(n);
        // Exact for degree 2n-1: ∫ x^{2k} = 2/(2k+1).
        for k in 0..n {
            let s: f64 = x
                .iter()
                .zip(&w)
                .map(|(x, w)| w * x.powi(2 * k as i32))
                .sum();
            assert!(
                (s - 2.0 / (2 * k + 1) as f64).abs() < 1e-13,
                "n={n} k={k} s={s}"
            );
        }
    }
}

#[test]
fn t07_trimmed_logistic_normalized() {
    for s in [0.01_f64, 0.1, 0.5, 2.0] {
        let inv = trimmed_logistic_inv_norm(s);
        let (x, w) = gauss_legendre(64);
        // Composite rule over 64 panels of [-π, π].
        let mut total = 0.0;
        for p in 0..64 {
            let a = -std::f64::consts::PI + p as f64 * std::f64::consts::TAU / 64.0;
            let h = std::f64::consts::TAU / 128.0;
            for (xi, wi) in x.iter().zip(&w) {
                total += wi * h * trimmed_logistic(a + h * (xi + 1.0), s, inv);
            }
        }
        assert!((total - 1.0).abs() < 1e-12, "s={s} total={total}");
        // Sampling inverts the CDF: the median is 0.
        assert!(trimmed_logistic_sample(0.5, s).abs() < 1e-12);
    }
}

#[test]
fn t09_gauss_kronrod_exact_for_polynomials_and_adaptive_for_peaks() {
    // K15 is exact to degree 22, G7 to 13: the error estimate of x^12 is ~0.
    let (i, e) = gauss_kronrod15(&mut |x: f64| [x.powi(12)], -1.0, 1.0);
    assert!((i[0] - 2.0 / 13.0).abs() < 1e-15 && e[0] < 1e-15);
    // A narrow Gaussian off the breakpoints, found by refinement.
    let s = 1e-3_f64;
    let g = |x: f64| {
        [(-0.5 * ((x - 0.123) / s).powi(2)).exp() / (s * (2.0 * std::f64::consts::PI).sqrt())]
    };
    let (i, _) = integrate_adaptive(g, &[-1.0, 0.0, 0.123, 1.0], 1e-12, 0.0, 1000);
    assert!((i[0] - 1.0).abs() < 1e-10, "{i:?}");
}

#[test]
fn t08_wrap_pi() {
    let pi = std::f64::consts::PI;
    assert!((wrap_pi(3.0 * pi) - (-pi)).abs() < 1e-12 || (wrap_pi(3.0 * pi) - pi).abs() < 1e-12);
    assert!((wrap_pi(0.5) - 0.5).abs() < 1e-15);
    assert!((wrap_pi(-0.5 - 2.0 * pi) + 0.5).abs() < 1e-12);
}

/// 10. The inlined rounding equals `std`'s bit for bit: every 61st f32
///    bit pattern (70 million, both signs, subnormals, NaNs, infinities),
///    and each integer up to 2^24 in magnitude with its neighbours one
///    ulp either side (where a wrong correction would show); `fract` on
///    20 million f64 patterns from a fixed LCG and on integers and their
///    neighbours up to 2^53.
#[test]
fn t10_rounding_equals_std() {
    let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let check = |x: f32| {
        assert!(
            same(floor(x), x.floor()),
            "floor {x:e} ({:#x})",
            x.to_bits()
        );
        assert!(same(ceil(x), x.ceil()), "ceil {x:e} ({:#x})", x.to_bits());
    };
    for bits in (0..=u32::MAX).step_by(61) {
        check(f32::from_bits(bits));
    }
    for k in -(1i32 << 24)..=(1 << 24) {
        let x = k as f32;
        for y in [x, x.next_up(), x.next_down(), x + 0.5] {
            check(y);
        }
    }
    for x in [
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MAX,
        f32::MIN,
    ] {
        check(x);
    }
    let same64 = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    for _ in 0..20_000_000 {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let x = f64::from_bits(state);
        assert!(same64(fract(x), x.fract()), "fract {x:e}");
    }
    for e in 0..=53 {
        let x = (1u64 << e) as f64;
        for y in [
            x,
            x.next_up(),
            x.next_down(),
            -x,
            -x.next_up(),
            -x.next_down(),
            x + 0.5,
        ] {
            assert!(same64(fract(y), y.fract()), "fract {y:e}");
        }
    }
}
