//! The regression matrix of the time-varying ODE by FFT (Lataire–Pintelon eqs. 11, 15, 18).
//!
//! The column of α̃ₙ,ₚ (resp. β̃ₙ,ₚ) is, for x = y (resp. u), eq. 15 with the bases of
//! eq. 3:
//!
//! ```text
//! K_x[k, (n, p)] = T_s · DFT{ b_p(t_d T_s) · iDFT{ Ψₙ(jω_k) · DFT{x(t_d T_s)} } }[k],   k ∈ 𝕂
//! ```
//!
//! with the unnormalised DFT X(k) = Σ_{t_d=0}^{N−1} x(t_d T_s) e^{−j2πk t_d/N} and
//! iDFT{X}(t_d) = (1/N) Σ_k X(k) e^{j2πk t_d/N} (eq. 13), over all N bins, Ψₙ evaluated at
//! the signed bin frequencies ω_k = 2πk/(N T_s) for k ≤ N/2 and 2π(k − N)/(N T_s) above,
//! so that Ψₙ{x} is real. At the Nyquist bin of an even N only the real part of Ψₙ is used
//! (odd Ψₙ give 0 there), which is the real part of the inverse transform.
//!
//! The cost is one forward FFT per signal, (N_x + 1) inverse FFTs and ⌈(N_x + 1)(N_p + 1)/2⌉
//! forward FFTs (two real sequences packed in one complex FFT), all with one plan pair:
//! O(columns · N log N), no dense DFT matrix.

use super::model::LtvOde;
use crate::data::TimeData;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The set 𝕂 of DFT lines the model equation is evaluated on (Lataire–Pintelon eq. 5).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Lines<T> {
    /// Every line k with f_lo ≤ k/(N T_s) ≤ f_hi (Hz); f_hi must not exceed the Nyquist
    /// frequency 1/(2 T_s).
    Band {
        /// Lower edge (Hz).
        f_lo: T,
        /// Upper edge (Hz).
        f_hi: T,
    },
    /// Explicit line indices k (0 ≤ k ≤ N/2), strictly increasing.
    Indices(Vec<usize>),
}

impl<T: Real> Lines<T> {
    /// The band [f_lo, f_hi] in Hz.
    pub fn band(f_lo: T, f_hi: T) -> Self {
        Self::Band { f_lo, f_hi }
    }

    /// The line indices selected on a record of `n` samples at sample time `ts` (s).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `band` for non-finite or negative edges,
    ///   f_lo > f_hi, or f_hi above the Nyquist frequency 1/(2 T_s);
    /// - [`FdidError::EmptyBand`] (edges in rad/s) when the band holds no line;
    /// - [`FdidError::InvalidArgument`] named `line index` for an index above N/2 or
    ///   indices that do not strictly increase; [`FdidError::TooShort`] for an empty list.
    pub fn resolve(&self, n: usize, ts: T) -> Result<Vec<usize>> {
        match self {
            Self::Band { f_lo, f_hi } => {
                let (lo, hi) = (f_lo.to_f64_lossless(), f_hi.to_f64_lossless());
                let fs = 1.0 / ts.to_f64_lossless();
                let bad = |reason: String| FdidError::InvalidArgument {
                    name: "band",
                    value: format!("[{lo}, {hi}] Hz"),
                    reason,
                };
                if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo <= hi) {
                    return Err(bad("the edges must be finite with 0 ≤ f_lo ≤ f_hi".into()));
                }
                // a relative tolerance of a few ε of T lets f_hi = fs/2 computed in T pass
                let tol = 1.0 + 8.0 * T::default_epsilon().to_f64_lossless();
                if hi > 0.5 * fs * tol {
                    return Err(bad(format!(
                        "the upper edge is above the Nyquist frequency {} Hz",
                        0.5 * fs
                    )));
                }
                let df = fs / n as f64;
                let k_lo = (lo / df * (1.0 - 1e-12)).ceil().max(0.0) as usize;
                let k_hi = ((hi / df * (1.0 + 1e-12)).floor() as usize).min(n / 2);
                if k_lo > k_hi {
                    let tau = std::f64::consts::TAU;
                    return Err(FdidError::EmptyBand {
                        min: tau * lo,
                        max: tau * hi,
                    });
                }
                Ok((k_lo..=k_hi).collect())
            }
            Self::Indices(k) => {
                if k.is_empty() {
                    return Err(FdidError::TooShort {
                        what: "line indices",
                        needed: 1,
                        got: 0,
                    });
                }
                for (i, v) in k.iter().enumerate() {
                    if *v > n / 2 {
                        return Err(FdidError::InvalidArgument {
                            name: "line index",
                            value: format!("{v} at entry {i}"),
                            reason: format!("lines run from 0 to N/2 = {}", n / 2),
                        });
                    }
                    if i > 0 && *v <= k[i - 1] {
                        return Err(FdidError::InvalidArgument {
                            name: "line index",
                            value: format!("{v} at entry {i}"),
                            reason: "line indices must strictly increase".into(),
                        });
                    }
                }
                Ok(k.clone())
            }
        }
    }
}

/// The complex regression matrix K = [K_Y, −K_U, Φ] of eq. 11 on the lines 𝕂, with the
/// columns in the order of θ (see [`LtvOde`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Regression<T: Real> {
    /// K, |𝕂| × [`LtvOde::n_params`].
    pub matrix: DMatrix<Complex<T>>,
    /// The line indices k ∈ 𝕂.
    pub lines: Vec<usize>,
    /// Their angular frequencies ω_k = 2πk/(N T_s) (rad/s).
    pub omega: Vec<T>,
    /// Record length T = N T_s (s).
    pub record: T,
    /// Frequency scale ω_tr of the transient polynomial: the highest frequency of 𝕂 (the
    /// first line frequency when 𝕂 = {0}).
    pub transient_scale: T,
}

/// The most time-basis order a record of N samples supports: ⌊√N⌋. Polynomials of order
/// p sampled on N equispaced points are well conditioned only while p² ≲ N (the discrete
/// Legendre polynomials stay close to the continuous ones); beyond that the time
/// variation is not resolved by the record.
pub fn max_time_order(n_samples: usize) -> usize {
    let mut r = (n_samples as f64).sqrt() as usize;
    while (r + 1) * (r + 1) <= n_samples {
        r += 1;
    }
    while r * r > n_samples {
        r -= 1;
    }
    r
}

/// Builds the regression matrix K of eq. 11 (columns by eq. 15, transient columns by
/// eq. 18) for `model` on the record `data` and the lines `lines`.
///
/// # Errors
/// - settings: [`LtvOde::validate`];
/// - lines: [`Lines::resolve`];
/// - [`FdidError::InvalidArgument`] named `n_p` when N_p > [`max_time_order`]`(N)`;
/// - [`FdidError::TooFewFrequencies`] when 2|𝕂| < [`LtvOde::n_params`].
pub fn regression<T: Real>(
    model: &LtvOde<T>,
    data: &TimeData<T>,
    lines: &Lines<T>,
) -> Result<Regression<T>> {
    model.validate()?;
    let n = data.len();
    let ts = data.ts();
    if model.n_p() > max_time_order(n) {
        return Err(FdidError::InvalidArgument {
            name: "n_p",
            value: format!("{}", model.n_p()),
            reason: format!(
                "a record of {n} samples resolves time polynomials up to order ⌊√N⌋ = {}",
                max_time_order(n)
            ),
        });
    }
    let lines = lines.resolve(n, ts)?;
    let p = model.n_params();
    if 2 * lines.len() < p {
        return Err(FdidError::TooFewFrequencies {
            lines: lines.len(),
            equations: 2 * lines.len(),
            parameters: p,
        });
    }
    let tau = std::f64::consts::TAU;
    let tsf = ts.to_f64_lossless();
    let omega_of = |k: isize| T::lit(tau * k as f64 / (n as f64 * tsf));
    let omega: Vec<T> = lines.iter().map(|k| omega_of(*k as isize)).collect();
    let record = T::from_usize_lossy(n) * ts;

    // b_p(t_d T_s), one row per p
    let np = model.n_p();
    let mut basis_t = vec![vec![T::zero(); n]; np + 1];
    let mut b = vec![T::zero(); np + 1];
    for td in 0..n {
        model
            .time_basis()
            .eval_into(T::from_usize_lossy(td) * ts, record, &mut b);
        for (row, v) in basis_t.iter_mut().zip(&b) {
            row[td] = *v;
        }
    }

    let mut planner = FftPlanner::<T>::new();
    let fft = Fft2 {
        forward: planner.plan_fft_forward(n),
        inverse: planner.plan_fft_inverse(n),
    };
    let signed: Vec<T> = (0..n)
        .map(|k| {
            if k <= n / 2 {
                omega_of(k as isize)
            } else {
                omega_of(k as isize - n as isize)
            }
        })
        .collect();
    let mut matrix = DMatrix::from_element(lines.len(), p, Complex::new(T::zero(), T::zero()));
    let ctx = Context {
        fft: &fft,
        basis_t: &basis_t,
        signed: &signed,
        lines: &lines,
        ts,
    };
    ctx.signal_columns(
        data.y(),
        model,
        model.n_alpha(),
        model.alpha_index(0, 0),
        T::one(),
        &mut matrix,
    );
    ctx.signal_columns(
        data.u(),
        model,
        model.n_beta(),
        model.beta_index(0, 0),
        -T::one(),
        &mut matrix,
    );

    let w_top = omega.iter().fold(T::zero(), |m, w| Float::max(m, *w));
    let transient_scale = if w_top > T::zero() {
        w_top
    } else {
        omega_of(1)
    };
    if let Some(order) = model.transient_order() {
        let mut phi = vec![Complex::new(T::zero(), T::zero()); order + 1];
        for (row, w) in omega.iter().enumerate() {
            super::basis::legendre_complex_into(*w / transient_scale, &mut phi);
            for (m, v) in phi.iter().enumerate() {
                matrix[(row, model.transient_index(m))] = *v;
            }
        }
    }
    Ok(Regression {
        matrix,
        lines,
        omega,
        record,
        transient_scale,
    })
}

struct Fft2<T: Real> {
    forward: Arc<dyn Fft<T>>,
    inverse: Arc<dyn Fft<T>>,
}

struct Context<'a, T: Real> {
    fft: &'a Fft2<T>,
    basis_t: &'a [Vec<T>],
    signed: &'a [T],
    lines: &'a [usize],
    ts: T,
}

impl<T: Real> Context<'_, T> {
    /// Writes the columns of x for n = 0 … `order`, p = 0 … N_p, starting at column `col0`
    /// (n major), times `sign`.
    fn signal_columns(
        &self,
        x: &[T],
        model: &LtvOde<T>,
        order: usize,
        col0: usize,
        sign: T,
        out: &mut DMatrix<Complex<T>>,
    ) {
        let n = x.len();
        let zero = Complex::new(T::zero(), T::zero());
        let scratch_len = self
            .fft
            .forward
            .get_inplace_scratch_len()
            .max(self.fft.inverse.get_inplace_scratch_len());
        let mut scratch = vec![zero; scratch_len];
        let mut spec: Vec<Complex<T>> = x.iter().map(|v| Complex::new(*v, T::zero())).collect();
        self.fft
            .forward
            .process_with_scratch(&mut spec, &mut scratch);

        // Ψₙ(jω_k) X(k) for every n and bin
        let basis = model.frequency_basis();
        let mut filtered = vec![vec![zero; n]; order + 1];
        let mut psi = vec![zero; order + 1];
        for (k, (xk, w)) in spec.iter().zip(self.signed).enumerate() {
            basis.eval_into(*w, &mut psi);
            let nyquist = n.is_multiple_of(2) && k == n / 2;
            for (f, ps) in filtered.iter_mut().zip(&psi) {
                let ps = if nyquist {
                    Complex::new(ps.re, T::zero())
                } else {
                    *ps
                };
                f[k] = *xk * ps;
            }
        }
        // Ψₙ{x}(t_d) = iDFT (real), then b_p · Ψₙ{x} two at a time through one FFT
        let inv_n = T::one() / T::from_usize_lossy(n);
        let half = T::lit(0.5);
        let mut z = vec![T::zero(); n];
        let mut buf = vec![zero; n];
        let np = self.basis_t.len() - 1;
        for (nn, f) in filtered.iter_mut().enumerate() {
            self.fft.inverse.process_with_scratch(f, &mut scratch);
            for (zt, ft) in z.iter_mut().zip(f.iter()) {
                *zt = ft.re * inv_n;
            }
            let mut p = 0;
            while p <= np {
                let pair = p < np;
                let b1 = &self.basis_t[p];
                for (t, o) in buf.iter_mut().enumerate() {
                    let im = if pair {
                        self.basis_t[p + 1][t] * z[t]
                    } else {
                        T::zero()
                    };
                    *o = Complex::new(b1[t] * z[t], im);
                }
                self.fft
                    .forward
                    .process_with_scratch(&mut buf, &mut scratch);
                for (row, k) in self.lines.iter().enumerate() {
                    let a = buf[*k];
                    let c = buf[(n - *k) % n].conj();
                    let w1 = (a + c) * half;
                    out[(row, col0 + nn * (np + 1) + p)] = w1 * (self.ts * sign);
                    if pair {
                        // (a − c)/(2j)
                        let d = (a - c) * half;
                        let w2 = Complex::new(d.im, -d.re);
                        out[(row, col0 + nn * (np + 1) + p + 1)] = w2 * (self.ts * sign);
                    }
                }
                p += 2;
            }
        }
    }
}
