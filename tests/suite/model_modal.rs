//! The modal (pole–residue) model: analytic Jacobians, the ZOH-sampled and band-limited
//! routes from sampled data with and without the transient term (McKelvey section 2.3,
//! eqs. 4–5, 9–10), poles/zeros, starting values and typed errors.

use crate::common;

use common::Noise;
use fdid::estimate::{ModalOptions, fit_modal};
use fdid::model::{Modal, ModalParts, Output};
use fdid::prelude::*;
use quickcheck::{Arbitrary, Gen};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

type C = Complex<f64>;

// ---------------------------------------------------------------------------------------
// Simulation of continuous-time modal systems from sampled data.
// ---------------------------------------------------------------------------------------

/// G_c(s) = d + Σ r/(s − p) + Σ [r/(s − p) + r̄/(s − p̄)] with an initial state per mode.
#[derive(Debug, Clone)]
struct System {
    real: Vec<(f64, f64)>,
    pairs: Vec<(C, C)>,
    d: f64,
    /// initial state of each real mode
    x0_real: Vec<f64>,
    /// initial (complex) state of each pair's mode p (the conjugate mode starts at its
    /// conjugate)
    x0_pairs: Vec<C>,
}

impl System {
    fn eval(&self, omega: f64) -> C {
        let s = C::new(0.0, omega);
        let mut g = C::new(self.d, 0.0);
        for (p, r) in &self.real {
            g += *r / (s - *p);
        }
        for (p, r) in &self.pairs {
            g += *r / (s - *p) + r.conj() / (s - p.conj());
        }
        g
    }

    fn parts(&self, tau_real: Vec<f64>, tau_pairs: Vec<C>) -> ModalParts<f64> {
        ModalParts {
            real_poles: self.real.iter().map(|m| m.0).collect(),
            real_residues: self.real.iter().map(|m| m.1).collect(),
            pair_poles: self.pairs.iter().map(|m| m.0).collect(),
            pair_residues: self.pairs.iter().map(|m| m.1).collect(),
            direct: self.d,
            transient_real: tau_real,
            transient_pairs: tau_pairs,
        }
    }

    /// Exact samples for an input held constant between samples: per mode
    /// x[k+1] = e^{pTs}x[k] + ((e^{pTs} − 1)/p) u[k], y = Σ r x + d u. Returns y and the
    /// transient coefficients τ = r (x[0] − x[N])/√N.
    fn simulate_zoh(&self, u: &[f64], ts: f64) -> (Vec<f64>, Vec<f64>, Vec<C>) {
        let n = u.len();
        let mut y: Vec<f64> = u.iter().map(|v| self.d * v).collect();
        let sq = (n as f64).sqrt();
        let mut tau_real = vec![];
        for ((p, r), x0) in self.real.iter().zip(&self.x0_real) {
            let lam = (p * ts).exp();
            let e = (p * ts).exp_m1() / p;
            let mut x = *x0;
            for k in 0..n {
                y[k] += r * x;
                x = lam * x + e * u[k];
            }
            tau_real.push(r * (x0 - x) / sq);
        }
        let mut tau_pairs = vec![];
        for ((p, r), x0) in self.pairs.iter().zip(&self.x0_pairs) {
            let lam = (*p * ts).exp();
            let e = ((*p * ts).exp() - 1.0) / *p;
            let mut x = *x0;
            for k in 0..n {
                y[k] += 2.0 * (*r * x).re;
                x = lam * x + e * u[k];
            }
            tau_pairs.push(*r * (*x0 - x) / sq);
        }
        (y, tau_real, tau_pairs)
    }

    /// A random-phase multisine on DFT lines `lines` (all below Nyquist) applied in
    /// continuous time, the exact output — the periodic steady state Σ a Re(G(iω)e^{i(ωt+φ)})
    /// plus the modal transient c e^{pt} from the initial state (c = r x₀ for each mode,
    /// x₀ the mismatch with the steady state) — sampled at t = kTs. Returns u, y and
    /// τ = c(1 − e^{pTsN})/√N.
    fn simulate_multisine(
        &self,
        n: usize,
        ts: f64,
        lines: &[usize],
        phases: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<C>) {
        let tau_n = std::f64::consts::TAU / (n as f64 * ts);
        let mut u = vec![0.0; n];
        let mut y = vec![0.0; n];
        for (l, ph) in lines.iter().zip(phases) {
            let w = tau_n * *l as f64;
            let g = self.eval(w);
            for k in 0..n {
                let e = C::new(0.0, w * k as f64 * ts + ph).exp();
                u[k] += e.re;
                y[k] += (g * e).re;
            }
        }
        let sq = (n as f64).sqrt();
        let mut tau_real = vec![];
        for ((p, r), x0) in self.real.iter().zip(&self.x0_real) {
            let c = r * x0;
            for (k, yk) in y.iter_mut().enumerate() {
                *yk += c * (p * k as f64 * ts).exp();
            }
            tau_real.push(c * (1.0 - (p * ts * n as f64).exp()) / sq);
        }
        let mut tau_pairs = vec![];
        for ((p, r), x0) in self.pairs.iter().zip(&self.x0_pairs) {
            let c = *r * *x0;
            for (k, yk) in y.iter_mut().enumerate() {
                *yk += 2.0 * (c * (*p * (k as f64 * ts)).exp()).re;
            }
            tau_pairs.push(c * (1.0 - (*p * (ts * n as f64)).exp()) / sq);
        }
        (u, y, tau_real, tau_pairs)
    }
}

/// Largest relative error of the poles and residues of `theta` against the system's.
fn modal_error(model: &Modal<f64>, theta: &[f64], sys: &System) -> f64 {
    let est = model.parts(theta);
    let mut err: f64 = 0.0;
    let mut rel = |a: C, b: C| err = err.max((a - b).norm() / b.norm());
    let mut used = vec![false; est.real_poles.len()];
    for (p, r) in &sys.real {
        let i = (0..used.len())
            .filter(|i| !used[*i])
            .min_by(|a, b| {
                let da = (est.real_poles[*a] - p).abs();
                let db = (est.real_poles[*b] - p).abs();
                da.partial_cmp(&db).unwrap()
            })
            .unwrap();
        used[i] = true;
        rel(C::new(est.real_poles[i], 0.0), C::new(*p, 0.0));
        rel(C::new(est.real_residues[i], 0.0), C::new(*r, 0.0));
    }
    // the modes may come out in any order: pair each true mode with the nearest estimate
    let mut used = vec![false; est.pair_poles.len()];
    for (p, r) in &sys.pairs {
        let j = (0..used.len())
            .filter(|j| !used[*j])
            .min_by(|a, b| {
                let da = (est.pair_poles[*a] - p).norm();
                let db = (est.pair_poles[*b] - p).norm();
                da.partial_cmp(&db).unwrap()
            })
            .unwrap();
        used[j] = true;
        rel(est.pair_poles[j], *p);
        rel(est.pair_residues[j], *r);
    }
    err
}

/// Largest relative error of the transient coefficients (relative to the largest τ).
fn transient_error(est: &ModalParts<f64>, tau_real: &[f64], tau_pairs: &[C]) -> f64 {
    let scale = tau_real
        .iter()
        .map(|t| t.abs())
        .chain(tau_pairs.iter().map(|t| t.norm()))
        .fold(0.0, f64::max);
    let a = est
        .transient_real
        .iter()
        .zip(tau_real)
        .map(|(a, b)| (a - b).abs());
    let b = est
        .transient_pairs
        .iter()
        .zip(tau_pairs)
        .map(|(a, b)| (a - b).norm());
    a.chain(b).fold(0.0, f64::max) / scale
}

/// A random stable system for N samples at sample time `ts`: `n_real` real poles and
/// `n_pairs` pairs with natural frequencies in the measured band, from 2.5 line spacings
/// (2.5·2π/(N Ts)) to 0.8 of the Nyquist frequency, that band cut into equal log-segments
/// with one mode in the middle 60 % of each; damping 0.05–0.5, residues of size ~|p|
/// (unit-order mode gains), d ∈ [−1, 1] when `direct`, initial states of unit order.
fn random_system(
    seed: u64,
    n_real: usize,
    n_pairs: usize,
    direct: bool,
    n: usize,
    ts: f64,
) -> System {
    let mut rng = StdRng::seed_from_u64(seed);
    let modes = n_real + n_pairs;
    let pi = std::f64::consts::PI;
    let (lo, hi) = ((5.0 * pi / n as f64).ln(), (0.8 * pi).ln());
    let seg = (hi - lo) / modes as f64;
    let mut wn: Vec<f64> = (0..modes)
        .map(|i| (lo + seg * (i as f64 + rng.gen_range(0.2..0.8))).exp() / ts)
        .collect();
    // shuffle which slots are real
    for i in (1..wn.len()).rev() {
        let j = rng.gen_range(0..=i);
        wn.swap(i, j);
    }
    let mut sys = System {
        real: vec![],
        pairs: vec![],
        d: if direct {
            rng.gen_range(-1.0..1.0)
        } else {
            0.0
        },
        x0_real: vec![],
        x0_pairs: vec![],
    };
    for w in wn.iter().take(n_real) {
        let r = w * rng.gen_range(0.5..2.0) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        sys.real.push((-w, r));
        sys.x0_real.push(rng.gen_range(-2.0..2.0) / w);
    }
    for w in wn.iter().skip(n_real) {
        let zeta: f64 = rng.gen_range(0.05..0.5);
        let p = C::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
        let r = C::from_polar(
            w * rng.gen_range(0.3..1.0),
            rng.gen_range(0.0..std::f64::consts::TAU),
        );
        sys.pairs.push((p, r));
        sys.x0_pairs
            .push(C::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) / *w);
    }
    sys
}

fn gaussian_input(seed: u64, n: usize) -> Vec<f64> {
    let mut noise = Noise::new(seed);
    (0..n).map(|_| noise.gauss()).collect()
}

/// ZOH-route data: the DFT (lines 0..N/2) of an exact simulation with a random
/// piecewise-constant input; also the true τ.
fn zoh_data(sys: &System, n: usize, ts: f64, seed: u64) -> (FrequencyData<f64>, Vec<f64>, Vec<C>) {
    let u = gaussian_input(seed, n);
    let (y, tr, tp) = sys.simulate_zoh(&u, ts);
    (TimeData::new(u, y, ts).unwrap().dft(), tr, tp)
}

/// Band-limited-route data: the excited lines 1..N/2 − 1 of a random-phase multisine.
fn multisine_data(
    sys: &System,
    n: usize,
    ts: f64,
    seed: u64,
) -> (FrequencyData<f64>, Vec<f64>, Vec<C>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let lines: Vec<usize> = (1..n / 2).collect();
    let phases: Vec<f64> = lines
        .iter()
        .map(|_| rng.gen_range(0.0..std::f64::consts::TAU))
        .collect();
    let (u, y, tr, tp) = sys.simulate_multisine(n, ts, &lines, &phases);
    let data = TimeData::new(u, y, ts).unwrap().dft();
    let keep: Vec<bool> = (0..data.len()).map(|k| k >= 1 && k < n / 2).collect();
    (data.select_lines(&keep).unwrap(), tr, tp)
}

fn two_modes() -> System {
    System {
        real: vec![(-0.3, 0.8)],
        pairs: vec![(C::new(-0.08, 1.1), C::new(0.2, -0.9))],
        d: 0.4,
        x0_real: vec![1.5],
        x0_pairs: vec![C::new(-0.7, 1.2)],
    }
}

// ---------------------------------------------------------------------------------------
// Jacobians against central differences.
// ---------------------------------------------------------------------------------------

fn fd_check(model: &Modal<f64>, theta: &[f64], omega: &[f64]) -> (f64, f64) {
    let (n, p) = (omega.len(), model.n_params());
    let zero = C::new(0.0, 0.0);
    let mut g = vec![zero; n];
    let mut jg = nalgebra::DMatrix::from_element(n, p, C::new(7.0, 7.0));
    model.jacobian_into(theta, omega, &mut g, &mut jg);
    let g0 = model.response(theta, omega);
    for (a, b) in g.iter().zip(&g0) {
        assert!((a - b).norm() <= 1e-14 * b.norm().max(1.0));
    }
    let mut t = vec![zero; n];
    let mut jt = nalgebra::DMatrix::from_element(n, p, C::new(7.0, 7.0));
    let has_t = model.transient_into(theta, omega, &mut t, Some(&mut jt));
    let (mut eg, mut et, mut sg, mut st) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for j in 0..p {
        let h = 1e-6 * theta[j].abs().max(1.0);
        let mut tp = theta.to_vec();
        let mut tm = theta.to_vec();
        tp[j] += h;
        tm[j] -= h;
        let (gp, gm) = (model.response(&tp, omega), model.response(&tm, omega));
        let mut tpv = vec![zero; n];
        let mut tmv = vec![zero; n];
        model.transient_into(&tp, omega, &mut tpv, None);
        model.transient_into(&tm, omega, &mut tmv, None);
        for k in 0..n {
            let fd = (gp[k] - gm[k]) / (2.0 * h);
            eg = eg.max((fd - jg[(k, j)]).norm());
            sg = sg.max(jg[(k, j)].norm());
            if has_t {
                let fd = (tpv[k] - tmv[k]) / (2.0 * h);
                et = et.max((fd - jt[(k, j)]).norm());
                st = st.max(jt[(k, j)].norm());
            }
        }
    }
    (eg / sg, if has_t { et / st } else { 0.0 })
}

fn jacobian_theta(model: &Modal<f64>, sys: &System) -> Vec<f64> {
    let nt = model.transient_ts().map_or(0, |_| 1);
    let tr = vec![0.3; nt * sys.real.len()];
    let tp = vec![C::new(-0.2, 0.5); nt * sys.pairs.len()];
    model.theta_from_parts(&sys.parts(tr, tp)).unwrap()
}

#[test]
fn jacobian_matches_finite_differences_in_both_domains() {
    let sys = two_modes();
    let omega: Vec<f64> = (0..40).map(|k| 0.07 * k as f64 + 0.01).collect();
    let ts = 0.9;
    let models = [
        Modal::continuous(1, 1, true).unwrap(),
        Modal::continuous(1, 1, true)
            .unwrap()
            .with_transient(ts)
            .unwrap(),
        Modal::zoh(1, 1, true, ts).unwrap(),
        Modal::zoh(1, 1, true, ts)
            .unwrap()
            .with_transient(ts)
            .unwrap(),
    ];
    for model in &models {
        let theta = jacobian_theta(model, &sys);
        let (eg, et) = fd_check(model, &theta, &omega);
        println!(
            "{:?} transient {:?}: dG {eg:.1e}, dT {et:.1e}",
            model.domain(),
            model.transient_ts()
        );
        assert!(eg < 1e-7, "dG rel error {eg}");
        assert!(et < 1e-7, "dT rel error {et}");
    }
}

#[test]
fn zoh_mode_is_continuous_through_p_equal_zero() {
    let ts = 0.5;
    let model = Modal::zoh(1, 1, false, ts).unwrap();
    let omega = [0.3, 1.0, 2.5, 6.0];
    // r Ts z⁻¹/(1 − z⁻¹) at p = 0 (an integrator)
    let limit = |w: f64, r: f64| {
        let zi = C::new(0.0, -w * ts).exp();
        r * ts * zi / (1.0 - zi)
    };
    for p in [0.0, 1e-14, -1e-9, 1e-5] {
        let theta = [p, 2.0, -0.5, 1e-12, 0.0, 0.0];
        let g = model.response(&theta, &omega);
        for (k, w) in omega.iter().enumerate() {
            // the pair with r = 0 contributes nothing
            let want = limit(*w, 2.0);
            // |dG/dp|/|G| ≈ Ts/2 + Ts/|1 − z⁻¹| < 4 on this grid
            let tol = 1e-14 + 4.0 * p.abs();
            assert!(
                (g[k] - want).norm() <= tol * want.norm(),
                "p = {p}: {} vs {}",
                g[k],
                want
            );
        }
        let (eg, _) = fd_check(&model, &[p, 2.0, -0.5, 0.3, 0.4, -0.2], &omega);
        assert!(eg < 1e-7, "p = {p}: dG rel error {eg}");
    }
    // the series (|pTs| < 1) and the expm1 branch meet without a jump
    for (a, b) in [
        (1.999_999_999, 2.000_000_001),
        (-1.999_999_999, -2.000_000_001),
    ] {
        let ga = model.response(&[a, 1.0, -0.1, 0.5, 1.0, 0.0], &omega);
        let gb = model.response(&[b, 1.0, -0.1, 0.5, 1.0, 0.0], &omega);
        for (x, y) in ga.iter().zip(&gb) {
            assert!((x - y).norm() < 1e-8 * y.norm(), "{x} vs {y}");
        }
        let (eg, _) = fd_check(&model, &[a, 1.0, -0.1, 0.5, 1.0, 0.0], &omega);
        assert!(eg < 1e-7);
    }
}

// ---------------------------------------------------------------------------------------
// The transient term reproduces exact simulations.
// ---------------------------------------------------------------------------------------

#[test]
fn zoh_model_with_transient_reproduces_the_sampled_record() {
    let sys = two_modes();
    let ts = 0.7;
    for n in [64, 100, 256] {
        let (data, tr, tp) = zoh_data(&sys, n, ts, 11);
        let model = Modal::zoh(1, 1, true, ts)
            .unwrap()
            .with_transient(ts)
            .unwrap();
        let theta = model.theta_from_parts(&sys.parts(tr, tp)).unwrap();
        let mut out = Output::new(data.len(), model.n_params());
        assert!(out.evaluate(&model, &theta, &data, false));
        let err = common::rel_rms(&out.yhat, data.y());
        println!("ZOH N = {n}: model vs DFT of the record {err:.1e}");
        assert!(err < 1e-12, "N = {n}: {err}");
        // without the transient the record is not explained
        let bare = Modal::zoh(1, 1, true, ts).unwrap();
        let tb = bare.theta_from_parts(&sys.parts(vec![], vec![])).unwrap();
        let g = bare.response(&tb, data.omega());
        let yhat: Vec<C> = g.iter().zip(data.u()).map(|(g, u)| g * u).collect();
        assert!(common::rel_rms(&yhat, data.y()) > 1e-3);
    }
}

#[test]
fn continuous_model_with_transient_reproduces_the_band_limited_record() {
    let sys = two_modes();
    let ts = 0.4;
    for n in [64, 128, 256] {
        let (data, tr, tp) = multisine_data(&sys, n, ts, 5);
        let model = Modal::continuous(1, 1, true)
            .unwrap()
            .with_transient(ts)
            .unwrap();
        let theta = model.theta_from_parts(&sys.parts(tr, tp)).unwrap();
        let mut out = Output::new(data.len(), model.n_params());
        assert!(out.evaluate(&model, &theta, &data, false));
        let err = common::rel_rms(&out.yhat, data.y());
        println!("band-limited N = {n}: model vs DFT of the record {err:.1e}");
        assert!(err < 1e-11, "N = {n}: {err}");
    }
}

// ---------------------------------------------------------------------------------------
// Recovery from sampled data.
// ---------------------------------------------------------------------------------------

#[test]
fn zoh_route_recovers_poles_and_residues_with_the_transient() {
    let sys = two_modes();
    let ts = 0.7;
    for n in [64, 128, 256] {
        let (data, tr, tp) = zoh_data(&sys, n, ts, 3);
        let opts = ModalOptions::zoh(ts).with_direct();
        let with = fit_modal(&Pipeline::default(), &data, 1, 1, opts.with_transient()).unwrap();
        let without = fit_modal(&Pipeline::default(), &data, 1, 1, opts).unwrap();
        let e_with = modal_error(with.model(), with.theta(), &sys);
        let e_without = modal_error(without.model(), without.theta(), &sys);
        let e_tau = transient_error(&with.model().parts(with.theta()), &tr, &tp);
        let d_err = (with.model().parts(with.theta()).direct - sys.d).abs();
        println!(
            "ZOH N = {n}: with transient {e_with:.1e} (τ {e_tau:.1e}, d {d_err:.1e}), \
             without {e_without:.1e}"
        );
        assert!(e_with < 1e-9, "N = {n}: {e_with}");
        assert!(e_tau < 1e-9, "N = {n}: τ {e_tau}");
        assert!(d_err < 1e-9);
        assert!(e_without > 1e-4, "N = {n}: {e_without}");
        assert!(with.model().is_stable(with.theta()).unwrap());
    }
}

#[test]
fn band_limited_route_recovers_poles_and_residues_with_the_transient() {
    let sys = two_modes();
    let ts = 0.4;
    for n in [64, 128, 256] {
        let (data, tr, tp) = multisine_data(&sys, n, ts, 9);
        let opts = ModalOptions::continuous().with_direct();
        let with = fit_modal(&Pipeline::default(), &data, 1, 1, opts.with_transient()).unwrap();
        let without = fit_modal(&Pipeline::default(), &data, 1, 1, opts).unwrap();
        let e_with = modal_error(with.model(), with.theta(), &sys);
        let e_without = modal_error(without.model(), without.theta(), &sys);
        let e_tau = transient_error(&with.model().parts(with.theta()), &tr, &tp);
        println!(
            "band-limited N = {n}: with transient {e_with:.1e} (τ {e_tau:.1e}), \
             without {e_without:.1e}"
        );
        assert!(e_with < 1e-9, "N = {n}: {e_with}");
        assert!(e_tau < 1e-9, "N = {n}: τ {e_tau}");
        assert!(e_without > 1e-4, "N = {n}: {e_without}");
    }
}

#[test]
fn zoh_route_without_transient_is_exact_for_a_steady_state_record() {
    // a record that starts and ends in the same state has no transient: then the model
    // without it is exact as well (the zero-initial-state simulation of a periodic input
    // after its transient has died out is approximated by a long decay)
    let mut sys = two_modes();
    sys.x0_real = vec![0.0];
    sys.x0_pairs = vec![C::new(0.0, 0.0)];
    let ts = 0.7;
    let n = 128;
    let period = gaussian_input(4, n);
    // 60 periods: the transient of the slowest mode (|Re p| Ts = 0.056) decays to 1e-186
    let u: Vec<f64> = period.iter().cycle().take(60 * n).copied().collect();
    let (y, _, _) = sys.simulate_zoh(&u, ts);
    let last = TimeData::new(u[59 * n..].to_vec(), y[59 * n..].to_vec(), ts).unwrap();
    let fit = fit_modal(
        &Pipeline::default(),
        &last.dft(),
        1,
        1,
        ModalOptions::zoh(ts).with_direct(),
    )
    .unwrap();
    let err = modal_error(fit.model(), fit.theta(), &sys);
    println!("ZOH steady state without transient: {err:.1e}");
    assert!(err < 1e-9, "{err}");
}

// ---------------------------------------------------------------------------------------
// Property tests over random stable modal systems.
// ---------------------------------------------------------------------------------------

/// A random case: seed, numbers of real poles (0–1) and pairs (1–2), direct term, N.
#[derive(Debug, Clone)]
struct Case {
    seed: u64,
    n_real: usize,
    n_pairs: usize,
    direct: bool,
    n: usize,
}

impl Arbitrary for Case {
    fn arbitrary(g: &mut Gen) -> Self {
        Case {
            seed: u64::arbitrary(g),
            n_real: usize::arbitrary(g) % 2,
            n_pairs: 1 + usize::arbitrary(g) % 2,
            direct: bool::arbitrary(g),
            n: [64, 128, 256][usize::arbitrary(g) % 3],
        }
    }
}

/// A [`Case`] of order ≤ 4 (the ZOH route's start fails on about 1 % of order-5 systems,
/// see `zoh_route_failure_rate_over_orders_up_to_five`).
#[derive(Debug, Clone)]
struct LowOrderCase(Case);

impl Arbitrary for LowOrderCase {
    fn arbitrary(g: &mut Gen) -> Self {
        let mut c = Case::arbitrary(g);
        if c.n_real + 2 * c.n_pairs > 4 {
            c.n_real = 0;
        }
        LowOrderCase(c)
    }
}

fn zoh_property(case: Case) -> bool {
    let ts = [0.01, 0.1, 1.0][(case.seed % 3) as usize];
    let sys = random_system(
        case.seed,
        case.n_real,
        case.n_pairs,
        case.direct,
        case.n,
        ts,
    );
    let (data, _, _) = zoh_data(&sys, case.n, ts, case.seed ^ 0x5a5a);
    let mut opts = ModalOptions::zoh(ts).with_transient();
    opts.direct = case.direct;
    match fit_modal(&Pipeline::default(), &data, case.n_real, case.n_pairs, opts) {
        Ok(fit) => {
            let err = modal_error(fit.model(), fit.theta(), &sys);
            if err > 1e-8 {
                println!("{case:?}: error {err:.1e}");
            }
            err < 1e-8
        }
        Err(e) => {
            println!("{case:?}: {e}");
            false
        }
    }
}

fn band_limited_property(case: Case) -> bool {
    let ts = [0.01, 0.1, 1.0][(case.seed % 3) as usize];
    let sys = random_system(
        case.seed,
        case.n_real,
        case.n_pairs,
        case.direct,
        case.n,
        ts,
    );
    let (data, _, _) = multisine_data(&sys, case.n, ts, case.seed ^ 0xa5a5);
    let mut opts = ModalOptions::continuous().with_transient();
    opts.direct = case.direct;
    match fit_modal(&Pipeline::default(), &data, case.n_real, case.n_pairs, opts) {
        Ok(fit) => {
            let err = modal_error(fit.model(), fit.theta(), &sys);
            if err > 1e-8 {
                println!("{case:?}: error {err:.1e}");
            }
            err < 1e-8
        }
        Err(e) => {
            println!("{case:?}: {e}");
            false
        }
    }
}

#[test]
fn quickcheck_zoh_route_recovers_random_systems_f64() {
    crate::common::seeded(0x10a35ba0)
        .tests(30)
        .quickcheck((|c: LowOrderCase| zoh_property(c.0)) as fn(LowOrderCase) -> bool);
}

/// Measured: 3–4 failures in 400 (all of order 5: one real pole and two pairs) for the ZOH
/// route, none for the band-limited route. Run with
/// `cargo test --release --test suite -- --ignored model_modal::failure_rate --nocapture`.
#[test]
#[ignore]
fn zoh_route_failure_rate_over_orders_up_to_five() {
    let mut g = Gen::from_size_and_seed(100, 400);
    let (mut fz, mut fb) = (0, 0);
    let runs = 400;
    for _ in 0..runs {
        let c = Case::arbitrary(&mut g);
        fz += usize::from(!zoh_property(c.clone()));
        fb += usize::from(!band_limited_property(c));
    }
    println!("failures: ZOH {fz}/{runs}, band-limited {fb}/{runs}");
    assert!(fz * 50 <= runs, "ZOH failures {fz}/{runs}");
    assert!(fb * 50 <= runs, "band-limited failures {fb}/{runs}");
}

#[test]
fn quickcheck_band_limited_route_recovers_random_systems_f64() {
    crate::common::seeded(0x67a46b36)
        .tests(30)
        .quickcheck(band_limited_property as fn(Case) -> bool);
}

// ---------------------------------------------------------------------------------------
// Monte Carlo with noise: bias and sample std against the predicted std.
// ---------------------------------------------------------------------------------------

/// ZOH route with transient on `runs` noisy records (circular complex noise of variance
/// `var` on every DFT line): per pole parameter (p, σ, ω) the bias in units of the std of
/// the mean and the ratio sample std / mean predicted std from `Fit::covariance`.
fn monte_carlo(runs: usize, var: f64) -> Vec<(f64, f64)> {
    let sys = two_modes();
    let (ts, n) = (0.7, 128);
    let (clean, _, _) = zoh_data(&sys, n, ts, 21);
    let truth = [sys.real[0].0, sys.pairs[0].0.re, sys.pairs[0].0.im];
    let mut est = vec![vec![]; 3];
    let mut pred = [0.0; 3];
    let mut noise = Noise::new(77);
    for _ in 0..runs {
        let y: Vec<C> = clean.y().iter().map(|y| y + noise.complex(var)).collect();
        let data =
            FrequencyData::new(clean.omega().to_vec(), y, clean.u().to_vec(), clean.ts()).unwrap();
        let opts = ModalOptions::zoh(ts).with_direct().with_transient();
        let fit = fit_modal(&Pipeline::default(), &data, 1, 1, opts).unwrap();
        let parts = fit.model().parts(fit.theta());
        let std = fit.theta_std().unwrap();
        for (k, (v, s)) in [
            (parts.real_poles[0], std[0]),
            (parts.pair_poles[0].re, std[2]),
            (parts.pair_poles[0].im, std[3]),
        ]
        .into_iter()
        .enumerate()
        {
            est[k].push(v);
            pred[k] += s / runs as f64;
        }
    }
    (0..3)
        .map(|k| {
            let m = est[k].iter().sum::<f64>() / runs as f64;
            let sd =
                (est[k].iter().map(|v| (v - m).powi(2)).sum::<f64>() / (runs - 1) as f64).sqrt();
            let bias = (m - truth[k]) / (sd / (runs as f64).sqrt());
            println!(
                "param {k}: true {:.4}, mean {m:.4}, bias {bias:.2} std-of-mean, sample std \
                 {sd:.2e}, predicted {:.2e}, ratio {:.3}",
                truth[k],
                pred[k],
                sd / pred[k]
            );
            (bias, sd / pred[k])
        })
        .collect()
}

#[test]
fn monte_carlo_zoh_route_bias_and_std_match_prediction() {
    for (bias, ratio) in monte_carlo(100, 1e-3) {
        assert!(bias.abs() < 4.0, "bias {bias} std of the mean");
        assert!((0.75..1.33).contains(&ratio), "std ratio {ratio}");
    }
}

/// Run with `cargo test --release --test suite -- --ignored model_modal::long --nocapture`.
#[test]
#[ignore]
fn monte_carlo_zoh_route_long() {
    for (bias, ratio) in monte_carlo(1000, 1e-3) {
        assert!(bias.abs() < 4.0, "bias {bias} std of the mean");
        assert!((0.9..1.11).contains(&ratio), "std ratio {ratio}");
    }
}

// ---------------------------------------------------------------------------------------
// f32.
// ---------------------------------------------------------------------------------------

#[test]
fn zoh_route_in_f32() {
    let sys = two_modes();
    let ts = 0.7;
    let (data, _, _) = zoh_data(&sys, 128, ts, 3);
    let c32 = |v: &[C]| -> Vec<Complex<f32>> {
        v.iter()
            .map(|c| Complex::new(c.re as f32, c.im as f32))
            .collect()
    };
    let data32 = FrequencyData::new(
        data.omega().iter().map(|w| *w as f32).collect(),
        c32(data.y()),
        c32(data.u()),
        Some(ts as f32),
    )
    .unwrap();
    let opts = ModalOptions::zoh(ts as f32).with_direct().with_transient();
    let fit = fit_modal(&Pipeline::default(), &data32, 1, 1, opts).unwrap();
    let theta: Vec<f64> = fit.theta().iter().map(|v| *v as f64).collect();
    let model = Modal::zoh(1, 1, true, ts)
        .unwrap()
        .with_transient(ts)
        .unwrap();
    let err = modal_error(&model, &theta, &sys);
    println!("f32 ZOH route: {err:.1e}");
    assert!(err < 1e-3, "{err}");
}

// ---------------------------------------------------------------------------------------
// Poles, zeros, gain.
// ---------------------------------------------------------------------------------------

#[test]
fn zeros_and_gain_of_known_systems() {
    // 1/(s + 1) + 1/(s + 2) = (2s + 3)/((s + 1)(s + 2))
    let m = Modal::continuous(2, 0, false).unwrap();
    let th = [-1.0, 1.0, -2.0, 1.0];
    let z = m.zeros(&th).unwrap();
    assert_eq!(z.len(), 1);
    assert!((z[0] - C::new(-1.5, 0.0)).norm() < 1e-13);
    assert!((m.gain(&th) - 2.0).abs() < 1e-13);
    // an integrator: 1/s + 1/(s + 1) = (2s + 1)/(s(s + 1)), also in the ZOH domain
    let m = Modal::zoh(2, 0, false, 0.1).unwrap();
    let th = [0.0, 1.0, -1.0, 1.0];
    let z = m.zeros(&th).unwrap();
    assert_eq!(z.len(), 1);
    assert!((z[0] - C::new(-0.5, 0.0)).norm() < 1e-12, "{z:?}");
    assert!((m.gain(&th) - 2.0).abs() < 1e-12);
    assert!(!m.is_stable(&th).unwrap());
    // a direct term and a pair: every zero makes G vanish
    let sys = two_modes();
    let m = Modal::continuous(1, 1, true).unwrap();
    let th = m.theta_from_parts(&sys.parts(vec![], vec![])).unwrap();
    let z = m.zeros(&th).unwrap();
    assert_eq!(z.len(), 3);
    for zi in &z {
        let mut g = C::new(sys.d, 0.0);
        let mut scale = sys.d.abs();
        for (p, r) in &sys.real {
            g += *r / (zi - p);
            scale += (*r / (zi - p)).norm();
        }
        for (p, r) in &sys.pairs {
            g += *r / (zi - p) + r.conj() / (zi - p.conj());
            scale += (*r / (zi - p)).norm() * 2.0;
        }
        assert!(g.norm() < 1e-12 * scale, "G({zi}) = {g}");
    }
    assert!((m.gain(&th) - sys.d).abs() < 1e-14);
    let poles = m.poles(&th).unwrap();
    assert_eq!(poles.len(), 3);
    assert!(poles.contains(&sys.pairs[0].0) && poles.contains(&sys.pairs[0].0.conj()));
    assert!(m.is_stable(&th).unwrap());
}

// ---------------------------------------------------------------------------------------
// Bad input.
// ---------------------------------------------------------------------------------------

fn is_invalid(r: Result<impl std::fmt::Debug>, name: &str) -> bool {
    matches!(r, Err(FdidError::InvalidArgument { name: n, .. }) if n == name)
}

#[test]
fn bad_input_gives_typed_errors() {
    for ts in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(is_invalid(Modal::zoh(1, 0, false, ts), "ts"), "ts = {ts}");
        assert!(
            is_invalid(
                Modal::continuous(1, 0, false).unwrap().with_transient(ts),
                "ts"
            ),
            "ts = {ts}"
        );
    }
    assert!(is_invalid(
        Modal::<f64>::continuous(0, 0, true),
        "n_real + n_pairs"
    ));
    assert!(is_invalid(
        Modal::zoh(1, 0, false, 0.5).unwrap().with_transient(0.6),
        "ts"
    ));
    // data sampled with another Ts
    let sys = two_modes();
    let (data, _, _) = zoh_data(&sys, 64, 0.7, 1);
    let m = Modal::zoh(1, 1, true, 0.5).unwrap();
    assert!(is_invalid(m.check_data(&data), "ts"));
    assert!(is_invalid(
        fit_modal(&Pipeline::default(), &data, 1, 1, ModalOptions::zoh(0.5)),
        "ts"
    ));
    let m = Modal::continuous(1, 1, true)
        .unwrap()
        .with_transient(0.5)
        .unwrap();
    assert!(is_invalid(m.check_data(&data), "ts"));
    assert!(
        Modal::continuous(1, 1, true)
            .unwrap()
            .check_data(&data)
            .is_ok()
    );
    // lines above the Nyquist frequency of the ZOH model
    let m = Modal::zoh(1, 1, true, 1.0).unwrap();
    let fast = data.clone().with_ts(None).unwrap();
    assert!(is_invalid(m.check_data(&fast), "omega"));
    // a transient in continuous time needs the data's sample time
    let opts = ModalOptions::continuous().with_transient();
    assert!(is_invalid(
        fit_modal(&Pipeline::default(), &fast, 1, 1, opts),
        "ts"
    ));
    assert!(is_invalid(
        fit_modal(&Pipeline::default(), &data, 0, 0, ModalOptions::zoh(0.7)),
        "n_real + n_pairs"
    ));
    // a discrete-time pole on the negative real axis has no ZOH preimage
    let r = Rational::discrete(1, 1, 0.7).unwrap();
    let m = Modal::zoh(1, 0, false, 0.7).unwrap();
    assert!(is_invalid(
        m.start_from_rational(&r, &[0.5, 1.0, 0.0], &data, NoiseWeighting::Flat),
        "discrete-time pole"
    ));
    assert!(
        m.start_from_rational(&r, &[-0.5, 1.0, 0.0], &data, NoiseWeighting::Flat)
            .is_ok()
    );
    // wrong numbers of poles or parts
    assert!(is_invalid(
        m.theta_for_poles(&[C::new(-1.0, 1.0)], &data, NoiseWeighting::Flat),
        "poles"
    ));
    assert!(matches!(
        m.theta_from_parts(&sys.parts(vec![], vec![])),
        Err(FdidError::LengthMismatch { .. })
    ));
    // too few lines
    let few = data
        .select_lines(
            &[true, true, false, false]
                .iter()
                .copied()
                .chain(std::iter::repeat(false))
                .take(data.len())
                .collect::<Vec<_>>(),
        )
        .unwrap();
    assert!(matches!(
        Modal::zoh(1, 1, true, 0.7).unwrap().check_data(&few),
        Err(FdidError::TooFewFrequencies { .. })
    ));
}
