//! The stabilisation diagram: common-pole fits over a range of orders, each pole marked
//! by how well it repeats from one order to the next, and the poles that repeat
//! clustered into physical modes.

use super::model::Mode;
use super::{CommonPoleFit, CommonPoleOptions, fit_common_poles};
use crate::data::FrfMatrix;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use num_traits::Float;

/// How close a pole must come to one of the previous order to count as repeated, and how
/// often a physical mode must repeat.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `frequency` | 0.01 | relative change of the natural frequency, \|f − f′\|/f |
/// | `damping` | 0.05 | relative change of the damping ratio, \|ζ − ζ′\|/ζ |
/// | `mac` | 0.95 | least modal assurance criterion of the output mode shapes |
/// | `min_orders` | 3 | least number of orders at which a physical mode is stable |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StabilityTolerances<T: Real> {
    /// Relative frequency tolerance.
    pub frequency: T,
    /// Relative damping tolerance.
    pub damping: T,
    /// Least MAC.
    pub mac: T,
    /// Least number of orders at which a cluster's poles are stable.
    pub min_orders: usize,
}

impl<T: Real> Default for StabilityTolerances<T> {
    fn default() -> Self {
        Self {
            frequency: T::lit(0.01),
            damping: T::lit(0.05),
            mac: T::lit(0.95),
            min_orders: 3,
        }
    }
}

/// What a pole of the diagram shares with the nearest pole (in frequency) of the previous
/// order: the classic marks o, f, d, v, s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoleMark {
    /// Not repeated (`o`): the first order, or no pole within the frequency tolerance.
    New,
    /// Frequency repeated, damping and shape not (`f`).
    Frequency,
    /// Frequency and damping repeated (`d`).
    Damping,
    /// Frequency and mode shape repeated (`v`).
    Shape,
    /// Frequency, damping and mode shape repeated (`s`): a stable pole.
    Stable,
}

impl PoleMark {
    /// The one-letter mark: o, f, d, v or s.
    pub fn letter(self) -> char {
        match self {
            Self::New => 'o',
            Self::Frequency => 'f',
            Self::Damping => 'd',
            Self::Shape => 'v',
            Self::Stable => 's',
        }
    }
}

/// One pole of the diagram.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagramPole<T: Real> {
    /// The model order it was fitted at.
    pub order: usize,
    /// The mode: pole, natural frequency, damping and shape.
    pub mode: Mode<T>,
    /// How it repeats from the previous order.
    pub mark: PoleMark,
}

/// A physical mode: a cluster of stable poles over several orders.
#[derive(Debug, Clone, PartialEq)]
pub struct PhysicalMode<T: Real> {
    /// Mean natural frequency (Hz).
    pub f_n_hz: T,
    /// Standard deviation of the natural frequency over the cluster (Hz).
    pub f_n_spread_hz: T,
    /// Mean damping ratio.
    pub damping: T,
    /// Standard deviation of the damping ratio over the cluster.
    pub damping_spread: T,
    /// The orders at which the cluster has a stable pole, ascending.
    pub orders: Vec<usize>,
}

/// The stabilisation diagram of [`stabilisation_diagram`].
#[derive(Debug, Clone, PartialEq)]
pub struct StabilisationDiagram<T: Real> {
    /// The orders fitted, ascending.
    pub orders: Vec<usize>,
    /// The stable poles (Re s < 0, |z| < 1) of every order with f_n inside the data's
    /// band, in order then frequency.
    pub poles: Vec<DiagramPole<T>>,
    /// The physical modes, by frequency.
    pub modes: Vec<PhysicalMode<T>>,
    /// The orders whose fit failed, with the reason (they break the chain: the next
    /// order's poles compare with the last order that was fitted).
    pub failed: Vec<(usize, String)>,
}

/// Fits every order of `orders` with common poles ([`fit_common_poles`] with `options`)
/// and builds the stabilisation diagram; see [`diagram_of_fits`].
///
/// # Errors
/// No order, or no order that could be fitted (the first failure's error).
pub fn stabilisation_diagram<T: Real>(
    data: &FrfMatrix<T>,
    orders: &[usize],
    options: &CommonPoleOptions<T>,
    tolerances: &StabilityTolerances<T>,
) -> Result<StabilisationDiagram<T>> {
    let band = band_hz(data.omega());
    diagram_of_fits(orders, band, tolerances, |n| {
        fit_common_poles(data, n, options)
    })
}

/// The stabilisation diagram of the fits `fit(n)` for every order n of `orders`: each
/// fit's stable modes with f_n in `band` (Hz) are compared with the previous order's —
/// the nearest in frequency, repeated when |f − f′| ≤ `frequency`·f; its damping when
/// |ζ − ζ′| ≤ `damping`·ζ; its shape when MAC(φ, φ′) = |φᴴφ′|²/(‖φ‖²‖φ′‖²) ≥ `mac` —
/// and marked ([`PoleMark`]). The stable poles (mark `s`) are sorted by frequency and
/// split where consecutive poles differ by more than `frequency` relatively; a cluster
/// with stable poles at `min_orders` or more orders is a physical mode (mean and spread
/// of f_n and ζ over its poles, one per order: the nearest to the cluster's median).
///
/// # Errors
/// No order, or no order that could be fitted (the first failure's error).
pub fn diagram_of_fits<T: Real>(
    orders: &[usize],
    band: (T, T),
    tolerances: &StabilityTolerances<T>,
    mut fit: impl FnMut(usize) -> Result<CommonPoleFit<T>>,
) -> Result<StabilisationDiagram<T>> {
    if orders.is_empty() {
        return Err(FdidError::InvalidArgument {
            name: "orders",
            value: "none".into(),
            reason: "a stabilisation diagram needs at least one order".into(),
        });
    }
    let mut sorted = orders.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut poles = Vec::new();
    let mut failed = Vec::new();
    let mut first_error = None;
    let mut previous: Vec<Mode<T>> = Vec::new();
    let mut fitted_any = false;
    for &n in &sorted {
        let modes = match fit(n).and_then(|f| f.model.modes()) {
            Ok(m) => m,
            Err(e) => {
                failed.push((n, e.to_string()));
                first_error.get_or_insert(e);
                continue;
            }
        };
        let modes: Vec<Mode<T>> = modes
            .into_iter()
            .filter(|m| m.pole.re < T::zero() && m.f_n_hz >= band.0 && m.f_n_hz <= band.1)
            .collect();
        for m in &modes {
            let mark = if fitted_any {
                mark_against(m, &previous, tolerances)
            } else {
                PoleMark::New
            };
            poles.push(DiagramPole {
                order: n,
                mode: m.clone(),
                mark,
            });
        }
        previous = modes;
        fitted_any = true;
    }
    if !fitted_any {
        return Err(first_error.expect("an order was tried"));
    }
    let modes = clusters(&poles, tolerances);
    Ok(StabilisationDiagram {
        orders: sorted,
        poles,
        modes,
        failed,
    })
}

/// The frequency band of the lines (Hz).
fn band_hz<T: Real>(omega: &[T]) -> (T, T) {
    let lo = omega.iter().copied().fold(T::infinity(), Float::min);
    let hi = omega.iter().copied().fold(T::zero(), Float::max);
    (lo / T::two_pi(), hi / T::two_pi())
}

/// The mark of `mode` against the modes of the previous order.
fn mark_against<T: Real>(
    mode: &Mode<T>,
    previous: &[Mode<T>],
    tol: &StabilityTolerances<T>,
) -> PoleMark {
    let nearest = previous.iter().min_by(|a, b| {
        Float::abs(a.f_n_hz - mode.f_n_hz)
            .partial_cmp(&Float::abs(b.f_n_hz - mode.f_n_hz))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let Some(other) = nearest else {
        return PoleMark::New;
    };
    if Float::abs(other.f_n_hz - mode.f_n_hz) > tol.frequency * mode.f_n_hz {
        return PoleMark::New;
    }
    let damping = Float::abs(other.damping - mode.damping) <= tol.damping * mode.damping;
    let shape = mac(&mode.shape, &other.shape) >= tol.mac;
    match (damping, shape) {
        (true, true) => PoleMark::Stable,
        (true, false) => PoleMark::Damping,
        (false, true) => PoleMark::Shape,
        (false, false) => PoleMark::Frequency,
    }
}

/// The modal assurance criterion |aᴴb|²/(‖a‖²‖b‖²) (0 for a zero vector).
pub fn mac<T: Real>(a: &[Complex<T>], b: &[Complex<T>]) -> T {
    let dot = a
        .iter()
        .zip(b)
        .fold(Complex::new(T::zero(), T::zero()), |s, (x, y)| {
            s + x.conj() * y
        });
    let na = a.iter().fold(T::zero(), |s, x| s + x.norm_sqr());
    let nb = b.iter().fold(T::zero(), |s, x| s + x.norm_sqr());
    if na > T::zero() && nb > T::zero() {
        dot.norm_sqr() / (na * nb)
    } else {
        T::zero()
    }
}

/// The physical modes: the stable poles sorted by frequency, split at relative gaps above
/// the frequency tolerance, kept when stable at `min_orders` orders or more.
fn clusters<T: Real>(
    poles: &[DiagramPole<T>],
    tol: &StabilityTolerances<T>,
) -> Vec<PhysicalMode<T>> {
    let mut stable: Vec<&DiagramPole<T>> = poles
        .iter()
        .filter(|p| p.mark == PoleMark::Stable)
        .collect();
    stable.sort_by(|a, b| {
        a.mode
            .f_n_hz
            .partial_cmp(&b.mode.f_n_hz)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut groups: Vec<Vec<&DiagramPole<T>>> = Vec::new();
    for p in stable {
        match groups.last_mut() {
            Some(g)
                if p.mode.f_n_hz - g[g.len() - 1].mode.f_n_hz <= tol.frequency * p.mode.f_n_hz =>
            {
                g.push(p)
            }
            _ => groups.push(vec![p]),
        }
    }
    groups
        .into_iter()
        .filter_map(|g| physical_mode(&g, tol.min_orders))
        .collect()
}

/// The physical mode of a cluster: one pole per order (the nearest to the cluster's
/// median frequency), kept with `min_orders` orders or more.
fn physical_mode<T: Real>(group: &[&DiagramPole<T>], min_orders: usize) -> Option<PhysicalMode<T>> {
    let median = group[group.len() / 2].mode.f_n_hz;
    let mut per_order: Vec<&DiagramPole<T>> = Vec::new();
    for p in group {
        match per_order.iter_mut().find(|q| q.order == p.order) {
            Some(q) => {
                if Float::abs(p.mode.f_n_hz - median) < Float::abs(q.mode.f_n_hz - median) {
                    *q = p;
                }
            }
            None => per_order.push(p),
        }
    }
    if per_order.len() < min_orders.max(1) {
        return None;
    }
    per_order.sort_by_key(|p| p.order);
    let (f_n_hz, f_n_spread_hz) = mean_spread(per_order.iter().map(|p| p.mode.f_n_hz));
    let (damping, damping_spread) = mean_spread(per_order.iter().map(|p| p.mode.damping));
    Some(PhysicalMode {
        f_n_hz,
        f_n_spread_hz,
        damping,
        damping_spread,
        orders: per_order.iter().map(|p| p.order).collect(),
    })
}

/// Mean and sample standard deviation (0 for one value).
fn mean_spread<T: Real>(values: impl Iterator<Item = T> + Clone) -> (T, T) {
    let n = values.clone().count();
    let nf = T::from_usize_lossy(n);
    let mean = values.clone().fold(T::zero(), |s, v| s + v) / nf;
    if n < 2 {
        return (mean, T::zero());
    }
    let var = values.fold(T::zero(), |s, v| s + (v - mean) * (v - mean)) / (nf - T::one());
    (mean, Float::sqrt(var))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mac_of_parallel_and_orthogonal_shapes() {
        let a = [Complex::new(1.0, 0.0), Complex::new(0.0, 2.0)];
        let b: Vec<Complex<f64>> = a.iter().map(|x| x * Complex::new(0.0, -3.0)).collect();
        assert!((mac(&a, &b) - 1.0).abs() < 1e-15);
        let c = [Complex::new(2.0, 0.0), Complex::new(0.0, 1.0)];
        assert!(mac(&a, &c) < 1.0 - 1e-3);
        let e1 = [Complex::new(1.0, 0.0), Complex::new(0.0, 0.0)];
        let e2 = [Complex::new(0.0, 0.0), Complex::new(0.0, 1.0)];
        assert_eq!(mac(&e1, &e2), 0.0);
        assert_eq!(mac(&a, &[Complex::new(0.0, 0.0); 2]), 0.0);
    }

    #[test]
    fn spread_of_one_and_of_several_values() {
        assert_eq!(mean_spread([2.0].into_iter()), (2.0, 0.0));
        let (m, s) = mean_spread([1.0, 2.0, 3.0].into_iter());
        assert!((m - 2.0).abs() < 1e-15 && (s - 1.0).abs() < 1e-15);
    }
}
