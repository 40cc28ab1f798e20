//! The discrepancy workflow from a user's physical model: a rigid-body (one-mass) model of
//! a drive, fitted to the frequency response of a two-mass drive, is told
//! `missing_resonance` and augmented by a flexible mode.
//!
//! Run: `cargo run --release --example workflow_greybox`.
use fdid::estimate::greybox::physical_values;
use fdid::greybox::physical::{DriveOutput, TwoMassDrive};
use fdid::greybox::{AutoDiff, DualScalar, Fixed, GreyBox, Parameter};
use fdid::prelude::*;
use fdid::simulate::SplitMix64;
use fdid::workflow::{Context, Workflow};

/// The user's model: a rigid inertia with viscous friction, torque → speed, read by a
/// speed sensor of gain g: G(s) = g/(J s + b), θ = [ln J, ln b, ln g].
#[derive(Debug, Clone, Copy)]
struct RigidBody;

impl GreyBox for RigidBody {
    fn n_params(&self) -> usize {
        3
    }
    fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
        let (j, b, g) = (theta[0].exp(), theta[1].exp(), theta[2].exp());
        (s * j + Complex::new(b, S::zero())).inv() * g
    }
    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::log("J", "kg·m²"),
            Parameter::log("b", "N·m·s/rad"),
            Parameter::log("g", "1"),
        ]
    }
}

fn main() -> fdid::Result<()> {
    // the plant: J₁ = 0.02, J₂ = 0.04 kg·m², k = 40 N·m/rad, c = 0.02, b₁ = 0.05,
    // b₂ = 0.02 N·m·s/rad; motor speed measured on 300 lines of 0.5 rad/s with σ = 0.01
    let drive = AutoDiff::new(TwoMassDrive::new(DriveOutput::MotorSpeed).with_friction());
    let truth: Vec<f64> = drive.theta_from_physical(&[0.02, 0.04, 40.0, 0.02, 0.05, 0.02])?;
    let omega: Vec<f64> = (1..=300).map(|k| 0.5 * k as f64).collect();
    let var = 1e-4;
    let mut rng = SplitMix64::new(7);
    let s = (var / 2.0_f64).sqrt();
    let y: Vec<Complex<f64>> = drive
        .response(&truth, &omega)
        .iter()
        .map(|g| g + Complex::new(s * rng.gaussian(), s * rng.gaussian()))
        .collect();
    let u = vec![Complex::new(1.0, 0.0); omega.len()];
    let data = FrequencyData::new(omega.clone(), y, u, None)?
        .with_noise(NoiseVariances::output_only(vec![var; omega.len()]))?;

    // the user's one-mass model, the sensor gain held at its calibration
    let model = Fixed::physical(AutoDiff::new(RigidBody), &[("g", 1.0)])?;
    let start = model.theta_from_physical(&[0.05, 0.1])?;
    let out = Workflow::default().run_model(&data, model, &start, Context::periodic(0.05))?;

    let r = &out.report;
    println!(
        "start: {} — cost {:.1} (expected {:.0}), consistent with the noise: {}",
        r.initial_fit.custom.as_deref().unwrap_or("?"),
        r.initial_fit.cost,
        r.initial_fit.validation.cost_expected.unwrap_or(f64::NAN),
        r.initial_fit.consistent_with_noise(0.05)
    );
    for (step, fit) in r.steps.iter().zip(&r.step_fits) {
        println!(
            "step {}: detector p = {:.1e}, cost {:.1} → {:.1}, LR p = {:.1e}, detail {:?}\n  → {}",
            step.effect,
            step.p_value,
            step.cost_before,
            step.cost_after,
            step.lr_p,
            step.detail.entries(),
            fit.custom.as_deref().unwrap_or("?")
        );
    }
    println!("consistent with the noise: {}", r.consistent_with_noise);
    for f in &out.not_added {
        println!(
            "named, not added to a user model: {} (p = {:.1e})",
            f.effect, f.p_value
        );
    }
    for v in physical_values(&out.fit)
        .iter()
        .filter(|v| !v.name.starts_with("omega") && !v.name.starts_with("zeta"))
    {
        let std = v
            .std
            .map_or(String::from("fixed"), |s| format!("± {s:.2e}"));
        println!("{:>9} = {:.5} {} {std}", v.name, v.value, v.unit);
    }
    for v in out.modes() {
        println!(
            "{:>9} = {:.5} {} ± {:.2e}",
            v.name,
            v.value,
            v.unit,
            v.std.unwrap_or(f64::NAN)
        );
    }
    println!(
        "truth: antiresonance √(k/J₂) = {:.3} rad/s, resonance ≈ √(k(J₁+J₂)/(J₁J₂)) = {:.3} rad/s (undamped, without friction)",
        (40.0_f64 / 0.04).sqrt(),
        (40.0_f64 * 0.06 / 0.0008).sqrt()
    );
    Ok(())
}
