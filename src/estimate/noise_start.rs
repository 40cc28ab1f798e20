//! A linear start for the noise model H = C/D of the noise-model ML: the two regressions
//! of Hannan and Rissanen, on the DFT lines instead of the samples.
//!
//! From H = 1 (η = 0) the ML of a noise model of high order starts where the columns of
//! ∂H/∂c_j and ∂H/∂d_j are equal and opposite (C = D), and Levenberg–Marquardt needs
//! hundreds of iterations to leave that singular point. The residuals ε_k = Y_k − Ŷ_k of
//! the system's start are (to first order) H(ω_k)E_k, so H can be estimated linearly:
//!
//! 1. a long autoregression: the monic A_L of order L minimising Σ_k |A_L(z_k⁻¹) ε_k|²
//!    (least squares in its coefficients), whose output ê_k = A_L(z_k⁻¹) ε_k estimates
//!    the innovations E_k;
//! 2. the ARMA regression D ε = C ê, i.e. Σ_j d_j z_k⁻ʲ ε_k − Σ_j c_j z_k⁻ʲ ê_k ≈ ê_k − ε_k,
//!    least squares in η = [c, d];
//!
//! with z_k = e^{iω_kTs}. The roots are then reflected into the unit disc
//! ([`NoiseModel::stabilised`]).

use crate::linalg::least_squares;
use crate::model::NoiseModel;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};

/// Order L of the long autoregression for a noise model of orders (`nc`, `nd`) on `lines`
/// lines: 2·max(nc, nd) + 10, at most a quarter of the lines.
fn long_order(nc: usize, nd: usize, lines: usize) -> usize {
    (2 * nc.max(nd) + 10).min(lines / 4)
}

/// The least-squares solution of Σ_j x_j col_j(k) ≈ rhs_k over the lines k (complex
/// equations, real-stacked), `None` when it fails.
fn solve<T: Real>(columns: &[&[Complex<T>]], rhs: &[Complex<T>]) -> Option<Vec<T>> {
    let n = rhs.len();
    let a = DMatrix::from_fn(2 * n, columns.len(), |row, j| {
        let v = columns[j][row / 2];
        if row % 2 == 0 { v.re } else { v.im }
    });
    let b = DVector::from_fn(2 * n, |row, _| {
        let v = rhs[row / 2];
        if row % 2 == 0 { v.re } else { v.im }
    });
    let (x, _) = least_squares(a, b, 1e-12).ok()?;
    Some(x.iter().copied().collect())
}

/// The columns z_k⁻ʲ·`sign`·v_k, j = 1 … `lags`, with z_k⁻¹ = `zinv`[k] (each column from
/// the one before: one complex product per value).
fn lagged<T: Real>(
    v: &[Complex<T>],
    zinv: &[Complex<T>],
    lags: usize,
    sign: T,
) -> Vec<Vec<Complex<T>>> {
    let mut out: Vec<Vec<Complex<T>>> = Vec::with_capacity(lags);
    let mut previous: Vec<Complex<T>> = v.iter().map(|x| *x * sign).collect();
    for _ in 0..lags {
        previous = previous.iter().zip(zinv).map(|(x, z)| *x * *z).collect();
        out.push(previous.clone());
    }
    out
}

/// The start η₀ = [c₁ … c_nc, d₁ … d_nd] of `noise` from the residuals `eps` of the
/// system's start on the lines `omega` (module documentation); `None` when the lines are
/// too few for the long autoregression (L < max(nc, nd) + 1), a regression fails, or the
/// result is not finite.
pub(crate) fn hannan_rissanen<T: Real>(
    noise: &NoiseModel<T>,
    eps: &[Complex<T>],
    omega: &[T],
) -> Option<Vec<T>> {
    let (nc, nd) = (noise.nc(), noise.nd());
    let ts = noise.ts();
    let long = long_order(nc, nd, eps.len());
    if long < nc.max(nd) + 1 || eps.len() < 2 * (nc + nd) + 1 {
        return None;
    }
    let zinv: Vec<Complex<T>> = omega
        .iter()
        .map(|w| Complex::from_polar(T::one(), -*w * ts))
        .collect();
    // 1. the long autoregression: ε_k + Σ a_j z⁻ʲ ε_k ≈ 0
    let past = lagged(eps, &zinv, long, T::one());
    let slices: Vec<&[Complex<T>]> = past.iter().map(Vec::as_slice).collect();
    let minus: Vec<Complex<T>> = eps.iter().map(|v| -*v).collect();
    let a = solve(&slices, &minus)?;
    let innovations: Vec<Complex<T>> = (0..eps.len())
        .map(|k| {
            past.iter()
                .zip(&a)
                .fold(eps[k], |s, (col, aj)| s + col[k] * *aj)
        })
        .collect();
    // 2. Σ c_j (−z⁻ʲ ê) + Σ d_j (z⁻ʲ ε) ≈ ê − ε
    let past_innovations = lagged(&innovations, &zinv, nc, -T::one());
    let columns: Vec<&[Complex<T>]> = past_innovations
        .iter()
        .chain(&past[..nd])
        .map(Vec::as_slice)
        .collect();
    let rhs: Vec<Complex<T>> = innovations.iter().zip(eps).map(|(e, x)| *e - *x).collect();
    let eta = solve(&columns, &rhs)?;
    let eta = noise.stabilised(&eta).ok()?;
    eta.iter()
        .all(|v| num_traits::Float::is_finite(*v))
        .then_some(eta)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::SplitMix64;

    /// ε_k = H(ω_k)E_k with H = (1 + 0.5z⁻¹)/(1 − 0.9z⁻¹) and white complex E on the
    /// interior lines of a 4 096-sample grid: the linear start is within a few standard
    /// deviations of c₁ = 0.5, d₁ = −0.9 (the ML spread on 2 047 lines is about 0.02).
    #[test]
    fn arma_one_one_is_recovered_from_its_residuals() {
        let (n, ts) = (4096, 1.0);
        let omega: Vec<f64> = (1..n / 2)
            .map(|k| std::f64::consts::TAU * k as f64 / n as f64)
            .collect();
        let mut rng = SplitMix64::new(7);
        let eps: Vec<Complex<f64>> = omega
            .iter()
            .map(|w| {
                let zinv = Complex::from_polar(1.0, -w);
                let h = (1.0 + 0.5 * zinv) / (1.0 - 0.9 * zinv);
                h * Complex::new(rng.gaussian(), rng.gaussian())
            })
            .collect();
        let noise = NoiseModel::new(1, 1, ts).unwrap();
        let eta = hannan_rissanen(&noise, &eps, &omega).unwrap();
        println!("ARMA(1, 1) start {eta:?}");
        assert!((eta[0] - 0.5).abs() < 0.08, "{eta:?}");
        assert!((eta[1] + 0.9).abs() < 0.03, "{eta:?}");
        // an over-parameterised model still gives a finite, stable start
        let noise = NoiseModel::new(10, 10, ts).unwrap();
        let eta = hannan_rissanen(&noise, &eps, &omega).unwrap();
        assert_eq!(eta.len(), 20);
        assert_eq!(noise.stabilised(&eta).unwrap(), eta);
        // too few lines for the long autoregression
        assert!(hannan_rissanen(&noise, &eps[..40], &omega[..40]).is_none());
    }
}
