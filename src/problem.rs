//! The problem kinds a [`crate::Criterion`] produces and a [`crate::Solver`] consumes.
//!
//! Each kind is a small trait; a solver is implemented only for the kinds it can solve, so a
//! criterion paired with the wrong solver does not compile. Complex equations are stacked as
//! real ones (real and imaginary parts, line by line) so parameters stay real.

use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem: minimise ‖r(θ)‖² over θ ∈ ℝᵖ.
pub trait NonlinearProblem<T: Real> {
    /// Number of parameters p.
    fn n_params(&self) -> usize;
    /// Number of real residuals m.
    fn n_residuals(&self) -> usize;
    /// Writes r(θ) (length m). Returns false if the residuals are not finite.
    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool;
    /// Writes r(θ) and its Jacobian ∂r/∂θ (m × p). Returns false if not finite.
    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool;

    /// Writes r(θ), the Gram matrix `gram` = JᵀJ (p × p) and the gradient `grad` = Jᵀr
    /// (length p) of J = ∂r/∂θ: what a normal-equation step needs. Returns false if not
    /// finite. The default forms J in `jac` (resized to m × p when its shape differs) by
    /// [`NonlinearProblem::jacobian_into`]; an implementation may accumulate JᵀJ and Jᵀr
    /// over blocks of rows instead and leave `jac` untouched.
    fn normal_equations_into(
        &self,
        theta: &[T],
        r: &mut [T],
        jac: &mut DMatrix<T>,
        gram: &mut DMatrix<T>,
        grad: &mut DVector<T>,
    ) -> bool {
        let (m, p) = (self.n_residuals(), self.n_params());
        if jac.shape() != (m, p) {
            *jac = DMatrix::zeros(m, p);
        }
        if !self.jacobian_into(theta, r, jac) {
            return false;
        }
        if gram.shape() != (p, p) {
            *gram = DMatrix::zeros(p, p);
        }
        if grad.len() != p {
            *grad = DVector::zeros(p);
        }
        crate::linalg::gram::gram_into(jac, gram, false);
        crate::linalg::gram::GramWork::tr_mul(jac, r, grad);
        true
    }
}

/// A linear least-squares problem: minimise ‖Aθ − b‖².
pub trait LinearProblem<T: Real> {
    /// The real-stacked system (A, b).
    fn system(&self) -> (DMatrix<T>, DVector<T>);
}

/// A homogeneous problem: minimise ‖M c‖ subject to ‖c‖ = 1, then map c to θ.
pub trait HomogeneousProblem<T: Real> {
    /// The real-stacked matrix M.
    fn matrix(&self) -> DMatrix<T>;
    /// θ from the unit-norm minimiser c; `None` if c does not define a model (e.g. its
    /// normalising coefficient is zero).
    fn theta_from_null_vector(&self, c: &[T]) -> Option<Vec<T>>;
}

/// A linear problem whose weights depend on the previous estimate (iteratively re-weighted
/// least squares, e.g. Sanathanan–Koerner).
pub trait ReweightedProblem<T: Real> {
    /// The real-stacked system at iteration m, with weights from θ^(m−1) (`None` for the
    /// first iteration).
    fn system(&self, previous: Option<&[T]>) -> (DMatrix<T>, DVector<T>);
    /// The minimiser of the system at iteration m and its residual norm², through the
    /// guarded normal equations of [`crate::solver`]'s `gram` kernels (κ₁ of the
    /// equilibrated Gram matrix at most 10⁸ in f64, 10³ in f32); `None` when they are
    /// refused, and the caller then solves [`ReweightedProblem::system`] by QR/SVD. The
    /// default forms the system; an implementation may accumulate the Gram matrix without
    /// it.
    fn solve_normal_equations(&self, previous: Option<&[T]>) -> Option<(Vec<T>, T)> {
        let (a, b) = self.system(previous);
        crate::linalg::gram::least_squares_gram(&a, &b, crate::linalg::gram::max_condition::<T>())
            .map(|(theta, cost)| (theta.as_slice().to_vec(), cost))
    }
    /// The real equations of one solve (the rows of [`ReweightedProblem::system`]), for
    /// the work budget of [`crate::solver::work`]. The default forms the system once.
    fn rows(&self) -> usize {
        self.system(None).0.nrows()
    }
    /// A scale-free measure of the change between two estimates (e.g. relative change of
    /// the model response), used for the convergence test.
    fn change(&self, old: &[T], new: &[T]) -> T;
    /// The criterion value at θ, reported with the solution.
    fn cost(&self, theta: &[T]) -> T;
}
