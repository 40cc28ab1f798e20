//! A fitted model as `fdid fit --save` writes it: the JSON envelope (`format`, `version`,
//! `kind`, `domain`, `ts`, `source`, `fitted`) around the serialised [`FittedModel`].

use fdid::estimate::RationalFit;
use fdid::model::{Delayed, Domain, PolesZeros, Rational, WithNoiseModel};
use fdid::{Fit, FittedModel, ModelStructure};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Value, json};

use fdid::fitted::{SAVED_FORMAT as FORMAT, SAVED_VERSION as VERSION};

/// The fitted model of each kind of [`RationalFit`].
pub enum Fitted {
    Plain(FittedModel<f64, Rational<f64>>),
    Delayed(FittedModel<f64, Delayed<Rational<f64>>>),
    NoiseModel(FittedModel<f64, WithNoiseModel<Rational<f64>>>),
    DelayedNoiseModel(FittedModel<f64, WithNoiseModel<Delayed<Rational<f64>>>>),
}

/// Applies `$body` to the fitted model of every kind.
macro_rules! each {
    ($self:expr, $m:ident => $body:expr) => {
        match $self {
            Fitted::Plain($m) => $body,
            Fitted::Delayed($m) => $body,
            Fitted::NoiseModel($m) => $body,
            Fitted::DelayedNoiseModel($m) => $body,
        }
    };
}

/// A fitted model with its domain and its `kind` in the saved-model file.
pub struct Saved {
    pub model: Fitted,
    pub domain: Domain<f64>,
    kind: &'static str,
}

impl Saved {
    pub fn of_fit(fit: &RationalFit, domain: Domain<f64>) -> Self {
        let model = match fit {
            RationalFit::Plain(f) => Fitted::Plain(fitted(f)),
            RationalFit::Delayed(f) => Fitted::Delayed(fitted(f)),
            RationalFit::NoiseModel(f) => Fitted::NoiseModel(fitted(f)),
            RationalFit::DelayedNoiseModel(f) => Fitted::DelayedNoiseModel(fitted(f)),
        };
        Self {
            model,
            domain,
            kind: fit.kind(),
        }
    }

    /// Poles, zeros and gain of the factored form.
    pub fn factored(&self) -> fdid::Result<(Vec<Complex64>, Vec<Complex64>, f64)> {
        each!(&self.model, m => factored(m))
    }

    pub fn delay(&self) -> Option<f64> {
        match &self.model {
            Fitted::Delayed(m) => m.model.delay(&m.theta),
            Fitted::DelayedNoiseModel(m) => {
                let p = m.model.system().n_params();
                m.model.system().delay(&m.theta[..p])
            }
            _ => None,
        }
    }

    pub fn theta(&self) -> &[f64] {
        each!(&self.model, m => &m.theta)
    }

    pub fn covariance(&self) -> Option<&DMatrix<f64>> {
        each!(&self.model, m => m.covariance.as_ref())
    }

    pub fn cost(&self) -> f64 {
        each!(&self.model, m => m.cost)
    }

    pub fn noise_variance(&self) -> f64 {
        each!(&self.model, m => m.noise_variance)
    }

    pub fn lines(&self) -> usize {
        each!(&self.model, m => m.lines)
    }

    pub fn response(&self, omega: &[f64]) -> Vec<Complex64> {
        each!(&self.model, m => m.response(omega))
    }

    pub fn response_std(&self, omega: &[f64]) -> Option<Vec<f64>> {
        each!(&self.model, m => m.response_std(omega))
    }

    pub fn bounds(&self, omega: &[f64], level: f64) -> Option<Vec<fdid::fit::Bounds<f64>>> {
        each!(&self.model, m => m.bounds(omega, level))
    }

    /// The JSON of `fdid fit --save`.
    pub fn to_json(&self) -> serde_json::Result<String> {
        let fitted = each!(&self.model, m => serde_json::to_value(m))?;
        let (domain, ts) = match self.domain {
            Domain::Continuous => ("s", None),
            Domain::Discrete { ts } => ("z", Some(ts)),
        };
        let v = json!({
            "format": FORMAT,
            "version": VERSION,
            "kind": self.kind,
            "domain": domain,
            "ts": ts,
            "source": "python",
            "fitted": fitted,
            "unresolved_poles": [],
            "marginal_poles": [],
        });
        serde_json::to_string_pretty(&v)
    }

    /// A model from the JSON of [`Saved::to_json`] or `fdid fit --save`, checked
    /// ([`FittedModel::check`]).
    pub fn from_json(text: &str) -> Result<Self, String> {
        let v: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
        if v["format"] != FORMAT {
            return Err(format!(
                "not a saved fdid model (no \"format\": \"{FORMAT}\")"
            ));
        }
        if v["version"] != VERSION {
            return Err(format!(
                "saved-model version {} is not supported (this fdid reads version {VERSION})",
                v["version"]
            ));
        }
        let domain = match (v["domain"].as_str(), v["ts"].as_f64()) {
            (Some("s"), _) => Domain::Continuous,
            (Some("z"), Some(ts)) if ts.is_finite() && ts > 0.0 => Domain::Discrete { ts },
            _ => {
                return Err(format!(
                    "bad domain {} with ts {} (\"s\", or \"z\" with a positive ts)",
                    v["domain"], v["ts"]
                ));
            }
        };
        let fitted = &v["fitted"];
        let (kind, model) = match v["kind"].as_str() {
            Some("rational") => ("rational", Fitted::Plain(parse(fitted)?)),
            Some("delayed") => ("delayed", Fitted::Delayed(parse(fitted)?)),
            Some("noise_model") => ("noise_model", Fitted::NoiseModel(parse(fitted)?)),
            Some("delayed_noise_model") => (
                "delayed_noise_model",
                Fitted::DelayedNoiseModel(parse(fitted)?),
            ),
            _ => {
                return Err(format!(
                    "model kind {} is not a single-entry model (rational, delayed, \
                     noise_model, delayed_noise_model)",
                    v["kind"]
                ));
            }
        };
        Ok(Self {
            model,
            domain,
            kind,
        })
    }
}

fn fitted<M: ModelStructure<f64> + Clone>(fit: &Fit<f64, M>) -> FittedModel<f64, M> {
    FittedModel::of_fit(fit)
}

fn factored<M: ModelStructure<f64> + PolesZeros<f64>>(
    m: &FittedModel<f64, M>,
) -> fdid::Result<(Vec<Complex64>, Vec<Complex64>, f64)> {
    Ok((
        m.model.poles(&m.theta)?,
        m.model.zeros(&m.theta)?,
        m.model.gain(&m.theta),
    ))
}

fn parse<M: ModelStructure<f64> + Serialize + DeserializeOwned>(
    fitted: &Value,
) -> Result<FittedModel<f64, M>, String> {
    let m: FittedModel<f64, M> =
        serde_json::from_value(fitted.clone()).map_err(|e| format!("bad fitted model: {e}"))?;
    m.check().map_err(|e| e.to_string())?;
    Ok(m)
}
