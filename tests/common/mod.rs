//! Simulation helpers shared by tests and benches: systems with known poles and zeros,
//! their exact frequency responses, and seeded Gaussian noise.
#![allow(dead_code)]

use fdid::{Complex, Real};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A system in factored form G(v) = k Π(v − zᵢ)/Π(v − pⱼ), v = s or z (for z, times
/// z^{−delay} handled by the caller).
#[derive(Debug, Clone)]
pub struct Zpk {
    pub zeros: Vec<Complex<f64>>,
    pub poles: Vec<Complex<f64>>,
    pub gain: f64,
    /// sample time for a discrete-time system
    pub ts: Option<f64>,
}

impl Zpk {
    /// G at angular frequency ω (rad/s).
    pub fn eval(&self, omega: f64) -> Complex<f64> {
        let v = match self.ts {
            None => Complex::new(0.0, omega),
            Some(ts) => Complex::new(0.0, omega * ts).exp(),
        };
        let num = self
            .zeros
            .iter()
            .fold(Complex::new(self.gain, 0.0), |a, z| a * (v - z));
        let den = self
            .poles
            .iter()
            .fold(Complex::new(1.0, 0.0), |a, p| a * (v - p));
        num / den
    }

    pub fn frf(&self, omega: &[f64]) -> Vec<Complex<f64>> {
        omega.iter().map(|w| self.eval(*w)).collect()
    }

    /// In the scalar type T.
    pub fn frf_t<T: Real>(&self, omega: &[f64]) -> Vec<Complex<T>> {
        self.frf(omega)
            .into_iter()
            .map(|g| Complex::new(T::lit(g.re), T::lit(g.im)))
            .collect()
    }
}

/// Modal form Σ gᵢ ωᵢ² / (s² + 2ζᵢωᵢ s + ωᵢ²) as poles and a polynomial numerator given
/// by its values: returns (poles, frf function).
pub fn modal(wn: &[f64], zeta: &[f64], gain: &[f64]) -> Modal {
    Modal {
        wn: wn.to_vec(),
        zeta: zeta.to_vec(),
        gain: gain.to_vec(),
    }
}

#[derive(Debug, Clone)]
pub struct Modal {
    pub wn: Vec<f64>,
    pub zeta: Vec<f64>,
    pub gain: Vec<f64>,
}

impl Modal {
    pub fn eval(&self, omega: f64) -> Complex<f64> {
        let s = Complex::new(0.0, omega);
        let mut g = Complex::new(0.0, 0.0);
        for i in 0..self.wn.len() {
            let w = self.wn[i];
            g += self.gain[i] * w * w / (s * s + 2.0 * self.zeta[i] * w * s + w * w);
        }
        g
    }
    pub fn frf(&self, omega: &[f64]) -> Vec<Complex<f64>> {
        omega.iter().map(|w| self.eval(*w)).collect()
    }
    pub fn poles(&self) -> Vec<Complex<f64>> {
        let mut p = vec![];
        for i in 0..self.wn.len() {
            let (w, z) = (self.wn[i], self.zeta[i]);
            p.push(Complex::new(-z * w, w * (1.0 - z * z).sqrt()));
            p.push(Complex::new(-z * w, -w * (1.0 - z * z).sqrt()));
        }
        p
    }
}

/// The peers' b_ct10 system: five modes, 0.1–10 rad/s.
pub fn b_ct10() -> Modal {
    modal(
        &[0.3, 0.7, 1.5, 3.2, 7.0],
        &[0.02, 0.03, 0.02, 0.05, 0.04],
        &[1.0, 1.0, 1.0, 1.0, 1.0],
    )
}

/// The peers' a_ct4 system: two modes.
pub fn a_ct4() -> Modal {
    modal(&[1.0, 3.2], &[0.02, 0.05], &[1.0, 5.0])
}

/// Five resonances spread over four decades (a wide-band stress case).
pub fn five_resonances() -> Zpk {
    let mut poles = vec![];
    for (wn, zeta) in [
        (1.0, 0.05),
        (5.0, 0.03),
        (30.0, 0.04),
        (200.0, 0.02),
        (1500.0, 0.05),
    ] {
        let re = -zeta * wn;
        let im = wn * (1.0f64 - zeta * zeta).sqrt();
        poles.push(Complex::new(re, im));
        poles.push(Complex::new(re, -im));
    }
    let zeros = vec![
        Complex::new(-3.0, 0.0),
        Complex::new(-0.5, 12.0),
        Complex::new(-0.5, -12.0),
        Complex::new(-8.0, 90.0),
        Complex::new(-8.0, -90.0),
        Complex::new(-700.0, 0.0),
    ];
    let mut g = Zpk {
        zeros,
        poles,
        gain: 1.0,
        ts: None,
    };
    let g0 = g.eval(0.0).norm();
    g.gain = 1.0 / g0;
    g
}

/// Two resonances (an order-4 CT case).
pub fn two_resonances() -> Zpk {
    let mut poles = vec![];
    for (wn, zeta) in [(2.0, 0.05), (20.0, 0.1)] {
        let re = -zeta * wn;
        let im = wn * (1.0f64 - zeta * zeta).sqrt();
        poles.push(Complex::new(re, im));
        poles.push(Complex::new(re, -im));
    }
    let zeros = vec![Complex::new(-5.0, 0.0)];
    let mut g = Zpk {
        zeros,
        poles,
        gain: 1.0,
        ts: None,
    };
    let g0 = g.eval(0.0).norm();
    g.gain = 1.0 / g0;
    g
}

pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 10f64.powf(lo + (hi - lo) * k as f64 / (n - 1).max(1) as f64))
        .collect()
}

/// Seeded circular complex Gaussian noise with E|n|² = var.
pub struct Noise(StdRng);

impl Noise {
    pub fn new(seed: u64) -> Self {
        Noise(StdRng::seed_from_u64(seed))
    }
    pub fn gauss(&mut self) -> f64 {
        // Box–Muller
        let u1: f64 = self.0.gen_range(f64::MIN_POSITIVE..1.0);
        let u2: f64 = self.0.r#gen();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
    pub fn complex(&mut self, var: f64) -> Complex<f64> {
        let s = (var / 2.0).sqrt();
        Complex::new(s * self.gauss(), s * self.gauss())
    }
}

/// Relative RMS error ‖a − b‖/‖b‖.
pub fn rel_rms<T: Real>(a: &[Complex<T>], b: &[Complex<f64>]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let x = Complex::new(x.re.to_f64_lossless(), x.im.to_f64_lossless());
        num += (x - y).norm_sqr();
        den += y.norm_sqr();
    }
    (num / den).sqrt()
}
