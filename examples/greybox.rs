//! Grey-box (physical) models fitted to simulated data, and a two-mass flexible drive
//! fitted to the measured robot-arm data set (data/robot_arm.csv).
//!
//! For each of the four shipped parameterisations — mass–spring–damper, two-mass drive,
//! RLC circuit, DC motor — noisy frequency-response data are simulated with known noise
//! variance, a start is taken (for the mass–spring–damper from the poles of a rational
//! fit), the model is fitted by output-error ML (McKelvey eq. 23) and the physical values
//! are printed with their standard deviations (delta method) next to the truth.
//!
//! Run: `cargo run --release --example greybox`

use fdid::estimate::greybox::{fit_ml_from, physical_values};
use fdid::greybox::physical::{
    DcMotor, DriveOutput, MassSpringDamper, Rlc, RlcOutput, TwoMassDrive,
};
use fdid::greybox::{AutoDiff, Fixed, PhysicalParameters};
use fdid::io::{Measurement, read_csv};
use fdid::prelude::*;

/// A small seeded Gaussian generator (xorshift + Box–Muller).
struct Gauss(u64);

impl Gauss {
    fn next(&mut self) -> f64 {
        let mut u = || {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (u1, u2) = (u(), u());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
    /// Circular complex noise with E|n|² = var.
    fn complex(&mut self, var: f64) -> Complex<f64> {
        Complex::new(self.next(), self.next()) * (var / 2.0).sqrt()
    }
}

fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 10f64.powf(lo + (hi - lo) * k as f64 / (n - 1) as f64))
        .collect()
}

/// Noisy FRF data of `model` at the physical values `truth`, noise std `rel` × RMS |G|.
fn simulate<M: ModelStructure<f64> + PhysicalParameters>(
    model: &M,
    truth: &[f64],
    omega: &[f64],
    rel: f64,
    seed: u64,
) -> FrequencyData<f64> {
    let theta: Vec<f64> = model.theta_from_physical(truth).unwrap();
    let g = model.response(&theta, omega);
    let rms = (g.iter().map(|v| v.norm_sqr()).sum::<f64>() / g.len() as f64).sqrt();
    let var = (rel * rms).powi(2);
    let mut noise = Gauss(seed);
    let y = g.iter().map(|v| v + noise.complex(var)).collect();
    FrequencyData::from_frf(omega.to_vec(), y, None)
        .unwrap()
        .with_noise(NoiseVariances::output_only(vec![var; omega.len()]))
        .unwrap()
}

fn print_fit<M: ModelStructure<f64> + PhysicalParameters>(
    title: &str,
    fit: &Fit<f64, M>,
    truth: &[f64],
) {
    println!("\n{title}");
    if fit.noise_known() {
        println!(
            "  cost {:.1} for {} lines (expected ≈ N − p/2 = {:.1})",
            fit.cost(),
            fit.omega().len(),
            fit.omega().len() as f64 - fit.theta().len() as f64 / 2.0
        );
    } else {
        println!(
            "  cost {:.4e} for {} lines, noise level estimated: λ̂ = {:.3e}",
            fit.cost(),
            fit.omega().len(),
            fit.noise_variance()
        );
    }
    let mut t = truth.iter();
    for v in physical_values(fit) {
        let std = v.std.map_or("—".into(), |s| format!("{s:.3e}"));
        let (lo, hi) = v.interval(0.95).unwrap_or((f64::NAN, f64::NAN));
        if v.fixed {
            println!("  {:>3} = {:.4e} {} (fixed)", v.name, v.value, v.unit);
        } else {
            let truth = t
                .next()
                .map_or(String::new(), |t| format!("   truth {t:.4e}"));
            println!(
                "  {:>3} = {:.4e} ± {std} {:<10} 95 % [{lo:.4e}, {hi:.4e}]{truth}",
                v.name, v.value, v.unit
            );
        }
    }
}

/// Mass–spring–damper: the start comes from a rational fit's poles and static gain.
fn mass_spring_damper() {
    let model = AutoDiff::new(MassSpringDamper::new());
    let truth = [2.0, 0.3, 50.0];
    let data = simulate(&model, &truth, &logspace(-1.0, 1.3, 200), 0.02, 1);
    // a second-order rational fit: poles p, p̄ and G(0) give k = 1/G(0), m = k/|p|²,
    // c = −2 Re(p) m
    let rational = Rational::continuous(2, 0, data.omega()).unwrap();
    let rfit = Pipeline::default().fit(&rational, &data).unwrap();
    let p = rfit.poles().unwrap()[0];
    let g0 = rfit.response_at(&[0.0])[0].re;
    let k = 1.0 / g0;
    let m = k / p.norm_sqr();
    let c = -2.0 * p.re * m;
    println!("\nstart from the rational fit: m = {m:.4}, c = {c:.4}, k = {k:.4}");
    let start: Vec<f64> = model.theta_from_physical(&[m, c, k]).unwrap();
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    print_fit(
        "mass–spring–damper (force → displacement), 200 lines, 2 % noise",
        &fit,
        &truth,
    );
}

fn two_mass() {
    let model = AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorSpeed));
    let truth = [0.02, 0.05, 100.0, 0.05];
    let data = simulate(&model, &truth, &logspace(0.5, 2.5, 300), 0.01, 2);
    // a physical guess 20–40 % off
    let start: Vec<f64> = model
        .theta_from_physical(&[0.025, 0.04, 120.0, 0.07])
        .unwrap();
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    print_fit(
        "two-mass drive (torque → motor speed), 300 lines, 1 % noise",
        &fit,
        &truth,
    );
}

fn rlc() {
    let model = AutoDiff::new(Rlc::new(RlcOutput::Current));
    let truth = [10.0, 1e-3, 1e-6];
    let data = simulate(&model, &truth, &logspace(3.0, 6.0, 150), 0.02, 3);
    let start: Vec<f64> = model.theta_from_physical(&[15.0, 0.7e-3, 1.5e-6]).unwrap();
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    print_fit(
        "series RLC (voltage → current), 150 lines, 2 % noise",
        &fit,
        &truth,
    );
}

fn dc_motor() {
    // five parameters, three identifiable combinations: R and L measured and held
    let model = Fixed::physical(AutoDiff::new(DcMotor::new()), &[("R", 1.0), ("L", 0.01)]).unwrap();
    let truth = [0.1, 1e-4, 0.01];
    let data = simulate(&model, &truth, &logspace(0.0, 4.0, 150), 0.02, 4);
    let start: Vec<f64> = model.theta_from_physical(&[0.15, 2e-4, 0.005]).unwrap();
    let fit = fit_ml_from(&model, &data, &start).unwrap();
    print_fit(
        "DC motor (voltage → speed), R and L held, 150 lines, 2 % noise",
        &fit,
        &truth,
    );
}

fn main() {
    mass_spring_damper();
    two_mass();
    rlc();
    dc_motor();
    robot_arm();
}

/// Relative residual ‖Y − Ĝ U‖/‖Y‖ of a fit on `data`.
fn relative_residual<M: ModelStructure<f64>>(fit: &Fit<f64, M>, data: &FrequencyData<f64>) -> f64 {
    let g = fit.response();
    let (mut e, mut y) = (0.0, 0.0);
    for ((yk, uk), gk) in data.y().iter().zip(data.u()).zip(g) {
        e += (yk - gk * uk).norm_sqr();
        y += yk.norm_sqr();
    }
    (e / y).sqrt()
}

/// The robot arm (DaISy): reaction torque → arm acceleration, one period, Ts = 1
/// (normalised), odd excited lines. A rational fit of order 4 shows an anti-resonance
/// below a first resonance and a second resonance; the two-mass drive (motor-side
/// acceleration: anti-resonance then resonance) with J₁ = 1 held (the units are unknown,
/// the gain g sets the scale) models the first pair. Its start comes from the rational
/// fit's zeros and poles: ω_a² = k/J₂, ω_r²/ω_a² = (J₁ + J₂)/J₁, c/J₂ = 2ζ_a ω_a.
fn robot_arm() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/robot_arm.csv");
    let Measurement::Time(record) = read_csv::<f64>(std::path::Path::new(path)).unwrap() else {
        panic!("robot_arm.csv is a time record")
    };
    let all = record.dft();
    let umax = all.u().iter().map(|u| u.norm()).fold(0.0, f64::max);
    let keep: Vec<bool> = all
        .u()
        .iter()
        .enumerate()
        .map(|(k, u)| k % 2 == 1 && u.norm() > 1e-3 * umax)
        .collect();
    let data = all.select_lines(&keep).unwrap();
    // the reaction torque on the ground opposes the drive torque: the data have the sign of
    // −G; a positive-gain physical model is fitted to −Y
    let negated: Vec<Complex<f64>> = data.y().iter().map(|y| -y).collect();
    let data =
        FrequencyData::new(data.omega().to_vec(), negated, data.u().to_vec(), data.ts()).unwrap();
    println!(
        "
robot arm: {} excited odd lines, ω = {:.4} … {:.4} rad/sample (no noise variances: λ estimated)",
        data.len(),
        data.omega()[0],
        data.omega()[data.len() - 1]
    );
    let rational = Rational::continuous(4, 4, data.omega()).unwrap();
    let rfit = Pipeline::default().fit(&rational, &data).unwrap();
    let mut poles = rfit.poles().unwrap();
    let mut zeros = rfit.zeros().unwrap();
    poles.retain(|p| p.im > 0.0);
    zeros.retain(|z| z.im > 0.0);
    poles.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
    zeros.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
    println!(
        "rational (4, 4) fit: resonances {:?} rad/sample, zeros {:?}, relative residual {:.4}",
        poles
            .iter()
            .map(|p| format!("{:.4}", p.norm()))
            .collect::<Vec<_>>(),
        zeros
            .iter()
            .map(|z| format!("{:.4}", z.norm()))
            .collect::<Vec<_>>(),
        relative_residual(&rfit, &data)
    );
    let (wa, za) = (zeros[0].norm(), -zeros[0].re / zeros[0].norm());
    let wr = poles[0].norm();
    let j1 = 1.0;
    let j2 = (wr * wr / (wa * wa) - 1.0) * j1;
    let k = wa * wa * j2;
    let c = 2.0 * za * wa * j2;
    let drive = AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorAcceleration).with_gain());
    let model = Fixed::physical(drive, &[("J1", j1)]).unwrap();
    // the first mode alone: the band below the second resonance
    let low = data.band(0.0, 0.6).unwrap();
    // the gain by least squares with the other parameters at their starts
    let unit: Vec<f64> = model.theta_from_physical(&[j2, k, c, 1.0]).unwrap();
    let g1 = model.response(&unit, low.omega());
    let h = low.etfe().unwrap();
    let num: f64 = g1.iter().zip(&h).map(|(a, b)| (a.conj() * b).re).sum();
    let den: f64 = g1.iter().map(|a| a.norm_sqr()).sum();
    let gain = num / den;
    println!("start: J2 = {j2:.4}, k = {k:.4}, c = {c:.4e}, g = {gain:.4} (J1 = 1 held)");
    if gain <= 0.0 {
        println!(
            "the least-squares gain is not positive: the model's sign does not match the data"
        );
        return;
    }
    let start: Vec<f64> = model.theta_from_physical(&[j2, k, c, gain]).unwrap();
    let lfit = fit_ml_from(&model, &low, &start).unwrap();
    print_fit(
        "two-mass drive, band ω ≤ 0.6 rad/sample (first mode)",
        &lfit,
        &[],
    );
    println!(
        "  relative residual {:.4} on {} lines",
        relative_residual(&lfit, &low),
        low.len()
    );
    let delayed = Delayed::new(model.clone());
    let mut dstart = lfit.theta().to_vec();
    dstart.push(0.0);
    let dlow = fit_ml_from(&delayed, &low, &dstart).unwrap();
    print_fit(
        "two-mass drive × delay, band ω ≤ 0.6 rad/sample",
        &dlow,
        &[],
    );
    println!("  relative residual {:.4}", relative_residual(&dlow, &low));
    // the whole band: the second mode is not in the model
    let fit = fit_ml_from(&delayed, &data, dlow.theta()).unwrap();
    print_fit(
        "two-mass drive × delay, full band (second mode unmodelled)",
        &fit,
        &[],
    );
    println!(
        "  relative residual {:.4} (rational (4, 4): {:.4})",
        relative_residual(&fit, &data),
        relative_residual(&rfit, &data)
    );
}
