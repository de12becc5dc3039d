//! The penalty law `λ_c = k_p,c max(0, −g_c)` of the HBM-AFT (docs/theory.md §7): the contact
//! state at the samples (the AFT), the groups of samples or intervals with the same active
//! penalty springs, the exact quadrature of the penalty force between penetration times
//! (docs/theory.md §6), and the penetration of a solution.

use std::collections::HashMap;

use super::samples::{ContactState, PenaltyGroup};
use super::HbmAft;
use crate::error::Result;
use crate::harmonic::{
    add_interval_gram, basis_derivative, evaluate, n_coefficients, polynomial_extremum,
};
use crate::method::check_dimension;
use crate::problem::PeriodicProblem;
use crate::roots::find_sign_change;

impl HbmAft {
    /// The AFT: `q_N(τ_j)`, gaps and penalty forces at every sample.
    pub(super) fn contact_state(&self, x: &[f64]) -> ContactState {
        let (n, nc, ns) = (self.n(), self.n_contacts(), self.sampling.len());
        let mut displacement = vec![0.0; ns * n];
        let mut gap = vec![0.0; ns * nc];
        let mut force = vec![0.0; ns * nc];
        for j in 0..ns {
            let q = &mut displacement[j * n..(j + 1) * n];
            self.sampling.synthesize_into(j, x, n, q);
            for c in 0..nc {
                let g = self.gap[c] + (0..n).map(|i| self.w[i * nc + c] * q[i]).sum::<f64>();
                gap[j * nc + c] = g;
                force[j * nc + c] = self.penalty[c] * (-g).max(0.0);
            }
        }
        let mut state = ContactState {
            force,
            gap,
            displacement,
            slider: None,
        };
        if let Some(jenkins) = &self.jenkins {
            state.slider = Some(self.slider_state(jenkins, &state));
        }
        state
    }

    /// Fourier coefficients of the contact force on the N DOFs, `F̂_c = E_dft [W λ_j]`
    /// (with friction `E_dft [W λ_N,j + T λ_T,j]`, docs/theory.md (T164)).
    pub(super) fn contact_force_coefficients(&self, state: &ContactState) -> Vec<f64> {
        let (n, nc, ns) = (self.n(), self.n_contacts(), self.sampling.len());
        let mut f = vec![0.0; ns * n];
        for j in 0..ns {
            for c in 0..nc {
                let l = state.force[j * nc + c];
                if l != 0.0 {
                    for i in 0..n {
                        f[j * n + i] += self.w[i * nc + c] * l;
                    }
                }
            }
        }
        if let (Some(jenkins), Some(slider)) = (&self.jenkins, &state.slider) {
            for j in 0..ns {
                for c in 0..nc {
                    let l = slider.force[j * nc + c];
                    if l != 0.0 {
                        for i in 0..n {
                            f[j * n + i] += jenkins.tangent[i * nc + c] * l;
                        }
                    }
                }
            }
        }
        self.sampling.dft_set(&f, n)
    }

    /// `K_A` for a set of contacts.
    fn penalty_stiffness(&self, active: impl Iterator<Item = usize>) -> Vec<f64> {
        let (n, ncon) = (self.n(), self.n_contacts());
        let mut ka = vec![0.0; n * n];
        for c in active {
            let kp = self.penalty[c];
            for i in 0..n {
                let wi = self.w[i * ncon + c];
                if wi != 0.0 {
                    for l in 0..n {
                        ka[i * n + l] += kp * wi * self.w[l * ncon + c];
                    }
                }
            }
        }
        ka
    }

    /// Samples grouped by their set of penetrating contacts (`g < 0`; a sample with
    /// `g = 0` counts as open), with the DFT Gram block of each group.
    pub(super) fn sample_groups(&self, state: &ContactState) -> Vec<PenaltyGroup> {
        if let (Some(jenkins), Some(slider)) = (&self.jenkins, &state.slider) {
            return self.jenkins_groups(jenkins, state, slider);
        }
        let ncon = self.n_contacts();
        let nc = n_coefficients(self.harmonics);
        let mut grams: HashMap<Vec<bool>, Vec<f64>> = HashMap::new();
        for j in 0..self.sampling.len() {
            let active: Vec<bool> = (0..ncon).map(|c| state.force[j * ncon + c] > 0.0).collect();
            if !active.iter().any(|&a| a) {
                continue;
            }
            let gram = grams.entry(active).or_insert_with(|| vec![0.0; nc * nc]);
            self.sampling.add_sample_gram(j, gram);
        }
        grams
            .into_iter()
            .map(|(active, gram)| PenaltyGroup {
                stiffness: self.penalty_stiffness((0..ncon).filter(|&c| active[c])),
                gram,
            })
            .collect()
    }

    /// Exact quadrature: per contact, the intervals where the series `g_c(τ)` is negative
    /// (roots located cell by cell on the sample grid, including dips inside a cell) and
    /// the closed-form Gram block over them; the penalty force `−k_p g_c` is a trigonometric
    /// polynomial there, so its Fourier coefficients are exact, and they are continuously
    /// differentiable in `x` (the force vanishes at the interval ends).
    pub(super) fn exact_penalty(
        &self,
        x: &[f64],
        state: &ContactState,
    ) -> (Vec<f64>, Vec<PenaltyGroup>) {
        let (n, ncon) = (self.n(), self.n_contacts());
        let h = self.harmonics;
        let nc = n_coefficients(h);
        let mut fc = vec![0.0; n * nc];
        let mut groups = Vec::new();
        for (c, g) in self.gap_coefficients(x).iter().enumerate() {
            let intervals = self.penetration_intervals(g, |j| state.gap[j * ncon + c]);
            if intervals.is_empty() {
                continue;
            }
            let mut gram = vec![0.0; nc * nc];
            for &(a, b) in &intervals {
                add_interval_gram(h, a, b, &mut gram);
            }
            // λ̂_c = −k_p Γ_c ĝ_c, force W λ
            let kp = self.penalty[c];
            for m in 0..nc {
                let l: f64 = -kp * (0..nc).map(|k| gram[m * nc + k] * g[k]).sum::<f64>();
                for i in 0..n {
                    fc[m * n + i] += self.w[i * ncon + c] * l;
                }
            }
            groups.push(PenaltyGroup {
                stiffness: self.penalty_stiffness(std::iter::once(c)),
                gram,
            });
        }
        (fc, groups)
    }

    /// The intervals of `[0, 2π)` (in `τ = ωt`; one may reach past `2π`, wrapping round)
    /// where the gap series `g` (coefficients) is negative, given its values at the samples
    /// (`gap_at(j)`): sign changes between samples, and within a cell an extremum that
    /// crosses zero (grazing, or a contact shorter than a cell), located to round-off.
    pub(super) fn penetration_intervals(
        &self,
        g: &[f64],
        gap_at: impl Fn(usize) -> f64,
    ) -> Vec<(f64, f64)> {
        let (h, ns) = (self.harmonics, self.sampling.len());
        let two_pi = 2.0 * std::f64::consts::PI;
        let dg = |t: f64| -> f64 {
            basis_derivative(h, t)
                .iter()
                .zip(g)
                .map(|(b, v)| b * v)
                .sum::<f64>()
        };
        let value = |t: f64| evaluate(g, t);
        let mut roots = Vec::new();
        for j in 0..ns {
            let a = self.sampling.taus[j];
            let b = if j + 1 < ns {
                self.sampling.taus[j + 1]
            } else {
                two_pi
            };
            let ga = gap_at(j);
            let gb = gap_at((j + 1) % ns);
            if (ga < 0.0) != (gb < 0.0) {
                roots.push(find_root(&value, a, b, ga, gb));
            } else {
                let (da, db) = (dg(a), dg(b));
                if (da < 0.0) != (db < 0.0) {
                    let m = find_root(&dg, a, b, da, db);
                    let gm = value(m);
                    if (gm < 0.0) != (ga < 0.0) {
                        roots.push(find_root(&value, a, m, ga, gm));
                        roots.push(find_root(&value, m, b, gm, gb));
                    }
                }
            }
        }
        if roots.is_empty() {
            return if gap_at(0) < 0.0 {
                vec![(0.0, two_pi)]
            } else {
                Vec::new()
            };
        }
        roots.sort_by(f64::total_cmp);
        let mut intervals = Vec::new();
        for (i, &a) in roots.iter().enumerate() {
            let b = roots.get(i + 1).copied().unwrap_or(roots[0] + two_pi);
            if b > a && value(0.5 * (a + b)) < 0.0 {
                intervals.push((a, b));
            }
        }
        intervals
    }

    /// Coefficients of the gap `g_c(τ) = w_cᵀ q_N(τ) + g0_c` of each contact.
    pub(super) fn gap_coefficients(&self, x: &[f64]) -> Vec<Vec<f64>> {
        let (n, ncon) = (self.n(), self.n_contacts());
        let nc = n_coefficients(self.harmonics);
        (0..ncon)
            .map(|c| {
                let mut g: Vec<f64> = (0..nc)
                    .map(|m| (0..n).map(|i| self.w[i * ncon + c] * x[m * n + i]).sum())
                    .collect();
                g[0] += self.gap[c];
                g
            })
            .collect()
    }

    /// Penetration `max_τ (−g_c(τ))` of each contact over the time signal (the truncated
    /// series `q_N(τ)`, refined between samples); negative when the contact never closes.
    pub fn penetration(&self, x: &[f64]) -> Result<Vec<f64>> {
        check_dimension(x, self.dimension())?;
        Ok(self
            .gap_coefficients(x)
            .iter()
            .map(|g| -polynomial_extremum(g, self.sampling.len(), -1.0))
            .collect())
    }

    /// Penetration `max_j (−g_c(τ_j))` of each contact over the AFT samples (what the
    /// penalty sees).
    pub fn sample_penetration(&self, x: &[f64]) -> Result<Vec<f64>> {
        check_dimension(x, self.dimension())?;
        let state = self.contact_state(x);
        let ncon = self.n_contacts();
        Ok((0..ncon)
            .map(|c| {
                (0..self.sampling.len())
                    .map(|j| -state.gap[j * ncon + c])
                    .fold(f64::NEG_INFINITY, f64::max)
            })
            .collect())
    }
}

/// Root of `f` in `[a, b]` with `f(a) = fa`, `f(b) = fb` of opposite signs, to round-off
/// ([`find_sign_change`]).
fn find_root(f: &impl Fn(f64) -> f64, a: f64, b: f64, fa: f64, fb: f64) -> f64 {
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    find_sign_change(f, a, b, fa, fb).nearest()
}
