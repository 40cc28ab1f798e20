//! The best linear approximation at the excited lines: per realisation with its noise
//! variance, the mean over realisations, and its nonlinear and total variances.

use super::{f64c, noise_of};
use crate::data::PeriodicAverage;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};

/// The BLA at the excited lines from `R` realisations.
pub(super) struct Bla {
    /// Per realisation `Ĝ_r,k = Ȳ_r,k / Ū_r,k`.
    per_realisation: Vec<Vec<Complex<f64>>>,
    /// `mean_r |Ū_r,k|²`.
    input_power: Vec<f64>,
    /// `P_Y = mean |Ȳ_r,k|²` over the excited lines and the realisations.
    pub(super) output_power: f64,
    /// `Ĝ_k = mean_r Ĝ_r,k`.
    pub(super) mean: Vec<Complex<f64>>,
    /// The noise variance of the mean, `(1/R²) Σ_r σ̂²_Ĝ,n,r`.
    pub(super) noise_variance: Vec<f64>,
}

impl Bla {
    /// The BLA of the period averages `averages` (one per realisation) at the lines
    /// `excited`, whose frequencies are `omega[k]`.
    ///
    /// # Errors
    /// [`FdidError::ZeroInput`] when the input at an excited line is zero or at the
    /// rounding level of the largest excited line.
    pub(super) fn new<T: Real>(
        averages: &[PeriodicAverage<T>],
        excited: &[usize],
        omega: &[T],
    ) -> Result<Self> {
        let r = averages.len();
        let r_f = r as f64;
        let mut per_realisation: Vec<Vec<Complex<f64>>> = Vec::with_capacity(r);
        let mut noise_per_realisation: Vec<Vec<f64>> = Vec::with_capacity(r);
        let mut input_power = vec![0.0; excited.len()];
        let mut output_power = 0.0;
        for avg in averages {
            let (g, gv) = realisation(
                avg,
                excited,
                omega,
                r_f,
                &mut input_power,
                &mut output_power,
            )?;
            per_realisation.push(g);
            noise_per_realisation.push(gv);
        }
        let n_exc = excited.len();
        output_power /= (n_exc * r) as f64;
        let mean = (0..n_exc)
            .map(|i| per_realisation.iter().map(|g| g[i]).sum::<Complex<f64>>() / r_f)
            .collect();
        let noise_variance = (0..n_exc)
            .map(|i| noise_per_realisation.iter().map(|v| v[i]).sum::<f64>() / (r_f * r_f))
            .collect();
        Ok(Self {
            per_realisation,
            input_power,
            output_power,
            mean,
            noise_variance,
        })
    }

    /// The nonlinear and total variances of the mean: from the spread over realisations
    /// when `R ≥ 2`; else the output power of the nonlinear contribution at the excited
    /// lines, `excited_distortion` (none without odd detection lines), over `|Ū_k|²`.
    pub(super) fn variances(
        &self,
        excited_distortion: Option<&[f64]>,
    ) -> (Option<Vec<f64>>, Vec<f64>) {
        if self.per_realisation.len() >= 2 {
            let total = self.spread();
            let nl = total
                .iter()
                .zip(&self.noise_variance)
                .map(|(t, n)| (t - n).max(0.0))
                .collect();
            return (Some(nl), total);
        }
        match excited_distortion {
            Some(d) => {
                let nl: Vec<f64> = d
                    .iter()
                    .zip(&self.input_power)
                    .map(|(d, u2)| d / u2)
                    .collect();
                let total = nl
                    .iter()
                    .zip(&self.noise_variance)
                    .map(|(a, b)| a + b)
                    .collect();
                (Some(nl), total)
            }
            None => (None, self.noise_variance.clone()),
        }
    }

    /// The sample variance of the mean over the realisations,
    /// `(1/(R(R − 1))) Σ_r |Ĝ_r,k − Ĝ_k|²`.
    fn spread(&self) -> Vec<f64> {
        let r_f = self.per_realisation.len() as f64;
        (0..self.mean.len())
            .map(|i| {
                self.per_realisation
                    .iter()
                    .map(|g| (g[i] - self.mean[i]).norm_sqr())
                    .sum::<f64>()
                    / (r_f * (r_f - 1.0))
            })
            .collect()
    }
}

/// The BLA of one realisation at the lines `excited` with its noise variance, adding
/// `|Ū_k|²/R` to `input_power` and `|Ȳ_k|²` to `output_power`.
fn realisation<T: Real>(
    avg: &PeriodicAverage<T>,
    excited: &[usize],
    omega: &[T],
    r_f: f64,
    input_power: &mut [f64],
    output_power: &mut f64,
) -> Result<(Vec<Complex<f64>>, Vec<f64>)> {
    let d = avg.data();
    let nv = noise_of(avg);
    let mut g = Vec::with_capacity(excited.len());
    let mut gv = Vec::with_capacity(excited.len());
    let u_floor = input_floor(avg, excited);
    for (i, &k) in excited.iter().enumerate() {
        let (y, u) = (f64c(d.y()[k]), f64c(d.u()[k]));
        let u2 = u.norm_sqr();
        if !(d.u()[k].norm() > u_floor) || !(u2 > 0.0) {
            return Err(FdidError::ZeroInput {
                index: k,
                omega: omega[k].to_f64_lossless(),
            });
        }
        let gk = y / u;
        let var = (nv.var_y[k].to_f64_lossless() + gk.norm_sqr() * nv.var_u[k].to_f64_lossless()
            - 2.0 * (gk.conj() * f64c(nv.cov_yu[k])).re)
            / u2;
        g.push(gk);
        gv.push(var.max(0.0));
        input_power[i] += u2 / r_f;
        *output_power += y.norm_sqr();
    }
    Ok((g, gv))
}

/// The input magnitude below which an excited line counts as not excited: the rounding
/// level `10³ ε max_k |Ū_k|` of the largest excited line.
fn input_floor<T: Real>(avg: &PeriodicAverage<T>, excited: &[usize]) -> T {
    let d = avg.data();
    let u_max = excited
        .iter()
        .map(|&k| d.u()[k].norm())
        .fold(T::zero(), |a, b| if b > a { b } else { a });
    T::lit(1e3) * <T as num_traits::Float>::epsilon() * u_max
}

/// Smoothed (3-point mean), linearly interpolated and clipped levels at `targets`.
pub(super) fn interpolate_levels(lines: &[usize], levels: &[f64], targets: &[usize]) -> Vec<f64> {
    let n = lines.len();
    let smooth: Vec<f64> = (0..n)
        .map(|j| {
            let lo = j.saturating_sub(1);
            let hi = (j + 1).min(n - 1);
            levels[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
        })
        .collect();
    targets
        .iter()
        .map(|&k| {
            let v = match lines.iter().position(|&l| l >= k) {
                Some(0) => smooth[0],
                None => smooth[n - 1],
                Some(j) => {
                    let (k0, k1) = (lines[j - 1] as f64, lines[j] as f64);
                    let t = (k as f64 - k0) / (k1 - k0);
                    smooth[j - 1] + t * (smooth[j] - smooth[j - 1])
                }
            };
            v.max(0.0)
        })
        .collect()
}
