use crate::data::DistortionAnalysis;
use crate::data::{FrequencyData, NoiseVariances};
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, Remedy, present,
};
use crate::workflow::spec::SpecFit;
use std::sync::Arc;

/// Energy above the noise at the non-excited lines of an odd random-phase multisine:
/// nonlinear distortion, which no linear model removes.
///
/// The test is that of [`DistortionAnalysis`]: at the odd and, separately, the even
/// detection lines each |Ȳ_k|²/σ̂²_k ~ F(2, 2(P − 1)) under "noise only" (the linear data
/// model of McKelvey eq. 19), combined by Fisher's method into an exact p-value per kind;
/// with several phase realisations also the spread of the BLA between realisations
/// against its noise variance between periods
/// ([`DistortionAnalysis::spread_test`](crate::data::DistortionAnalysis::spread_test): the
/// stochastic nonlinear contribution changes between realisations, not between periods);
/// the finding's p-value is the smallest one times the number m ≤ 3 of tests
/// (Bonferroni), its statistic the Fisher statistic of that test. The analysis is the
/// [`Context`]'s ([`Context::with_distortion`], e.g. over several phase realisations) or
/// else built from its periodic record ([`Context::with_record`]) with the fitted lines as
/// the excited lines and the band they span.
///
/// **The model stays linear.** At the excited lines the output of a random-phase
/// multisine is Y = G_BLA U + Y_S + N: the stochastic nonlinear contribution Y_S behaves
/// as a noise of variance σ²_S,k that does not average over periods, so the fit of a
/// linear model is the parametric best linear approximation (BLA) and its residual keeps
/// Y_S. The remedy ([`Remedy::NoiseReference`]) keeps the model and adds σ̂²_S,k
/// ([`DistortionAnalysis::excited_distortion_power`], interpolated from the odd detection
/// lines) to the output noise variance of each fitted line, so that the final fit is
/// judged against "noise + nonlinear distortion": the residual that remains is
/// distortion, not a model error, and the workflow reports the effect as unmodelled. The
/// step is accepted on this test alone (the nested likelihood-ratio test does not apply:
/// the model does not change). With one realisation the fitted data must be the averaged
/// spectra of that realisation (the record's). With several realisations the fitted data
/// are the BLA (`Y = Ĝ`, `U = 1`) weighted by its noise variance between periods, and the
/// remedy puts the total variance between realisations, `|U_k|² σ̂²_Ĝ,k`, in its place
/// (noise + nonlinear distortion); `distortion_to_noise_db` is then that of the nonlinear
/// variance (total − noise).
///
/// Applies to output-error or EIV fits with given noise variances; `None` without an
/// analysis or record, when a fitted line is not an excited line of the analysis, or when
/// no detection test exists. Detail: [`NonlinearDistortionDetail`].
#[derive(Debug, Clone, Copy, Default)]
pub struct NonlinearDistortion;

impl NonlinearDistortion {
    /// The analysis of `ctx` (given or built from its record) and, for each fitted line,
    /// its index among the analysis's excited lines.
    fn analysis(
        fit: &SpecFit,
        ctx: &Context,
    ) -> Option<(Arc<DistortionAnalysis<f64>>, Vec<usize>)> {
        let analysis = match (&ctx.distortion, &ctx.record) {
            (Some(a), _) => a.clone(),
            (None, Some(rec)) => {
                let lines = rec.period_lines(&fit.omega)?;
                let lo = *lines.iter().min()?;
                let hi = *lines.iter().max()?;
                Arc::new(
                    DistortionAnalysis::new(rec.record(), rec.periods(), &lines, [lo, hi]).ok()?,
                )
            }
            (None, None) => return None,
        };
        let omega = analysis.omega();
        let index = fit
            .omega
            .iter()
            .map(|w| {
                omega
                    .iter()
                    .position(|v| (v - w).abs() <= 1e-9 * w.abs().max(1e-300))
            })
            .collect::<Option<Vec<usize>>>()?;
        Some((analysis, index))
    }
}

impl Detector for NonlinearDistortion {
    fn effect(&self) -> Effect {
        Effect::NonlinearDistortion
    }

    fn measurement(&self) -> bool {
        true
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        let noise = data.noise()?;
        let (analysis, index) = Self::analysis(fit, ctx)?;
        // (p-value, statistic) of each test: odd and even detection lines, and with several
        // realisations their spread against the noise
        let tests: Vec<(f64, f64)> = [analysis.odd(), analysis.even()]
            .into_iter()
            .flatten()
            .map(|t| (t.p_value(), t.fisher_statistic))
            .chain(
                analysis
                    .spread_test()
                    .map(|t| (t.p_value, t.fisher_statistic)),
            )
            .collect();
        let best = tests.iter().min_by(|a, b| a.0.total_cmp(&b.0))?;
        let p_value = (best.0 * tests.len() as f64).min(1.0);
        let v = noise.var_y.iter().sum::<f64>() / noise.var_y.len() as f64;
        let distortion_to_noise_db = if analysis.realisations() >= 2 {
            // the nonlinear variance of the BLA (total − noise) at the fitted lines, as output
            // power |U_k|² σ²_Ĝ,S,k
            analysis.bla_nonlinear_variance().and_then(|nl| {
                let d = index
                    .iter()
                    .zip(data.u())
                    .map(|(i, u)| nl[*i] * u.norm_sqr())
                    .sum::<f64>()
                    / index.len() as f64;
                (d > 0.0 && v > 0.0).then(|| 10.0 * (d / v).log10())
            })
        } else {
            analysis.excited_distortion_power().and_then(|ds| {
                let d = index.iter().map(|i| ds[*i]).sum::<f64>() / index.len() as f64;
                (d > 0.0 && v > 0.0).then(|| 10.0 * (d / v).log10())
            })
        };
        let detail = NonlinearDistortionDetail {
            odd_p: analysis.odd().map(|t| t.p_value()),
            odd_db: analysis.odd().and_then(|t| t.distortion_db),
            even_p: analysis.even().map(|t| t.p_value()),
            even_db: analysis.even().and_then(|t| t.distortion_db),
            noise_db: analysis.noise_db(),
            distortion_to_noise_db,
            realisations: analysis.realisations(),
        };
        Some(Finding {
            effect: Effect::NonlinearDistortion,
            statistic: best.1,
            p_value,
            detail: Detail::NonlinearDistortion(detail),
            proposal: fit.spec.clone(),
        })
    }

    fn remedy(
        &self,
        data: &FrequencyData<f64>,
        fit: &SpecFit,
        ctx: &Context,
        _finding: &Finding,
    ) -> Option<Remedy> {
        let noise = data.noise()?;
        let (analysis, index) = Self::analysis(fit, ctx)?;
        let mut var_y = noise.var_y.clone();
        if analysis.realisations() >= 2 {
            // the total variance of the BLA (between realisations), as output variance
            let total = analysis.bla_total_variance();
            for ((v, i), u) in var_y.iter_mut().zip(&index).zip(data.u()) {
                *v = v.max(total[*i] * u.norm_sqr());
            }
        } else if let Some(ds) = analysis.excited_distortion_power() {
            for (v, i) in var_y.iter_mut().zip(&index) {
                *v += ds[*i].max(0.0);
            }
        }
        let reference = NoiseVariances {
            var_y,
            ..noise.clone()
        };
        // the degrees of freedom of the sample variances are kept
        Some(Remedy::NoiseReference(
            data.clone().with_noise(reference).ok()?,
        ))
    }
}

/// The detail of a [`NonlinearDistortion`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonlinearDistortionDetail {
    /// The odd detection lines' test p-value, when that test exists, named `odd_p`.
    pub odd_p: Option<f64>,
    /// The distortion power at the odd detection lines relative to the output power at the
    /// excited lines (dB), when above the noise, named `odd_db`.
    pub odd_db: Option<f64>,
    /// The even detection lines' test p-value, when that test exists, named `even_p`.
    pub even_p: Option<f64>,
    /// As `odd_db` at the even detection lines, named `even_db`.
    pub even_db: Option<f64>,
    /// The noise power relative to the output (dB), named `noise_db`.
    pub noise_db: f64,
    /// The mean σ̂²_S,k over the mean output noise variance at the fitted lines (dB), when
    /// positive, named `distortion_to_noise_db`.
    pub distortion_to_noise_db: Option<f64>,
    /// The number of phase realisations of the analysis, named `realisations`.
    pub realisations: usize,
}

impl DetailFields for NonlinearDistortionDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        present([
            ("odd_p", self.odd_p),
            ("odd_db", self.odd_db),
            ("even_p", self.even_p),
            ("even_db", self.even_db),
            ("noise_db", Some(self.noise_db)),
            ("distortion_to_noise_db", self.distortion_to_noise_db),
            ("realisations", Some(self.realisations as f64)),
        ])
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            odd_p: values.take("odd_p"),
            odd_db: values.take("odd_db"),
            even_p: values.take("even_p"),
            even_db: values.take("even_db"),
            noise_db: values.take("noise_db")?,
            distortion_to_noise_db: values.take("distortion_to_noise_db"),
            realisations: values.take_count("realisations")?,
        })
    }
}
