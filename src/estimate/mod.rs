//! Estimation strategies: everything that turns a model structure and data into a
//! [`crate::Fit`].
//!
//! Models ([`crate::model`]) and criteria ([`crate::criterion`]) only describe; the
//! solvers ([`crate::solver`]) minimise one problem. This layer owns every strategy that
//! runs them:
//!
//! | strategy | entry point |
//! |---|---|
//! | one specification (domain, orders, factors, criterion) → the strategy it needs | [`ModelSpec::fit`] |
//! | Levy → Sanathanan–Koerner → ML chain, with relocation and further starts | [`Pipeline`] |
//! | any criterion with any solver | [`estimate()`] |
//! | several automatic starts (s and z) | [`multistart`] |
//! | time delay: starting delay search, joint ML | [`delay_start`], [`fit_delayed`] |
//! | errors-in-variables ML (eq. 42) | [`fit_eiv`], [`fit_eiv_delayed`] |
//! | noise model H = C/D (eq. 26) | [`fit_noise_model`], [`refine_noise_model`] |
//! | modal / ZOH continuous-time fits of sampled data (section 2.3) | [`fit_modal`] |
//! | grey-box (physical) models | [`greybox`] |
//! | many data sets (rayon) | [`batch`] |

pub mod batch;
mod chain;
mod delay;
mod delay_profile;
mod eiv;
mod from_poles;
pub mod greybox;
mod modal;
pub mod multistart;
mod noise_model;
mod noise_start;
mod spec;
mod work;

pub use chain::{
    FEWER_LINES_TOLERANCE, FurtherStarts, MIN_START_LINES, Pipeline, START_LINES,
    START_LINES_PER_COEFFICIENT, estimate,
};
pub use delay::{DelayStart, delay_start, fit_delayed};
pub use eiv::{fit_eiv, fit_eiv_delayed};
pub use modal::{ModalOptions, fit_modal};
pub use multistart::{
    DISCRETE_SEARCH_ORDER, MAX_RESTART_ORDER, RELOCATION_ORDER, fit_multistart,
    fit_multistart_discrete, without_relocation,
};
pub use noise_model::{NOISE_MODEL_COST_TOLERANCE, fit_noise_model, refine_noise_model};
pub use spec::{DelayRange, Method, ModelSpec, RationalFit, Stability, causal_delay_limit};
