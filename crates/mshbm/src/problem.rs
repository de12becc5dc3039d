//! The one trait every periodic-solution method implements, so that Newton and
//! continuation are written once (docs/architecture.md; their algorithms are
//! docs/theory.md §10).

use faer::Mat;

use crate::dense::DenseLu;
use crate::error::Result;
use crate::solution::{DiagramPoint, PeriodicSolution};
use crate::stability::Floquet;

/// Residual, Jacobian and frequency derivative at one point.
pub struct Linearization {
    pub residual: Vec<f64>,
    /// `∂R/∂x` (`dimension × dimension`).
    pub jacobian: Jacobian,
    /// `∂R/∂ω` (ω in rad/s).
    pub d_omega: Vec<f64>,
}

impl Default for Linearization {
    fn default() -> Self {
        Linearization::empty()
    }
}

impl Linearization {
    /// Nothing yet: storage for [`PeriodicProblem::linearize_into`].
    pub fn empty() -> Self {
        Linearization {
            residual: Vec::new(),
            jacobian: Jacobian::Dense(Mat::zeros(0, 0)),
            d_omega: Vec::new(),
        }
    }
}

/// The Jacobian of a Newton system: a dense matrix, or an operator that applies it and
/// approximately inverts it (solved by preconditioned GMRES, docs/theory.md §18).
pub enum Jacobian {
    Dense(Mat<f64>),
    Operator(Box<dyn JacobianOperator>),
}

/// A Jacobian given by its action (docs/theory.md §18).
pub trait JacobianOperator {
    /// Number of rows and columns.
    fn dimension(&self) -> usize;
    /// `out = J x`.
    fn apply(&self, x: &[f64], out: &mut [f64]);
    /// `out ≈ J⁻¹ r` (the preconditioner).
    fn precondition(&self, r: &[f64], out: &mut [f64]);
    /// The whole matrix (what a dense solve falls back on when GMRES does not converge).
    fn dense(&self) -> Mat<f64>;
    /// Make the preconditioner exact for this operator (e.g. factor its dense matrix),
    /// because GMRES did not converge within [`KRYLOV_REFRESH_ITERATIONS`]; `false` when it
    /// cannot do better than it does.
    fn refresh_preconditioner(&self) -> bool {
        false
    }
}

/// Relative residual to which GMRES solves Newton's and the continuation's linear systems:
/// an inexact Newton step with this forcing term contracts as the exact one does down to
/// Newton's tolerances (docs/theory.md §18).
pub const KRYLOV_TOLERANCE: f64 = 1e-9;
/// Operator applications after which the preconditioner is refreshed
/// ([`JacobianOperator::refresh_preconditioner`]); also the Krylov vectors kept.
pub const KRYLOV_REFRESH_ITERATIONS: usize = 30;

impl Jacobian {
    pub fn dimension(&self) -> usize {
        match self {
            Jacobian::Dense(m) => m.nrows(),
            Jacobian::Operator(op) => op.dimension(),
        }
    }

    /// The whole matrix.
    pub fn to_dense(&self) -> Mat<f64> {
        match self {
            Jacobian::Dense(m) => m.clone(),
            Jacobian::Operator(op) => op.dense(),
        }
    }

    /// [`Jacobian::solve`] into `y`, a dense matrix by `lu` (which then allocates nothing
    /// once grown to the size); `false` when the solution is not finite.
    pub fn solve_into(
        &self,
        rhs: impl Fn(usize) -> f64,
        lu: &mut DenseLu,
        y: &mut Vec<f64>,
    ) -> bool {
        match self {
            Jacobian::Dense(m) => lu.solve_into(m, rhs, y),
            Jacobian::Operator(_) => match self.solve(rhs) {
                Some(solution) => {
                    *y = solution;
                    true
                }
                None => false,
            },
        }
    }

    /// `J x`.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        match self {
            Jacobian::Dense(m) => (0..m.nrows())
                .map(|i| (0..m.ncols()).map(|j| m[(i, j)] * x[j]).sum())
                .collect(),
            Jacobian::Operator(op) => {
                let mut out = vec![0.0; op.dimension()];
                op.apply(x, &mut out);
                out
            }
        }
    }

    /// Solve `J y = b`, `b_i = rhs(i)`: LU with partial pivoting for a dense matrix. For an
    /// operator, GMRES with the operator's preconditioner to [`KRYLOV_TOLERANCE`]; when it
    /// has not converged after [`KRYLOV_REFRESH_ITERATIONS`] applications the preconditioner
    /// is refreshed and GMRES runs again, and the dense LU of the operator's matrix is the
    /// last resort. `None` when the solution is not finite (`J` singular).
    pub fn solve(&self, rhs: impl Fn(usize) -> f64) -> Option<Vec<f64>> {
        let n = self.dimension();
        match self {
            Jacobian::Dense(m) => dense_solve(m, rhs),
            Jacobian::Operator(op) => {
                let b: Vec<f64> = (0..n).map(&rhs).collect();
                let gmres = || {
                    crate::krylov::gmres(
                        &b,
                        |x, y| op.apply(x, y),
                        |r, z| op.precondition(r, z),
                        &crate::krylov::GmresOptions {
                            relative_tolerance: KRYLOV_TOLERANCE,
                            restart: KRYLOV_REFRESH_ITERATIONS,
                            max_iterations: KRYLOV_REFRESH_ITERATIONS,
                        },
                    )
                };
                let out = gmres();
                if out.converged {
                    return Some(out.x);
                }
                if op.refresh_preconditioner() {
                    let out = gmres();
                    if out.converged {
                        return Some(out.x);
                    }
                }
                dense_solve(&op.dense(), rhs)
            }
        }
    }
}

/// Solve `A y = b` densely (LU with partial pivoting, faer), `b_i = rhs(i)`; `None` when the
/// solution is not finite (`A` singular).
fn dense_solve(a: &Mat<f64>, rhs: impl Fn(usize) -> f64) -> Option<Vec<f64>> {
    let mut y = Vec::new();
    DenseLu::default().solve_into(a, rhs, &mut y).then_some(y)
}

/// What a method's residual lets the pseudo-arclength continuation assume (docs/theory.md §10):
/// declared by each method ([`PeriodicProblem::continuation_policy`]) so that every caller of
/// [`crate::continuation::arclength::trace_branch`] runs the same algorithm for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContinuationPolicy {
    /// How Newton's corrector contracts on this residual.
    pub newton_contraction: NewtonContraction,
    /// What the continuation does where the arclength step fails (the step falls below its
    /// smallest value).
    pub where_arclength_fails: ArclengthFallback,
    /// How many signals the unknowns hold (the contacts' displacements, each with its
    /// `2H + 1` coefficients; at least 1). The arclength measures the unknowns' change per
    /// signal, `‖Δx‖ / (ℓ √signals)`, so that a step means the same change of the response on
    /// one contact and on a thousand (docs/theory.md (T72)).
    pub signals: usize,
}

/// How Newton contracts on a method's residual (paper eq. 13).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NewtonContraction {
    /// Exact Jacobian of a smooth residual (smooth on each piece): Newton contracts
    /// quadratically, so each corrector update at least halves the previous one, and an
    /// update that does not is a corrector working across a grazing event or towards another
    /// piece of the branch — refused, the arclength step is halved.
    Quadratic,
    /// No quadratic contraction to rely on (a finite-difference Jacobian, a stiff penalty
    /// with a kinked residual): the corrector's updates are not checked.
    Unchecked,
}

/// What the continuation does where the arclength corrector fails down to the smallest
/// step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ArclengthFallback {
    /// The branch has isolated corners (grazing contacts): look for the outgoing piece on
    /// small spheres around the last point (at most once in a row), then stop.
    EscapeCorner,
    /// The residual is piecewise affine at the time-step scale, so the branch is a staircase
    /// of tiny corners the arclength corrector cannot follow while Newton at a fixed
    /// frequency converges: once the arclength step falls below `min_arclength_step`
    /// (scaled arclength; steps below the staircase scale are not tried, nor are corner
    /// escapes), step in frequency instead — Newton at `ω e^{±Δ}` from the last point, `Δ` a
    /// quarter, a sixteenth, a sixty-fourth of the largest frequency step. Such a step cannot
    /// turn at a fold: past one it lands on whatever solution Newton finds (a jump, as in a
    /// sweep experiment).
    StepInFrequency { min_arclength_step: f64 },
}

/// A periodic-solution problem `R(x, ω) = 0` (e.g. the connectivity condition, paper eq. 30,
/// docs/theory.md (T33)).
pub trait PeriodicProblem {
    /// Number of unknowns.
    fn dimension(&self) -> usize;

    /// A length that sets the scale of `x` (e.g. the gap, or the static deflection;
    /// docs/theory.md (T6)): Newton's tolerance and continuation's scaling are relative to it.
    fn length_scale(&self) -> f64;

    /// A starting point at `ω` (the contact-free linear response).
    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>>;

    /// `R(x, ω)`.
    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>>;

    /// `R`, `∂R/∂x` and `∂R/∂ω`.
    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization>;

    /// [`PeriodicProblem::linearize`] into `out`, reusing its storage where the method can
    /// (the redistributed MS-HBM allocates nothing then); by default a new linearization.
    fn linearize_into(&mut self, x: &[f64], omega: f64, out: &mut Linearization) -> Result<()> {
        *out = self.linearize(x, omega)?;
        Ok(())
    }

    /// The periodic solution described by `x` at `ω`, with the time series of the contacts
    /// and of the model DOF `response_dof`. Newton statistics are left at their defaults.
    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution>;

    /// What a frequency response diagram keeps of the solution `x` at `ω`. By default taken
    /// from [`PeriodicProblem::solution`]; a method whose whole solution costs much more than
    /// the response of one DOF (the extremes of every contact of a large interface) gives
    /// it directly, equal to the whole solution's.
    fn diagram_point(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
    ) -> Result<DiagramPoint> {
        Ok(DiagramPoint::of(&self.solution(x, omega, response_dof)?))
    }

    /// What the residual lets the continuation assume ([`ContinuationPolicy`]).
    fn continuation_policy(&self) -> ContinuationPolicy;

    /// Floquet multipliers of the solution `x` at `ω`, for methods that provide them.
    fn floquet(&mut self, _x: &[f64], _omega: f64) -> Result<Option<Floquet>> {
        Ok(None)
    }
}

/// A problem whose initial guess is a given point (a continuation started from a known
/// solution, e.g. one reached by another path); everything else is the wrapped method's.
pub struct StartingAt<'a> {
    pub problem: &'a mut dyn PeriodicProblem,
    pub x0: Vec<f64>,
}

impl PeriodicProblem for StartingAt<'_> {
    fn dimension(&self) -> usize {
        self.problem.dimension()
    }
    fn length_scale(&self) -> f64 {
        self.problem.length_scale()
    }
    fn initial_guess(&mut self, _omega: f64) -> Result<Vec<f64>> {
        Ok(self.x0.clone())
    }
    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        self.problem.residual(x, omega)
    }
    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        self.problem.linearize(x, omega)
    }
    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        self.problem.solution(x, omega, response_dof)
    }
    fn diagram_point(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
    ) -> Result<DiagramPoint> {
        self.problem.diagram_point(x, omega, response_dof)
    }
    fn continuation_policy(&self) -> ContinuationPolicy {
        self.problem.continuation_policy()
    }
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        self.problem.floquet(x, omega)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use std::cell::Cell;

    use faer::linalg::solvers::Solve;
    use faer::Mat;

    use super::{
        ArclengthFallback, ContinuationPolicy, Jacobian, JacobianOperator, Linearization,
        NewtonContraction, PeriodicProblem,
    };
    use crate::error::Result;
    use crate::solution::PeriodicSolution;

    /// A problem in one unknown: `equation(x, ω) = (R, ∂R/∂x, ∂R/∂ω)`, starting from 0.
    pub(crate) struct Scalar<F: FnMut(f64, f64) -> (f64, f64, f64)> {
        pub equation: F,
        pub contraction: NewtonContraction,
    }

    impl<F: FnMut(f64, f64) -> (f64, f64, f64)> PeriodicProblem for Scalar<F> {
        fn dimension(&self) -> usize {
            1
        }
        fn length_scale(&self) -> f64 {
            1.0
        }
        fn initial_guess(&mut self, _omega: f64) -> Result<Vec<f64>> {
            Ok(vec![0.0])
        }
        fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
            Ok(vec![(self.equation)(x[0], omega).0])
        }
        fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
            let (r, dx, dw) = (self.equation)(x[0], omega);
            Ok(Linearization {
                residual: vec![r],
                jacobian: Jacobian::Dense(Mat::from_fn(1, 1, |_, _| dx)),
                d_omega: vec![dw],
            })
        }
        fn solution(&mut self, _: &[f64], _: f64, _: usize) -> Result<PeriodicSolution> {
            unimplemented!("not needed by Newton or the corrector")
        }
        fn continuation_policy(&self) -> ContinuationPolicy {
            ContinuationPolicy {
                newton_contraction: self.contraction,
                where_arclength_fails: ArclengthFallback::EscapeCorner,
                signals: 1,
            }
        }
    }

    /// A dense matrix as an operator: preconditioned by the identity until refreshed, then
    /// by its own LU (or never, with `refreshable = false`).
    pub(crate) struct DenseOperator {
        pub matrix: Mat<f64>,
        pub refreshable: bool,
        pub refreshed: Cell<usize>,
    }

    impl DenseOperator {
        pub(crate) fn new(matrix: Mat<f64>, refreshable: bool) -> Self {
            DenseOperator {
                matrix,
                refreshable,
                refreshed: Cell::new(0),
            }
        }
    }

    impl JacobianOperator for DenseOperator {
        fn dimension(&self) -> usize {
            self.matrix.nrows()
        }
        fn apply(&self, x: &[f64], out: &mut [f64]) {
            for (i, o) in out.iter_mut().enumerate() {
                *o = x
                    .iter()
                    .enumerate()
                    .map(|(j, v)| self.matrix[(i, j)] * v)
                    .sum();
            }
        }
        fn precondition(&self, r: &[f64], out: &mut [f64]) {
            if self.refreshed.get() == 0 {
                out.copy_from_slice(r);
            } else {
                let b = faer::MatRef::from_column_major_slice(r, r.len(), 1);
                let y = self.matrix.partial_piv_lu().solve(b);
                out.iter_mut().enumerate().for_each(|(i, o)| *o = y[(i, 0)]);
            }
        }
        fn dense(&self) -> Mat<f64> {
            self.matrix.clone()
        }
        fn refresh_preconditioner(&self) -> bool {
            if !self.refreshable || self.refreshed.get() > 0 {
                return false;
            }
            self.refreshed.set(1);
            true
        }
    }

    /// A nonsymmetric matrix whose spectrum is spread over four decades (unpreconditioned
    /// GMRES needs far more than `KRYLOV_REFRESH_ITERATIONS` applications).
    pub(crate) fn spread_matrix(n: usize) -> Mat<f64> {
        Mat::from_fn(n, n, |i, j| {
            let diagonal = if i == j {
                10f64.powf(4.0 * i as f64 / n as f64)
            } else {
                0.0
            };
            diagonal + 0.3 * (((i * 5 + j * 11) % 7) as f64 / 7.0 - 0.5)
        })
    }

    fn check(jacobian: &Jacobian, matrix: &Mat<f64>) {
        let n = matrix.nrows();
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).cos()).collect();
        let x = jacobian.solve(|i| b[i]).expect("regular");
        let r = Jacobian::Dense(matrix.clone()).apply(&x);
        let err = r
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-8, "residual {err:.2e}");
    }

    #[test]
    fn an_operator_refreshes_a_poor_preconditioner_and_then_converges() {
        let matrix = spread_matrix(80);
        let op = Box::new(DenseOperator::new(matrix.clone(), true));
        let jacobian = Jacobian::Operator(op);
        check(&jacobian, &matrix);
        let Jacobian::Operator(op) = &jacobian else {
            unreachable!()
        };
        assert!(!op.refresh_preconditioner(), "refreshed once already");
    }

    #[test]
    fn an_operator_gmres_cannot_solve_falls_back_to_the_dense_lu() {
        let matrix = spread_matrix(80);
        let jacobian = Jacobian::Operator(Box::new(DenseOperator::new(matrix.clone(), false)));
        check(&jacobian, &matrix);
    }

    #[test]
    fn a_singular_operator_has_no_solution() {
        let mut matrix = spread_matrix(10);
        for j in 0..10 {
            matrix[(3, j)] = 0.0;
        }
        let jacobian = Jacobian::Operator(Box::new(DenseOperator::new(matrix, true)));
        assert!(jacobian.solve(|_| 1.0).is_none());
    }
}
