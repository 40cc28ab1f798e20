//! The F tail (regularised incomplete beta) and the likelihood-ratio tests.
use fdid::FdidError;
use fdid::stats::chi2_sf;
use fdid::workflow::lrt::{beta_inc, concentrated_lr_test, f_sf, lr_test};
use quickcheck::TestResult;

#[test]
fn beta_inc_known_values() {
    // I_x(a, b) reference values (closed forms)
    // I_x(1, 1) = x; I_x(a, 1) = x^a; I_x(1, b) = 1 − (1 − x)^b
    for x in [0.0, 0.1, 0.5, 0.93, 1.0] {
        assert!((beta_inc(1.0, 1.0, x) - x).abs() < 1e-14);
        assert!((beta_inc(3.5, 1.0, x) - x.powf(3.5)).abs() < 1e-14);
        assert!((beta_inc(1.0, 2.5, x) - (1.0 - (1.0 - x).powf(2.5))).abs() < 1e-14);
    }
    // I_0.4(2, 3) = 0.5248; I_0.5(a, a) = 0.5
    assert!((beta_inc(2.0, 3.0, 0.4) - 0.5248).abs() < 1e-13);
    for a in [0.5, 2.0, 17.0, 250.0] {
        assert!((beta_inc(a, a, 0.5) - 0.5).abs() < 1e-12, "{a}");
    }
    assert!(beta_inc(-1.0, 2.0, 0.5).is_nan());
    assert!(beta_inc(1.0, 2.0, 1.5).is_nan());
}

#[test]
fn f_tail_known_values() {
    // tabulated 95 % and 99 % points of F(d1, d2)
    for (f, d1, d2, p, tol) in [
        (4.964_602_743_730_7, 1.0, 10.0, 0.05, 1e-9),
        (10.044_289_273_396_6, 1.0, 10.0, 0.01, 1e-9),
        (3.325_835, 5.0, 10.0, 0.05, 1e-7),
        (2.164_580, 10.0, 30.0, 0.05, 1e-7),
    ] {
        let got = f_sf(f, d1, d2);
        assert!((got - p).abs() < tol, "F({d1}, {d2}) at {f}: {got}");
    }
    assert_eq!(f_sf(0.0, 2.0, 3.0), 1.0);
    assert!(f_sf(1.0, 0.0, 3.0).is_nan());
}

#[test]
fn f_tail_tends_to_chi2() {
    // d1 F(d1, ∞) = χ²(d1)
    for (x, d1) in [(3.0, 2.0), (10.0, 4.0), (1.0, 1.0)] {
        let f = f_sf(x / d1, d1, 1e7);
        assert!((f - chi2_sf(x, d1)).abs() < 1e-5, "{f}");
    }
}

#[test]
fn lr_test_known_and_estimated_noise() {
    // known noise: 2ΔV = 3.841 on one extra parameter is the 5 % point of χ²(1)
    let t = lr_test(10.0 + 3.841_458_820_694_124 / 2.0, 3, 10.0, 4, 50, true).unwrap();
    assert!((t.p_value - 0.05).abs() < 1e-12);
    assert_eq!(t.dof, 1);
    // estimated noise: F = (ΔV/1)/(V1/(2N − p1)) = 4.9646 with 2N − p1 = 10
    let v1 = 10.0;
    let t = lr_test(v1 + 4.964_602_743_730_7, 1, v1, 2, 6, false).unwrap();
    assert!((t.statistic - 4.964_602_743_730_7).abs() < 1e-12);
    assert!((t.p_value - 0.05).abs() < 1e-8);
    // a cost that rose gives p = 1
    assert_eq!(lr_test(1.0, 2, 2.0, 4, 20, true).unwrap().p_value, 1.0);
    let t = concentrated_lr_test(0.1, 3, 0.1 - 3.841_458_820_694_124 / 200.0, 4, 100).unwrap();
    assert!((t.p_value - 0.05).abs() < 1e-12);
}

#[test]
fn lr_test_bad_input_is_a_typed_error() {
    let cases = [
        (lr_test(1.0, 4, 0.5, 4, 10, true), "p1"),
        (lr_test(1.0, 2, 0.5, 20, 10, true), "n_lines"),
        (lr_test(f64::NAN, 2, 0.5, 4, 10, true), "v0"),
        (lr_test(1.0, 2, -0.5, 4, 10, false), "v1"),
        (concentrated_lr_test(1.0, 2, f64::INFINITY, 4, 10), "w"),
    ];
    for (result, which) in cases {
        match result {
            Err(FdidError::InvalidArgument { name, .. }) => assert_eq!(name, which),
            other => panic!("{which}: {other:?}"),
        }
    }
}

#[test]
fn f_tail_is_a_distribution_function() {
    fn prop(f: u16, d1: u8, d2: u8) -> TestResult {
        if d1 == 0 || d2 == 0 {
            return TestResult::discard();
        }
        let (f, d1, d2) = (f as f64 / 1000.0, d1 as f64, d2 as f64);
        let p = f_sf(f, d1, d2);
        let p2 = f_sf(f + 0.5, d1, d2);
        // P(F > f) + P(1/F ≥ 1/f) with 1/F ~ F(d2, d1): the two tails sum to 1
        let q = if f > 0.0 { f_sf(1.0 / f, d2, d1) } else { 0.0 };
        TestResult::from_bool(
            (0.0..=1.0).contains(&p)
                && p2 <= p + 1e-15
                && (f == 0.0 || (p + q - 1.0).abs() < 1e-10),
        )
    }
    crate::common::seeded(0xf2f0e132).quickcheck(prop as fn(u16, u8, u8) -> TestResult);
}

#[test]
fn beta_inc_matches_the_binomial_sum() {
    // integer a, b: I_x(a, b) = Σ_{j=a}^{a+b−1} C(a+b−1, j) x^j (1 − x)^{a+b−1−j}
    fn prop(a: u8, b: u8, x: u16) -> TestResult {
        let (a, b) = (a as usize % 40 + 1, b as usize % 40 + 1);
        let x = x as f64 / u16::MAX as f64;
        let n = a + b - 1;
        let mut sum = 0.0;
        for j in a..=n {
            let ln_c = fdid::stats::ln_gamma(n as f64 + 1.0)
                - fdid::stats::ln_gamma(j as f64 + 1.0)
                - fdid::stats::ln_gamma((n - j) as f64 + 1.0);
            sum += (ln_c + j as f64 * x.ln() + (n - j) as f64 * (1.0 - x).ln()).exp();
        }
        if x == 0.0 || x == 1.0 {
            sum = x;
        }
        let got = beta_inc(a as f64, b as f64, x);
        TestResult::from_bool((got - sum).abs() < 1e-10)
    }
    crate::common::seeded(0x85f7d1a4).quickcheck(prop as fn(u8, u8, u16) -> TestResult);
}
