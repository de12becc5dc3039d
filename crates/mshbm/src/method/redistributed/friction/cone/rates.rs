//! The rates of the cone law at one instant (docs/theory.md (T187), (T193)): the driving
//! rates of the cone margins, and the choice of which contacts on the cone's boundary slip,
//! a complementarity problem in the slip speeds.

use super::march::{Closed, March};
use super::*;

/// A contact that sticks with its cone margin below this many (T153) tolerances is on the
/// boundary of the cone for (T193).
pub(super) const BOUNDARY_TOLERANCES: f64 = 10.0;

impl March<'_> {
    /// The right-hand side of (T187) for `contacts` along `direction`: the rate at which the
    /// free gap's motion alone changes each contact's cone margin,
    /// `μ_c (Y_C γ̇_C)_N,c + e_cᵀ (Y_C γ̇_C)_T,c` (only the rows needed).
    pub(super) fn driving_rates(
        &self,
        tau: f64,
        closed: &Closed,
        contacts: &[usize],
        direction: &[[f64; 2]],
    ) -> Vec<f64> {
        let n = self.law.n;
        let k = closed.rows.len();
        let mut g = vec![0.0; 3 * n];
        let mut gd = vec![0.0; 3 * n];
        self.gamma_at(tau, &mut g, Some(&mut gd));
        let gk: Vec<f64> = closed.rows.iter().map(|&r| gd[r]).collect();
        // Y γ̇_K, row by row
        let row = |i: usize| -> f64 { (0..k).map(|j| closed.y[i * k + j] * gk[j]).sum() };
        contacts
            .iter()
            .zip(direction)
            .map(|(&c, e)| {
                let (nc, tc) = (
                    closed.normal_row[c].unwrap(),
                    closed.tangent_row[c].unwrap(),
                );
                self.law.mu[c] * row(nc) + e[0] * row(tc) + e[1] * row(tc + 1)
            })
            .collect()
    }

    /// Which closed contacts on the cone's boundary slip at `τ` (T193): those that slip and
    /// those that stick with the margin `μ λ_N − |λ_T|` at round-off solve the complementarity
    /// problem `w = A κ − b ≥ 0, κ ≥ 0, wᵀκ = 0` of (T187)'s matrix and right-hand side; a
    /// contact slips where its speed `κ_c > 0`. Returns whether a mode changed; `false` also
    /// where the problem has no unique solution (`A` not a P-matrix), leaving the choice to
    /// the one-contact flips of (T188).
    pub(super) fn choose_slip(
        &mut self,
        tau: f64,
        modes: &mut [ConeMode],
        anchors: &[f64],
    ) -> Result<bool> {
        let n = self.law.n;
        let closed = self.closed(modes)?;
        let lambda = self.forces(tau, modes, anchors, &closed);
        let boundary = BOUNDARY_TOLERANCES * INDICATOR_TOLERANCE * self.force_scale;
        let candidates: Vec<usize> = (0..n)
            .filter(|&c| {
                let tangential = lambda[n + c].hypot(lambda[2 * n + c]);
                closed.tangent_row[c].is_some()
                    && lambda[c] > 0.0
                    && (modes[c] == ConeMode::Slip
                        || (modes[c] == ConeMode::Stick
                            && self.law.mu[c] * lambda[c] - tangential <= boundary))
            })
            .collect();
        if candidates.len() < 2 {
            return Ok(false);
        }
        let direction = self.directions_at(tau, &closed, &candidates, &lambda);
        let a = self.slip_matrix(&closed, &candidates, &direction);
        let b = self.driving_rates(tau, &closed, &candidates, &direction);
        let q: Vec<f64> = b.iter().map(|v| -v).collect();
        let Ok(solution) = LcpSolver::new(LcpMatrix::new(candidates.len(), a)).solve(&q) else {
            return Ok(false);
        };
        let mut changed = false;
        for (i, &c) in candidates.iter().enumerate() {
            let mode = if solution.lambda[i] > 0.0 {
                ConeMode::Slip
            } else {
                ConeMode::Stick
            };
            changed |= modes[c] != mode;
            modes[c] = mode;
        }
        Ok(changed)
    }

    /// The slip directions of `contacts` (T187); at the cone's apex (a contact closing, or
    /// unloading to 0, `|λ_T,c|` at round-off) the direction of the round-off force means
    /// nothing, and the force grows along its rate: `e_c = −λ̇_T,c/|λ̇_T,c|` (T193).
    pub(super) fn directions_at(
        &self,
        tau: f64,
        closed: &Closed,
        contacts: &[usize],
        lambda: &[f64],
    ) -> Vec<[f64; 2]> {
        let mut direction = self.directions(contacts, lambda);
        for (i, &c) in contacts.iter().enumerate() {
            if self.at_apex(lambda, c) {
                let rate = self.stick_rate(tau, closed, c);
                let norm = rate[0].hypot(rate[1]);
                if norm > 0.0 {
                    direction[i] = [-rate[0] / norm, -rate[1] / norm];
                }
            }
        }
        direction
    }

    /// Whether contact `c`'s tangential force `λ_T,c` is within ten tolerances of (T153) of
    /// the cone's apex, where its slip direction is its rate's (T193), (T223).
    pub(super) fn at_apex(&self, lambda: &[f64], c: usize) -> bool {
        let n = self.law.n;
        let apex = BOUNDARY_TOLERANCES * INDICATOR_TOLERANCE * self.force_scale;
        lambda[n + c].hypot(lambda[2 * n + c]) <= apex
    }

    /// `λ̇_T,c` of a closed contact with friction while no contact slips, `−(Y_C γ̇_C)_T,c`
    /// (T186).
    pub(super) fn stick_rate(&self, tau: f64, closed: &Closed, c: usize) -> [f64; 2] {
        let n = self.law.n;
        let k = closed.rows.len();
        let mut g = vec![0.0; 3 * n];
        let mut gd = vec![0.0; 3 * n];
        self.gamma_at(tau, &mut g, Some(&mut gd));
        let tc = closed.tangent_row[c].unwrap();
        let row = |i: usize| -> f64 {
            -(0..k)
                .map(|j| closed.y[i * k + j] * gd[closed.rows[j]])
                .sum::<f64>()
        };
        [row(tc), row(tc + 1)]
    }
}
