//! Grey-box models: the automatic (dual-number) Jacobian against finite differences and
//! against the analytic one of `Rational`, recovery of physical parameters from noise-free
//! data, Monte Carlo coverage of the physical confidence intervals, composition with a
//! delay, fixed parameters, errors-in-variables and a noise model, and bad input.

use crate::common;

use common::{Noise, central_difference, logspace};
use fdid::estimate::greybox::{fit_eiv_from, fit_ml_from, physical_values};
use fdid::estimate::refine_noise_model;
use fdid::greybox::physical::{
    DcMotor, DriveOutput, MassSpringDamper, Rlc, RlcOutput, TwoMassDrive,
};
use fdid::greybox::{AutoDiff, DualScalar, Fixed, GreyBox, PhysicalParameters};
use fdid::model::NoiseModel;
use fdid::prelude::*;
use nalgebra::DMatrix;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// B(z⁻¹)/A(z⁻¹) written once in the generic form, θ = [a₁ … a_na, b₀ … b_nb] as
/// `Rational::discrete`.
#[derive(Debug, Clone, Copy)]
struct RationalZ {
    na: usize,
    nb: usize,
    ts: f64,
}

impl GreyBox for RationalZ {
    fn n_params(&self) -> usize {
        self.na + self.nb + 1
    }
    fn response<S: DualScalar>(&self, theta: &[S], zinv: Complex<S>) -> Complex<S> {
        let one = Complex::new(S::one(), S::zero());
        let (mut a, mut b, mut pw) = (one, Complex::new(S::zero(), S::zero()), one);
        for j in 0..=self.na.max(self.nb) {
            if j >= 1 && j <= self.na {
                a += pw * theta[j - 1];
            }
            if j <= self.nb {
                b += pw * theta[self.na + j];
            }
            pw *= zinv;
        }
        b / a
    }
    fn sample_time(&self) -> Option<f64> {
        Some(self.ts)
    }
}

/// Every shipped parameterisation (and the compositions), boxed as a model structure.
fn shipped<T: Real>() -> Vec<(String, Box<dyn ModelStructure<T>>)> {
    let mut v: Vec<(String, Box<dyn ModelStructure<T>>)> = vec![
        (
            "msd".into(),
            Box::new(AutoDiff::new(MassSpringDamper::new())),
        ),
        (
            "msd+g".into(),
            Box::new(AutoDiff::new(MassSpringDamper::new().with_gain())),
        ),
        (
            "rlc-i".into(),
            Box::new(AutoDiff::new(Rlc::new(RlcOutput::Current))),
        ),
        (
            "rlc-vc+g".into(),
            Box::new(AutoDiff::new(
                Rlc::new(RlcOutput::CapacitorVoltage).with_gain(),
            )),
        ),
        ("dc".into(), Box::new(AutoDiff::new(DcMotor::new()))),
        (
            "dc+g".into(),
            Box::new(AutoDiff::new(DcMotor::new().with_gain())),
        ),
        (
            "delayed msd".into(),
            Box::new(Delayed::new(AutoDiff::new(MassSpringDamper::new()))),
        ),
        (
            "dc, R fixed".into(),
            Box::new(Fixed::physical(AutoDiff::new(DcMotor::new()), &[("R", 2.0)]).unwrap()),
        ),
        (
            "2mass load speed, J1 fixed".into(),
            Box::new(
                Fixed::physical(
                    AutoDiff::new(TwoMassDrive::new(DriveOutput::LoadSpeed)),
                    &[("J1", 1.0)],
                )
                .unwrap(),
            ),
        ),
    ];
    for out in [
        DriveOutput::MotorSpeed,
        DriveOutput::MotorAcceleration,
        DriveOutput::LoadSpeed,
        DriveOutput::LoadAcceleration,
    ] {
        let m = TwoMassDrive::new(out);
        v.push((format!("2mass {out:?}"), Box::new(AutoDiff::new(m))));
        v.push((
            format!("2mass {out:?} friction+g"),
            Box::new(AutoDiff::new(m.with_friction().with_gain())),
        ));
    }
    v
}

fn jacobian<T: Real>(
    m: &dyn ModelStructure<T>,
    theta: &[T],
    omega: &[T],
) -> (Vec<Complex<T>>, DMatrix<Complex<T>>) {
    let mut g = vec![Complex::new(T::zero(), T::zero()); omega.len()];
    let mut jac = DMatrix::zeros(omega.len(), theta.len());
    m.jacobian_into(theta, omega, &mut g, &mut jac);
    (g, jac)
}

/// ‖J_a − J_b‖ of each column relative to ‖J_a‖ (2-norms over the lines).
fn column_rms_errors(a: &DMatrix<Complex<f64>>, b: &DMatrix<Complex<f64>>) -> Vec<f64> {
    (0..a.ncols())
        .map(|j| (a.column(j) - b.column(j)).norm() / a.column(j).norm().max(1e-300))
        .collect()
}

/// Largest |J_a − J_b| of each column relative to the column's largest entry.
fn column_errors(a: &DMatrix<Complex<f64>>, b: &DMatrix<Complex<f64>>) -> Vec<f64> {
    (0..a.ncols())
        .map(|j| {
            let scale = a.column(j).iter().map(|v| v.norm()).fold(0.0, f64::max);
            let err = a
                .column(j)
                .iter()
                .zip(b.column(j).iter())
                .map(|(x, y)| (x - y).norm())
                .fold(0.0, f64::max);
            err / scale.max(1e-300)
        })
        .collect()
}

fn random_theta(rng: &mut StdRng, p: usize) -> Vec<f64> {
    (0..p).map(|_| rng.gen_range(-1.5..1.5)).collect()
}

fn property_grid() -> Vec<f64> {
    logspace(-1.5, 1.5, 25)
}

#[test]
fn automatic_jacobian_matches_central_differences_f64() {
    fn prop(seed: u64) -> bool {
        let mut rng = StdRng::seed_from_u64(seed);
        let omega = property_grid();
        for (name, m) in shipped::<f64>() {
            let theta = random_theta(&mut rng, m.n_params());
            let (g, jac) = jacobian(m.as_ref(), &theta, &omega);
            let direct = m.response(&theta, &omega);
            assert!(
                g.iter()
                    .zip(&direct)
                    .all(|(a, b)| (a - b).norm() <= 1e-14 * b.norm()),
                "{name}: G"
            );
            let stacked = |t: &[f64]| -> Vec<f64> {
                m.response(t, &omega)
                    .iter()
                    .flat_map(|v| [v.re, v.im])
                    .collect()
            };
            let fd = DMatrix::from_fn(omega.len(), theta.len(), |k, j| {
                let d = central_difference(stacked, &theta, j);
                Complex::new(d[2 * k], d[2 * k + 1])
            });
            let err = column_errors(&jac, &fd);
            if err.iter().any(|e| e.is_nan() || *e >= 1e-7) {
                eprintln!("{name}: seed {seed}, theta {theta:?}, column errors {err:?}");
                return false;
            }
        }
        true
    }
    crate::common::seeded(0x28298631)
        .tests(20)
        .quickcheck(prop as fn(u64) -> bool);
}

#[test]
fn automatic_jacobian_f32_matches_f64() {
    fn prop(seed: u64) -> bool {
        let mut rng = StdRng::seed_from_u64(seed);
        let omega = property_grid();
        let omega32: Vec<f32> = omega.iter().map(|w| *w as f32).collect();
        for ((name, m), (_, m32)) in shipped::<f64>().into_iter().zip(shipped::<f32>()) {
            // physical values within e^±1 of one: wider ranges give lightly damped modes
            // whose lines lose digits in f32 whatever the differentiation method
            let theta: Vec<f64> = random_theta(&mut rng, m.n_params())
                .iter()
                .map(|t| t / 1.5)
                .collect();
            let theta32: Vec<f32> = theta.iter().map(|t| *t as f32).collect();
            // the reference at the f32-rounded θ and ω
            let theta_r: Vec<f64> = theta32.iter().map(|t| f64::from(*t)).collect();
            let omega_r: Vec<f64> = omega32.iter().map(|w| f64::from(*w)).collect();
            let (_, jac) = jacobian(m.as_ref(), &theta_r, &omega_r);
            let (_, jac32) = jacobian(m32.as_ref(), &theta32, &omega32);
            let jac32 = jac32.map(|v| Complex::new(f64::from(v.re), f64::from(v.im)));
            // 2-norm over the lines: single lines next to an anti-resonance (a numerator
            // that cancels) lose digits in f32 whatever the method
            let err = column_rms_errors(&jac, &jac32);
            if err.iter().any(|e| e.is_nan() || *e >= 1e-3) {
                eprintln!("{name}: seed {seed}, column errors {err:?}");
                return false;
            }
        }
        true
    }
    crate::common::seeded(0x5f2eb6a7)
        .tests(100)
        .quickcheck(prop as fn(u64) -> bool);
    // a seed whose θ puts lines next to the motor-side anti-resonance
    assert!(prop(33637847824291247));
    assert!(prop(371373153925985229));
}

#[test]
fn automatic_jacobian_of_generic_rational_equals_analytic() {
    fn check(seed: u64, na: usize, nb: usize) -> bool {
        let mut rng = StdRng::seed_from_u64(seed);
        let ts = 0.01;
        let omega: Vec<f64> = (1..=40)
            .map(|k| k as f64 / 41.0 * std::f64::consts::PI / ts)
            .collect();
        let auto = AutoDiff::new(RationalZ { na, nb, ts });
        let analytic = Rational::discrete(na, nb, ts).unwrap();
        let scale = 0.4 / (na as f64 / 4.0).max(1.0);
        let theta: Vec<f64> = (0..na + nb + 1)
            .map(|_| rng.gen_range(-scale..scale))
            .collect();
        let (g1, j1) = jacobian(&auto, &theta, &omega);
        let (g2, j2) = jacobian(&analytic, &theta, &omega);
        let g_ok = g1
            .iter()
            .zip(&g2)
            .all(|(a, b)| (a - b).norm() <= 1e-13 * b.norm().max(1.0));
        let err = column_errors(&j2, &j1);
        g_ok && err.iter().all(|e| *e < 1e-12)
    }
    fn prop(seed: u64, na: u8, nb: u8) -> bool {
        check(seed, usize::from(na % 8), usize::from(nb % 8))
    }
    crate::common::seeded(0xc627e71d)
        .tests(50)
        .quickcheck(prop as fn(u64, u8, u8) -> bool);
    // 21 and 37 parameters: one pass of a 24-component dual, two passes of 32
    assert!(check(7, 10, 10));
    assert!(check(8, 20, 16));
}

/// Noise-free FRF data of `model` at `theta`.
fn frf_data<M: ModelStructure<f64>>(model: &M, theta: &[f64], omega: &[f64]) -> FrequencyData<f64> {
    FrequencyData::from_frf(omega.to_vec(), model.response(theta, omega), None).unwrap()
}

/// Fits from the truth's physical values scaled by `factors` and returns the largest
/// relative error of the physical values.
fn recovery<M: ModelStructure<f64> + PhysicalParameters + Clone>(
    model: &M,
    truth: &[f64],
    factors: &[f64],
    omega: &[f64],
) -> f64 {
    let theta: Vec<f64> = model.theta_from_physical(truth).unwrap();
    let data = frf_data(model, &theta, omega);
    let guess: Vec<f64> = truth.iter().zip(factors).map(|(t, f)| t * f).collect();
    let start: Vec<f64> = model.theta_from_physical(&guess).unwrap();
    let fit = fit_ml_from(model, &data, &start).unwrap();
    let values: Vec<f64> = physical_values(&fit)
        .iter()
        .filter(|v| !v.fixed)
        .map(|v| v.value)
        .collect();
    values
        .iter()
        .zip(truth)
        .map(|(v, t)| ((v - t) / t).abs())
        .fold(0.0, f64::max)
}

#[test]
fn noise_free_recovery_of_physical_parameters() {
    let cases: Vec<(&str, f64)> = vec![
        (
            "mass-spring-damper",
            recovery(
                &AutoDiff::new(MassSpringDamper::new()),
                &[2.0, 0.3, 50.0],
                &[1.3, 0.6, 0.8],
                &logspace(-1.0, 1.3, 100),
            ),
        ),
        (
            "two-mass, motor speed",
            recovery(
                &AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorSpeed)),
                &[0.02, 0.05, 100.0, 0.05],
                &[1.2, 0.8, 1.15, 2.0],
                &logspace(0.5, 2.5, 200),
            ),
        ),
        (
            "two-mass with friction, motor acceleration",
            recovery(
                &AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorAcceleration).with_friction()),
                &[0.02, 0.05, 100.0, 0.05, 0.01, 0.02],
                &[1.1, 0.9, 1.1, 1.5, 0.7, 1.4],
                &logspace(-0.5, 2.5, 200),
            ),
        ),
        (
            "two-mass with friction, load acceleration, b2 fixed",
            recovery(
                &Fixed::physical(
                    AutoDiff::new(TwoMassDrive::new(DriveOutput::LoadAcceleration).with_friction()),
                    &[("b2", 0.02)],
                )
                .unwrap(),
                &[0.02, 0.05, 100.0, 0.05, 0.01],
                &[1.1, 0.9, 1.1, 1.5, 0.7],
                &logspace(-0.5, 2.5, 200),
            ),
        ),
        (
            "two-mass, load speed, J1 fixed",
            recovery(
                &Fixed::physical(
                    AutoDiff::new(TwoMassDrive::new(DriveOutput::LoadSpeed)),
                    &[("J1", 0.02)],
                )
                .unwrap(),
                &[0.05, 100.0, 0.05],
                &[0.8, 1.15, 2.0],
                &logspace(0.5, 2.5, 200),
            ),
        ),
        (
            "RLC, current",
            recovery(
                &AutoDiff::new(Rlc::new(RlcOutput::Current)),
                &[10.0, 1e-3, 1e-6],
                &[1.5, 0.8, 1.2],
                &logspace(3.0, 6.0, 100),
            ),
        ),
        (
            "RLC, capacitor voltage, C fixed",
            recovery(
                &Fixed::physical(
                    AutoDiff::new(Rlc::new(RlcOutput::CapacitorVoltage)),
                    &[("C", 1e-6)],
                )
                .unwrap(),
                &[10.0, 1e-3],
                &[1.5, 0.8],
                &logspace(3.0, 6.0, 100),
            ),
        ),
        (
            "DC motor, R and L fixed",
            recovery(
                &Fixed::physical(AutoDiff::new(DcMotor::new()), &[("R", 1.0), ("L", 0.01)])
                    .unwrap(),
                &[0.1, 1e-4, 0.01],
                &[1.3, 0.7, 2.0],
                &logspace(0.0, 4.0, 100),
            ),
        ),
        (
            "mass-spring-damper with gain, m fixed",
            recovery(
                &Fixed::physical(
                    AutoDiff::new(MassSpringDamper::new().with_gain()),
                    &[("m", 2.0)],
                )
                .unwrap(),
                &[0.3, 50.0, 3.0],
                &[0.7, 1.2, 0.5],
                &logspace(-1.0, 1.3, 100),
            ),
        ),
    ];
    for (name, err) in &cases {
        println!("{name}: largest relative error of the physical values {err:.2e}");
    }
    for (name, err) in cases {
        assert!(err < 1e-9, "{name}: {err:e}");
    }
}

/// The DC motor's five parameters give three combinations: the fit has no covariance
/// (JᵀJ singular) however exact the data.
#[test]
fn unidentifiable_parameter_set_has_no_covariance() {
    let model = AutoDiff::new(DcMotor::new());
    let truth: Vec<f64> = model
        .theta_from_physical(&[0.1, 1.0, 0.01, 1e-4, 0.01])
        .unwrap();
    let data = frf_data(&model, &truth, &logspace(0.0, 4.0, 100));
    let fit = fit_ml_from(&model, &data, &truth).unwrap();
    assert!(fit.covariance().is_none());
    assert!(physical_values(&fit).iter().all(|v| v.std.is_none()));
}

#[test]
fn delayed_grey_box_recovers_delay_and_parameters() {
    let model = Delayed::new(AutoDiff::new(MassSpringDamper::new()));
    let omega = logspace(-1.0, 1.3, 100);
    let mut truth: Vec<f64> = model
        .inner()
        .theta_from_physical(&[2.0, 0.3, 50.0])
        .unwrap();
    truth.push(0.05);
    let data = frf_data(&model, &truth, &omega);
    let mut start: Vec<f64> = model
        .inner()
        .theta_from_physical(&[1.7, 0.4, 45.0])
        .unwrap();
    start.push(0.03);
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    let v = physical_values(&fit);
    assert_eq!(v[3].name, "tau");
    assert_eq!(v[3].unit, "s");
    for (p, t) in v.iter().zip([2.0, 0.3, 50.0, 0.05]) {
        assert!(
            ((p.value - t) / t).abs() < 1e-9,
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
}

#[test]
fn noise_free_recovery_f32() {
    let model = AutoDiff::new(MassSpringDamper::new());
    let omega: Vec<f32> = logspace(-1.0, 1.3, 100).iter().map(|w| *w as f32).collect();
    let truth: Vec<f32> = model.theta_from_physical(&[2.0, 0.3, 50.0]).unwrap();
    let data =
        FrequencyData::from_frf(omega.clone(), model.response(&truth, &omega), None).unwrap();
    let start: Vec<f32> = model.theta_from_physical(&[2.4, 0.2, 42.0]).unwrap();
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    for (p, t) in physical_values(&fit).iter().zip([2.0f32, 0.3, 50.0]) {
        assert!(
            ((p.value - t) / t).abs() < 1e-3,
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
}

/// Errors-in-variables with a delayed grey-box model: noise-free spectra with declared
/// input and output noise variances give the truth.
#[test]
fn errors_in_variables_with_delayed_grey_box() {
    let model = Delayed::new(AutoDiff::new(MassSpringDamper::new()));
    let omega = logspace(-1.0, 1.3, 80);
    let mut truth: Vec<f64> = model
        .inner()
        .theta_from_physical(&[2.0, 0.3, 50.0])
        .unwrap();
    truth.push(0.05);
    let n = omega.len();
    let u: Vec<Complex<f64>> = (0..n)
        .map(|k| Complex::from_polar(1.0, 0.3 * (k * k) as f64))
        .collect();
    let g = model.response(&truth, &omega);
    let y = g.iter().zip(&u).map(|(g, u)| g * u).collect();
    let noise = NoiseVariances {
        var_y: vec![1e-6; n],
        var_u: vec![1e-4; n],
        cov_yu: vec![Complex::new(0.0, 0.0); n],
    };
    let data = FrequencyData::new(omega, y, u, None)
        .unwrap()
        .with_noise(noise)
        .unwrap();
    let mut start: Vec<f64> = model
        .inner()
        .theta_from_physical(&[1.8, 0.35, 47.0])
        .unwrap();
    start.push(0.04);
    let fit = fit_eiv_from(&model, &data, &start).unwrap();
    assert_eq!(fit.stages().last().unwrap().kind, StageKind::Eiv);
    for (a, b) in fit.theta().iter().zip(&truth) {
        assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
    }
}

/// ML with an estimated noise model H = C/D over a grey-box start fit: coloured output
/// noise; the physical parameters land within 4 predicted std of the truth.
#[test]
fn noise_model_ml_over_grey_box() {
    let model = AutoDiff::new(MassSpringDamper::new());
    let ts = 0.05;
    let n = 400;
    let omega: Vec<f64> = (1..n)
        .map(|k| std::f64::consts::PI / ts * k as f64 / n as f64)
        .collect();
    let truth: Vec<f64> = model.theta_from_physical(&[2.0, 0.3, 50.0]).unwrap();
    let (h, eta) = NoiseModel::from_polynomials(&[1.0, 0.5], &[1.0, -0.7], ts).unwrap();
    let hk = h.response(&eta, &omega);
    let mut noise = Noise::new(11);
    let g = model.response(&truth, &omega);
    let u: Vec<Complex<f64>> = (0..omega.len())
        .map(|k| Complex::from_polar(1.0, 0.7 * (k * k) as f64))
        .collect();
    let y = (0..omega.len())
        .map(|k| g[k] * u[k] + hk[k] * noise.complex(1e-5))
        .collect();
    let data = FrequencyData::new(omega, y, u, Some(ts)).unwrap();
    let start = fit_ml_from(&model, &data, &truth).unwrap();
    let fit = refine_noise_model(
        &start,
        &data,
        NoiseModel::new(1, 1, ts).unwrap(),
        &LevenbergMarquardt::default(),
    )
    .unwrap();
    let std = fit.theta_std().unwrap();
    for j in 0..3 {
        let z = (fit.theta()[j] - truth[j]) / std[j];
        assert!(z.abs() < 4.0, "parameter {j}: z = {z}");
    }
    // the noise model is found: d₁ ≈ −0.7
    assert!(
        (fit.theta()[4] + 0.7).abs() < 0.1,
        "d1 = {}",
        fit.theta()[4]
    );
}

/// Monte Carlo over noisy FRF data with known noise variance: coverage of the 95 %
/// intervals of each physical parameter, and the ratio of the sample std of θ̂ to the
/// predicted one, and the bias in units of the predicted std of the mean.
struct McFigures {
    coverage: Vec<f64>,
    std_ratio: Vec<f64>,
    bias_z: Vec<f64>,
}

fn monte_carlo<M: ModelStructure<f64> + PhysicalParameters + Clone>(
    model: &M,
    truth: &[f64],
    omega: &[f64],
    var: f64,
    runs: usize,
    seed: u64,
) -> McFigures {
    let theta0: Vec<f64> = model.theta_from_physical(truth).unwrap();
    let g0 = model.response(&theta0, omega);
    let p = theta0.len();
    let mut noise = Noise::new(seed);
    let (mut hits, mut est, mut pred) = (vec![0usize; p], vec![vec![]; p], vec![0.0; p]);
    for _ in 0..runs {
        let frf = g0.iter().map(|g| g + noise.complex(var)).collect();
        let data = FrequencyData::from_frf(omega.to_vec(), frf, None)
            .unwrap()
            .with_noise(NoiseVariances::output_only(vec![var; omega.len()]))
            .unwrap();
        let fit = fit_ml_from(model, &data, &theta0).unwrap();
        for (j, v) in physical_values(&fit)
            .iter()
            .filter(|v| !v.fixed)
            .enumerate()
        {
            let (lo, hi) = v.interval(0.95).unwrap();
            hits[j] += usize::from(lo <= truth[j] && truth[j] <= hi);
            est[j].push(v.theta);
            pred[j] += v.theta_std.unwrap() / runs as f64;
        }
    }
    let r = runs as f64;
    let mut out = McFigures {
        coverage: vec![],
        std_ratio: vec![],
        bias_z: vec![],
    };
    for j in 0..p {
        let mean = est[j].iter().sum::<f64>() / r;
        let sd = (est[j].iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (r - 1.0)).sqrt();
        out.coverage.push(hits[j] as f64 / r);
        out.std_ratio.push(sd / pred[j]);
        out.bias_z.push((mean - theta0[j]) / (pred[j] / r.sqrt()));
    }
    out
}

fn report(name: &str, f: &McFigures) {
    println!(
        "{name}: coverage {:?}, std ratio {:?}, bias/std(mean) {:?}",
        f.coverage
            .iter()
            .map(|c| format!("{c:.3}"))
            .collect::<Vec<_>>(),
        f.std_ratio
            .iter()
            .map(|c| format!("{c:.3}"))
            .collect::<Vec<_>>(),
        f.bias_z
            .iter()
            .map(|c| format!("{c:.2}"))
            .collect::<Vec<_>>()
    );
}

fn msd_case() -> (AutoDiff<MassSpringDamper>, [f64; 3], Vec<f64>, f64) {
    (
        AutoDiff::new(MassSpringDamper::new()),
        [2.0, 0.3, 50.0],
        logspace(-1.0, 1.3, 100),
        4e-4,
    )
}

fn dc_case() -> (Fixed<AutoDiff<DcMotor>>, [f64; 3], Vec<f64>, f64) {
    let model = Fixed::physical(AutoDiff::new(DcMotor::new()), &[("R", 1.0), ("L", 0.01)]).unwrap();
    (model, [0.1, 1e-4, 0.01], logspace(0.0, 4.0, 100), 1e-3)
}

#[test]
fn monte_carlo_coverage_fast() {
    let (m, t, w, var) = msd_case();
    let f = monte_carlo(&m, &t, &w, var, 100, 1);
    report("mass-spring-damper, 100 runs", &f);
    let (m2, t2, w2, var2) = dc_case();
    let f2 = monte_carlo(&m2, &t2, &w2, var2, 100, 2);
    report("DC motor (R, L fixed), 100 runs", &f2);
    for f in [f, f2] {
        for j in 0..f.coverage.len() {
            assert!(
                (0.85..=1.0).contains(&f.coverage[j]),
                "coverage {:?}",
                f.coverage
            );
            assert!(
                (0.8..1.2).contains(&f.std_ratio[j]),
                "std ratio {:?}",
                f.std_ratio
            );
            assert!(f.bias_z[j].abs() < 4.0, "bias {:?}", f.bias_z);
        }
    }
}

/// Long run: `cargo test --release --test suite greybox:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn monte_carlo_coverage_long() {
    let (m, t, w, var) = msd_case();
    let f = monte_carlo(&m, &t, &w, var, 1000, 3);
    report("mass-spring-damper, 1000 runs", &f);
    let (m2, t2, w2, var2) = dc_case();
    let f2 = monte_carlo(&m2, &t2, &w2, var2, 1000, 4);
    report("DC motor (R, L fixed), 1000 runs", &f2);
    for f in [f, f2] {
        for j in 0..f.coverage.len() {
            assert!(
                (0.93..=0.97).contains(&f.coverage[j]),
                "coverage {:?}",
                f.coverage
            );
            assert!(
                (0.93..1.07).contains(&f.std_ratio[j]),
                "std ratio {:?}",
                f.std_ratio
            );
            assert!(f.bias_z[j].abs() < 4.0, "bias {:?}", f.bias_z);
        }
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let model = AutoDiff::new(MassSpringDamper::new());
    let omega = logspace(-1.0, 1.0, 20);
    let theta: Vec<f64> = model.theta_from_physical(&[1.0, 0.2, 4.0]).unwrap();
    let data = frf_data(&model, &theta, &omega);
    // wrong θ length
    assert!(matches!(
        fit_ml_from(&model, &data, &theta[..2]),
        Err(FdidError::LengthMismatch {
            what: "theta",
            expected: 3,
            got: 2
        })
    ));
    assert!(matches!(
        model.evaluate(&[0.0; 4], &omega),
        Err(FdidError::LengthMismatch { .. })
    ));
    // the unchecked path writes NaN instead of panicking
    let g = model.response(&[0.0f64; 5], &omega);
    assert!(g.iter().all(|v| v.re.is_nan()));
    let mut jac = DMatrix::zeros(omega.len(), 2);
    let mut gg = vec![Complex::new(0.0, 0.0); omega.len()];
    model.jacobian_into(&[0.0, 0.0], &omega, &mut gg, &mut jac);
    assert!(gg.iter().all(|v| v.re.is_nan()));
    // non-finite θ
    let err = fit_ml_from(&model, &data, &[0.0, f64::NAN, 1.0]).unwrap_err();
    assert!(
        matches!(
            err,
            FdidError::NonFinite {
                what: "theta",
                index: 1,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(matches!(
        model.evaluate(&[0.0, f64::INFINITY, 1.0], &omega),
        Err(FdidError::NonFinite { .. })
    ));
    // non-positive and non-finite physical values
    for bad in [[1.0, 0.0, 4.0], [1.0, -0.2, 4.0], [f64::NAN, 0.2, 4.0]] {
        let err = model.theta_from_physical::<f64>(&bad).unwrap_err();
        assert!(
            matches!(
                err,
                FdidError::InvalidArgument {
                    name: "physical value",
                    ..
                }
            ),
            "{err:?}"
        );
    }
    assert!(matches!(
        model.theta_from_physical::<f64>(&[1.0, 2.0]),
        Err(FdidError::LengthMismatch {
            what: "physical values",
            ..
        })
    ));
    // fixing: unknown name, twice, bad index, non-finite value, non-positive physical value
    let dc = AutoDiff::new(DcMotor::new());
    assert!(matches!(
        Fixed::physical(dc, &[("X", 1.0)]),
        Err(FdidError::InvalidArgument { name: "fixed", .. })
    ));
    assert!(matches!(
        Fixed::physical(dc, &[("R", 1.0), ("R", 2.0)]),
        Err(FdidError::InvalidArgument { .. })
    ));
    assert!(matches!(
        Fixed::physical(dc, &[("R", -1.0)]),
        Err(FdidError::InvalidArgument { .. })
    ));
    assert!(matches!(
        Fixed::new(dc, &[(5, 0.0f64)]),
        Err(FdidError::InvalidArgument { name: "fixed", .. })
    ));
    assert!(matches!(
        Fixed::new(dc, &[(1, f64::NAN)]),
        Err(FdidError::NonFinite { what: "fixed", .. })
    ));
    // a fixed model with a wrong free θ length
    let fixed = Fixed::physical(dc, &[("R", 2.0)]).unwrap();
    assert!(matches!(
        fit_ml_from(&fixed, &data, &[0.0; 5]),
        Err(FdidError::LengthMismatch { expected: 4, .. })
    ));
    // too few lines
    let short = FrequencyData::from_frf(vec![1.0], vec![Complex::new(1.0, 0.0)], None).unwrap();
    assert!(matches!(
        fit_ml_from(&model, &short, &theta),
        Err(FdidError::TooFewFrequencies { .. })
    ));
    // a discrete-time grey box against data of another sample time, and above Nyquist
    let z = AutoDiff::new(RationalZ {
        na: 1,
        nb: 0,
        ts: 0.1,
    });
    let zd = FrequencyData::from_frf(vec![1.0, 2.0], vec![Complex::new(1.0, 0.0); 2], Some(0.2))
        .unwrap();
    assert!(matches!(
        fit_ml_from(&z, &zd, &[0.5, 1.0]),
        Err(FdidError::InvalidArgument { name: "ts", .. })
    ));
    let zd =
        FrequencyData::from_frf(vec![1.0, 40.0], vec![Complex::new(1.0, 0.0); 2], None).unwrap();
    assert!(matches!(
        fit_ml_from(&z, &zd, &[0.5, 1.0]),
        Err(FdidError::InvalidArgument { name: "omega", .. })
    ));
    // a delay outside its bounds
    let delayed = Delayed::new(model).with_bounds(0.0, 0.1).unwrap();
    let mut start = theta.clone();
    start.push(0.5);
    assert!(matches!(
        fit_ml_from(&delayed, &data, &start),
        Err(FdidError::InvalidArgument { name: "delay", .. })
    ));
}

#[test]
fn default_parameter_names_and_generic_physical_values() {
    let z = AutoDiff::new(RationalZ {
        na: 1,
        nb: 0,
        ts: 0.1,
    });
    let p = z.physical_parameters();
    assert_eq!(p.len(), 2);
    assert_eq!(p[0].0.name, "theta0");
    assert_eq!(p[1].0.name, "theta1");
}
