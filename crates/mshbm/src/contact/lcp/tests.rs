//! Tests of the LCP solvers against the closed form and the brute-force enumeration.

use super::*;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// `D = B Bᵀ + 0.1 I` from the row-major entries of `B`.
fn spd_matrix(n: usize, b_entries: &[f64]) -> LcpMatrix {
    let mut data = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let b_i = &b_entries[i * n..(i + 1) * n];
            let b_j = &b_entries[j * n..(j + 1) * n];
            let mut entry: f64 = b_i.iter().zip(b_j).map(|(x, y)| x * y).sum();
            if i == j {
                entry += 0.1;
            }
            data[i * n + j] = entry;
        }
    }
    LcpMatrix::new(n, data)
}

fn scaled(matrix: &LcpMatrix, factor: f64) -> LcpMatrix {
    LcpMatrix::new(matrix.n(), matrix.data.iter().map(|v| v * factor).collect())
}

/// Random problem: `n`, entries of `B`, `q` and an initial active set.
fn problem() -> impl Strategy<Value = (usize, Vec<f64>, Vec<f64>, Vec<bool>)> {
    (1usize..=8).prop_flat_map(|n| {
        (
            Just(n),
            prop::collection::vec(-1.0..1.0f64, n * n),
            prop::collection::vec(-2.0..2.0f64, n),
            prop::collection::vec(any::<bool>(), n),
        )
    })
}

/// Exact feasibility and complementarity, `w = D λ + q`, agreement with enumeration.
fn check_solution(
    matrix: &LcpMatrix,
    q: &[f64],
    solution: &LcpSolution,
) -> Result<(), TestCaseError> {
    let n = matrix.n();
    prop_assert_eq!(solution.lambda.len(), n);
    prop_assert_eq!(solution.w.len(), n);
    prop_assert_eq!(solution.active.len(), n);
    let mut term_scale = 1.0f64;
    for (i, &q_i) in q.iter().enumerate() {
        let (force, gap) = (solution.lambda[i], solution.w[i]);
        prop_assert!(force >= 0.0, "lambda[{}] = {:e} < 0", i, force);
        prop_assert!(gap >= 0.0, "w[{}] = {:e} < 0", i, gap);
        prop_assert!(
            force * gap == 0.0,
            "lambda[{}] * w[{}] = {:e}",
            i,
            i,
            force * gap
        );
        if solution.active[i] {
            prop_assert!(gap == 0.0);
        } else {
            prop_assert!(force == 0.0);
        }
        let magnitude = q_i.abs()
            + (0..n)
                .map(|j| (matrix.get(i, j) * solution.lambda[j]).abs())
                .sum::<f64>();
        term_scale = term_scale.max(magnitude);
    }
    for (i, &q_i) in q.iter().enumerate() {
        let expected = q_i
            + (0..n)
                .map(|j| matrix.get(i, j) * solution.lambda[j])
                .sum::<f64>();
        prop_assert!(
            (solution.w[i] - expected).abs() <= 1e-10 * term_scale,
            "w[{}] = {:e}, D lambda + q = {:e}",
            i,
            solution.w[i],
            expected
        );
    }
    let reference = solve_by_enumeration(matrix, q);
    prop_assert!(reference.is_some(), "enumeration found no solution");
    let reference = reference.unwrap();
    let force_scale = reference.iter().fold(1.0f64, |s, v| s.max(v.abs()));
    for (i, (&force, &expected)) in solution.lambda.iter().zip(&reference).enumerate() {
        prop_assert!(
            (force - expected).abs() <= 1e-9 * force_scale,
            "lambda[{}] = {:e}, enumeration {:e}",
            i,
            force,
            expected
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn cold_start_matches_enumeration((n, b, q, _guess) in problem()) {
        let matrix = spd_matrix(n, &b);
        let mut solver = LcpSolver::new(matrix.clone());
        let solution = solver.solve(&q).unwrap();
        check_solution(&matrix, &q, &solution)?;
        // Re-solving the same q from the stored active set takes one evaluation.
        let again = solver.solve(&q).unwrap();
        prop_assert_eq!(again.pivots, 1);
        prop_assert_eq!(again.lambda, solution.lambda);
        prop_assert_eq!(again.w, solution.w);
        prop_assert_eq!(again.active, solution.active);
    }

    #[test]
    fn random_warm_start_matches_enumeration((n, b, q, guess) in problem()) {
        let matrix = spd_matrix(n, &b);
        let mut solver = LcpSolver::new(matrix.clone());
        let solution = solver.solve_from(&q, &guess).unwrap();
        check_solution(&matrix, &q, &solution)?;
    }

    #[test]
    fn murty_matches_enumeration((n, b, q, _guess) in problem()) {
        let matrix = spd_matrix(n, &b);
        let mut solver = LcpSolver::new(matrix.clone());
        let solution = solver.solve_murty(&q).unwrap();
        check_solution(&matrix, &q, &solution)?;
    }

    #[test]
    fn fallback_path_matches_enumeration((n, b, q, guess) in problem()) {
        let matrix = spd_matrix(n, &b);
        let mut solver = LcpSolver::new(matrix.clone());
        solver.max_active_set_iterations = 0;
        let solution = solver.solve_from(&q, &guess).unwrap();
        check_solution(&matrix, &q, &solution)?;
        // The fallback's active set is the warm start of the next call.
        solver.max_active_set_iterations = 10;
        prop_assert_eq!(solver.solve(&q).unwrap().pivots, 1);
    }

    #[test]
    fn badly_scaled_problems_match_enumeration(
        (n, b, q, guess) in problem(),
        stiffness_exponent in -3i32..=8,
        gap_exponent in -9i32..=2,
    ) {
        let matrix = scaled(&spd_matrix(n, &b), 10f64.powi(stiffness_exponent));
        let q: Vec<f64> = q.iter().map(|v| v * 10f64.powi(gap_exponent)).collect();
        let mut solver = LcpSolver::new(matrix.clone());
        let solution = solver.solve_from(&q, &guess).unwrap();
        check_solution(&matrix, &q, &solution)?;
    }
}

#[test]
fn single_contact_matches_closed_form() {
    for &d in &[0.1, 1.0, 3.7, 1e6] {
        let mut solver = LcpSolver::new(LcpMatrix::new(1, vec![d]));
        for k in -20..=20 {
            let q = 0.173 * f64::from(k);
            let (force, gap) = solve_scalar(d, q);
            assert!(force >= 0.0 && gap >= 0.0 && force * gap == 0.0);
            let solution = solver.solve(&[q]).unwrap();
            assert!((solution.lambda[0] - force).abs() <= 1e-15 * force.abs());
            assert_eq!(solution.w[0], gap);
            if q != 0.0 {
                // At q = 0 both sets are solutions; the warm start decides.
                assert_eq!(solution.active[0], q < 0.0);
            }
        }
    }
    assert_eq!(solve_scalar(2.0, -4.0), (2.0, 0.0));
    assert_eq!(solve_scalar(2.0, 4.0), (0.0, 4.0));
    assert_eq!(solve_scalar(2.0, -0.0), (0.0, 0.0));
}

#[test]
fn empty_problem_returns_empty_solution() {
    let mut solver = LcpSolver::new(LcpMatrix::new(0, Vec::new()));
    let solution = solver.solve(&[]).unwrap();
    assert!(solution.lambda.is_empty() && solution.w.is_empty() && solution.active.is_empty());
    let solution = solver.solve_from(&[], &[]).unwrap();
    assert!(solution.lambda.is_empty() && solution.w.is_empty() && solution.active.is_empty());
    assert_eq!(
        solve_by_enumeration(&LcpMatrix::new(0, Vec::new()), &[]),
        Some(vec![])
    );
}

#[test]
fn zero_q_gives_zero_force() {
    let matrix = spd_matrix(3, &[0.3, -0.2, 0.5, 0.1, 0.9, -0.4, -0.7, 0.2, 0.6]);
    let mut solver = LcpSolver::new(matrix);
    let solution = solver.solve_from(&[0.0; 3], &[true; 3]).unwrap();
    assert_eq!(solution.lambda, vec![0.0; 3]);
    assert_eq!(solution.w, vec![0.0; 3]);
}

/// Small deterministic generator for the sequence test (xorshift64*).
struct Xorshift(u64);

impl Xorshift {
    /// Uniform in `[-1, 1)`.
    fn next_symmetric(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
    }
}

#[test]
fn warm_started_sequence_matches_enumeration() {
    let n = 10;
    let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
    let b: Vec<f64> = (0..n * n).map(|_| rng.next_symmetric()).collect();
    let matrix = spd_matrix(n, &b);
    let q0: Vec<f64> = (0..n).map(|_| 0.5 * rng.next_symmetric()).collect();
    let q1: Vec<f64> = (0..n).map(|_| 2.0 * rng.next_symmetric()).collect();
    let mut warm = LcpSolver::new(matrix.clone());
    let mut cold = LcpSolver::new(matrix.clone());
    let (mut warm_pivots, mut cold_pivots) = (0, 0);
    let mut active_set_changes = 0;
    let mut previous_active: Option<Vec<bool>> = None;
    for step in 0..200 {
        let t = 4.0 * std::f64::consts::PI * f64::from(step) / 200.0;
        let q: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| a + t.cos() * b).collect();
        let solution = warm.solve(&q).unwrap();
        check_solution(&matrix, &q, &solution).unwrap();
        warm_pivots += solution.pivots;
        cold_pivots += cold.solve_from(&q, &[false; 10]).unwrap().pivots;
        if previous_active
            .as_ref()
            .is_some_and(|p| *p != solution.active)
        {
            active_set_changes += 1;
        }
        previous_active = Some(solution.active);
    }
    assert!(
        active_set_changes > 0,
        "the sequence should open and close contacts"
    );
    assert!(
        warm_pivots < cold_pivots,
        "warm start: {warm_pivots} pivots, cold start: {cold_pivots}"
    );
}

#[test]
fn singular_matrix_is_reported() {
    let mut solver = LcpSolver::new(LcpMatrix::new(2, vec![1.0, 1.0, 1.0, 1.0]));
    let error = solver.solve(&[-1.0, -2.0]).unwrap_err();
    assert!(
        matches!(
            error,
            LcpError::Singular {
                block_size: 2,
                contact: 1
            }
        ),
        "{error}"
    );
}

#[test]
fn non_finite_q_is_reported() {
    let mut solver = LcpSolver::new(LcpMatrix::new(1, vec![1.0]));
    let error = solver.solve(&[f64::NAN]).unwrap_err();
    assert!(
        matches!(error, LcpError::NoConvergence { pivots: 0, .. }),
        "{error}"
    );
    // The failed call leaves a usable solver behind.
    assert_eq!(solver.solve(&[-2.0]).unwrap().lambda, vec![2.0]);
}
