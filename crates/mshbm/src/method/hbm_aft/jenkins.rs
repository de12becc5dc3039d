//! Elastic dry friction of the HBM-AFT (docs/theory.md §20 "HBM-AFT with Jenkins elements", (T161)–(T169)): a Jenkins element
//! per frictional contact — a tangential penalty spring `k_t` in series with a Coulomb slider
//! whose limit is `μ λ_N(τ)`, with `λ_N` the normal penalty force of the same contact.
//!
//! The tangential force is `λ_T = −k_t (u_T − a)` with `u_T = t_cᵀ q_N` and the slider
//! position `a`; `|λ_T| ≤ μ λ_N` says that `a` lies in the interval
//! `C(τ) = [u_T − μλ_N/k_t, u_T + μλ_N/k_t]` (T161). Sampled, the slider is moved by the
//! return mapping, which is the projection of the previous position onto `C_j` (T162)
//! ([`periodic_slider`]). A composition of projections onto intervals is itself a projection
//! onto an interval, so the period map is idempotent and its fixed point is found by two
//! marches from `±∞` (T163); a contact stuck all period takes the middle of its admissible
//! anchors, the convention (T157) of the MS-HBM.
//!
//! The return mapping is piecewise linear in the samples, so the Fourier coefficients of the
//! force have an exact derivative (T165), (T166): per sample a local stiffness (normal
//! penalty, stick spring, or the slip force `∓μ k_p` along the normal), and per run of stuck
//! samples the dependence on the sample where the run began ([`StickRun`]), which couples
//! the coefficients through the basis at that sample.

pub use super::samples::SliderMode;
use super::samples::{AnchorTerm, ContactState, PenaltyGroup, SliderState, StickRun};
use super::{HbmAft, Penalty};
use crate::error::{Error, Result};
use crate::harmonic::n_coefficients;
use crate::model::System;
use crate::solution::FrictionSeries;

/// The Jenkins elements of a model's frictional contacts.
#[derive(Clone, Debug)]
pub(super) struct Jenkins {
    /// `T` (`n × n_c`, row-major, as `W`): the unit tangents; a zero column for a contact
    /// without friction.
    pub(super) tangent: Vec<f64>,
    /// `μ` of each contact (0 without friction).
    pub(super) mu: Vec<f64>,
    /// `k_t` of each contact (force per length).
    pub(super) stiffness: Vec<f64>,
}

/// Where the stuck slider of a run was left: the sample `s` where its position was last
/// set (a slip or a free sample), or the middle of the admissible anchors when the contact
/// sticks all period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SliderStart {
    /// The slider stopped at sample `s`.
    After(usize),
    /// Stuck all period at `½ (max_j lo_j + min_j hi_j)` (T163); the samples of the
    /// largest lower and the smallest upper end.
    Centred { lower: usize, upper: usize },
}

/// The periodic slider of one contact over the samples (T162), (T163).
#[derive(Clone, Debug)]
pub struct SliderPeriod {
    /// `λ_T,j`.
    pub force: Vec<f64>,
    pub modes: Vec<SliderMode>,
    /// `a_j` after sample `j`.
    pub position: Vec<f64>,
    /// Where the slider of the stuck samples at the start of the period was left (the last
    /// non-stuck sample of the period, or the centring).
    pub start: SliderStart,
}

/// `x` projected onto `[lo, hi]` (`lo ≤ hi`), without `f64::clamp`'s panic on NaN bounds.
fn project(x: f64, lo: f64, hi: f64) -> f64 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// The periodic state of a Jenkins element driven by the tangential displacements `u[j]`
/// with the slip limits `limit[j] = μ λ_N,j ≥ 0` (a zero limit frees the slider) and the
/// spring `kt` (T162), (T163): the period map is the projection onto `[P(−∞), P(+∞)]`; when
/// the two ends coincide (some sample slips or is free) one march from them is periodic,
/// else every sample sticks and the anchor is the middle of `∩_j C_j`.
pub fn periodic_slider(u: &[f64], limit: &[f64], kt: f64) -> SliderPeriod {
    let ns = u.len();
    let lo = |j: usize| u[j] - limit[j] / kt;
    let hi = |j: usize| u[j] + limit[j] / kt;
    let pass = |mut a: f64| {
        for j in 0..ns {
            a = if limit[j] == 0.0 {
                u[j]
            } else {
                project(a, lo(j), hi(j))
            };
        }
        a
    };
    let (low_end, high_end) = (pass(f64::NEG_INFINITY), pass(f64::INFINITY));
    // the extreme ends of the admissible anchors, for a contact stuck all period
    let (mut lower, mut upper) = (0, 0);
    for j in 1..ns {
        if lo(j) > lo(lower) {
            lower = j;
        }
        if hi(j) < hi(upper) {
            upper = j;
        }
    }
    let mut a = if low_end == high_end {
        low_end
    } else {
        0.5 * (lo(lower) + hi(upper))
    };
    let mut force = vec![0.0; ns];
    let mut modes = vec![SliderMode::Stick; ns];
    let mut position = vec![0.0; ns];
    for j in 0..ns {
        let (l, h) = (lo(j), hi(j));
        modes[j] = if limit[j] == 0.0 {
            a = u[j];
            SliderMode::Free
        } else if a < l {
            a = l;
            SliderMode::SlipPositive
        } else if a > h {
            a = h;
            SliderMode::SlipNegative
        } else {
            SliderMode::Stick
        };
        force[j] = match modes[j] {
            SliderMode::Free => 0.0,
            SliderMode::SlipPositive => -limit[j],
            SliderMode::SlipNegative => limit[j],
            SliderMode::Stick => -kt * (u[j] - a),
        };
        position[j] = a;
    }
    let start = match (0..ns).rev().find(|&j| modes[j] != SliderMode::Stick) {
        Some(s) => SliderStart::After(s),
        None => SliderStart::Centred { lower, upper },
    };
    SliderPeriod {
        force,
        modes,
        position,
        start,
    }
}

impl HbmAft {
    /// The friction force and its limit at the samples of every frictional contact, for a
    /// solution (empty without friction).
    pub(super) fn friction_series(&self, state: &ContactState) -> Vec<FrictionSeries> {
        let (nc, ns) = (self.n_contacts(), self.sampling.len());
        let Some(slider) = &state.slider else {
            return Vec::new();
        };
        self.system
            .contacts
            .iter()
            .enumerate()
            .filter_map(|(c, contact)| {
                let first = contact.friction.as_ref()?.w.first()?.0;
                let force: Vec<f64> = (0..ns).map(|j| slider.force[j * nc + c]).collect();
                Some(FrictionSeries {
                    force2: Vec::new(),
                    dof: self.system.model_dof[first],
                    max: force.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                    min: force.iter().copied().fold(f64::INFINITY, f64::min),
                    limit: (0..ns).map(|j| slider.limit[j * nc + c]).collect(),
                    force,
                    state: Vec::new(),
                })
            })
            .collect()
    }

    /// `α` of a slider position set at a sample in `mode` (T165): `a = u_T ∓ μ λ_N/k_t` with
    /// `λ_N = −k_p (wᵀ q + g0)`, so `∂a/∂q = t ± (μ k_p/k_t) w` (`t` when free).
    fn anchor_gradient(&self, jenkins: &Jenkins, c: usize, mode: SliderMode) -> Vec<f64> {
        let (n, nc) = (self.n(), self.n_contacts());
        let ratio = jenkins.mu[c] * self.penalty[c] / jenkins.stiffness[c];
        let sign = match mode {
            SliderMode::SlipPositive => 1.0,
            SliderMode::SlipNegative => -1.0,
            SliderMode::Free | SliderMode::Stick => 0.0,
        };
        (0..n)
            .map(|i| jenkins.tangent[i * nc + c] + sign * ratio * self.w[i * nc + c])
            .collect()
    }

    /// The periodic Jenkins elements of every frictional contact at the samples of `state`
    /// (whose normal penalty forces are set), with the runs of stuck samples.
    pub(super) fn slider_state(&self, jenkins: &Jenkins, state: &ContactState) -> SliderState {
        let (n, nc, ns) = (self.n(), self.n_contacts(), self.sampling.len());
        let mut out = SliderState {
            force: vec![0.0; ns * nc],
            limit: vec![0.0; ns * nc],
            modes: vec![SliderMode::Free; ns * nc],
            runs: Vec::new(),
        };
        for c in 0..nc {
            if jenkins.mu[c] == 0.0 {
                continue;
            }
            let u: Vec<f64> = (0..ns)
                .map(|j| {
                    let q = &state.displacement[j * n..(j + 1) * n];
                    (0..n).map(|i| jenkins.tangent[i * nc + c] * q[i]).sum()
                })
                .collect();
            let limit: Vec<f64> = (0..ns)
                .map(|j| jenkins.mu[c] * state.force[j * nc + c])
                .collect();
            let period = periodic_slider(&u, &limit, jenkins.stiffness[c]);
            #[allow(clippy::needless_range_loop)] // sample j of contact c, as (T161) writes it
            for j in 0..ns {
                out.force[j * nc + c] = period.force[j];
                out.limit[j * nc + c] = limit[j];
                out.modes[j * nc + c] = period.modes[j];
            }
            // the runs of stuck samples, each with where its slider was left
            let anchor = |start: SliderStart| -> Vec<AnchorTerm> {
                match start {
                    SliderStart::After(s) => vec![AnchorTerm {
                        sample: s,
                        weight: 1.0,
                        alpha: self.anchor_gradient(jenkins, c, period.modes[s]),
                    }],
                    SliderStart::Centred { lower, upper } => vec![
                        AnchorTerm {
                            sample: lower,
                            weight: 0.5,
                            alpha: self.anchor_gradient(jenkins, c, SliderMode::SlipPositive),
                        },
                        AnchorTerm {
                            sample: upper,
                            weight: 0.5,
                            alpha: self.anchor_gradient(jenkins, c, SliderMode::SlipNegative),
                        },
                    ],
                }
            };
            let mut current: Option<StickRun> = None;
            let mut last_set = period.start;
            for j in 0..ns {
                if period.modes[j] == SliderMode::Stick {
                    current
                        .get_or_insert_with(|| StickRun {
                            contact: c,
                            samples: Vec::new(),
                            anchor: anchor(last_set),
                        })
                        .samples
                        .push(j);
                } else {
                    out.runs.extend(current.take());
                    last_set = SliderStart::After(j);
                }
            }
            out.runs.extend(current.take());
        }
        out
    }

    /// The Jacobian groups of the samples with Jenkins elements (T166): the samples grouped
    /// by the normal state and slider mode of every contact, each with its local stiffness
    /// `−∂F_j/∂q_j`, and per run of stuck samples the coupling to where its slider was left.
    pub(super) fn jenkins_groups(
        &self,
        jenkins: &Jenkins,
        state: &ContactState,
        slider: &SliderState,
    ) -> Vec<PenaltyGroup> {
        let (n, ncon, ns) = (self.n(), self.n_contacts(), self.sampling.len());
        let nc = n_coefficients(self.harmonics);
        let mut grams: std::collections::HashMap<Vec<(bool, SliderMode)>, Vec<f64>> =
            std::collections::HashMap::new();
        for j in 0..ns {
            let key: Vec<(bool, SliderMode)> = (0..ncon)
                .map(|c| (state.force[j * ncon + c] > 0.0, slider.modes[j * ncon + c]))
                .collect();
            if key.iter().all(|&(a, m)| !a && m == SliderMode::Free) {
                continue;
            }
            let gram = grams.entry(key).or_insert_with(|| vec![0.0; nc * nc]);
            self.sampling.add_sample_gram(j, gram);
        }
        let mut groups: Vec<PenaltyGroup> = grams
            .into_iter()
            .map(|(key, gram)| {
                let mut k = vec![0.0; n * n];
                for (c, &(active, mode)) in key.iter().enumerate() {
                    let (kp, mu) = (self.penalty[c], jenkins.mu[c]);
                    let w = |i: usize| self.w[i * ncon + c];
                    let t = |i: usize| jenkins.tangent[i * ncon + c];
                    for i in 0..n {
                        for l in 0..n {
                            let mut v = 0.0;
                            if active {
                                v += kp * w(i) * w(l);
                            }
                            v += match mode {
                                SliderMode::Free => 0.0,
                                SliderMode::Stick => jenkins.stiffness[c] * t(i) * t(l),
                                SliderMode::SlipPositive => -mu * kp * t(i) * w(l),
                                SliderMode::SlipNegative => mu * kp * t(i) * w(l),
                            };
                            k[i * n + l] += v;
                        }
                    }
                }
                PenaltyGroup { gram, stiffness: k }
            })
            .collect();
        for run in &slider.runs {
            let c = run.contact;
            let mut row_sum = vec![0.0; nc];
            for &j in &run.samples {
                for (r, v) in row_sum.iter_mut().zip(self.sampling.dft_row(j)) {
                    *r += v;
                }
            }
            for term in &run.anchor {
                let b = &self.sampling.basis[term.sample];
                let mut gram = vec![0.0; nc * nc];
                for m in 0..nc {
                    for k in 0..nc {
                        gram[m * nc + k] = row_sum[m] * term.weight * b[k];
                    }
                }
                // dF_j = k_t t da: the stiffness (−∂F/∂q) is −k_t t αᵀ
                let kt = jenkins.stiffness[c];
                let mut stiffness = vec![0.0; n * n];
                for i in 0..n {
                    for l in 0..n {
                        stiffness[i * n + l] = -kt * jenkins.tangent[i * ncon + c] * term.alpha[l];
                    }
                }
                groups.push(PenaltyGroup { gram, stiffness });
            }
        }
        groups
    }
}

/// The Jenkins elements of `system`'s frictional contacts (docs/theory.md (T161)): the unit
/// tangents in `N` numbering, `μ`, and `k_t` from `tangential` (`None`: the contact's normal
/// penalty `penalty[c]`).
pub(super) fn jenkins_elements(
    system: &System,
    source: &std::path::Path,
    k_nn: &crate::sparse::SparseMatrix,
    penalty: &[f64],
    tangential: Option<Penalty>,
) -> Result<Jenkins> {
    let n = system.nonlinear_dofs.len();
    let nc = system.contacts.len();
    let mut tangent = vec![0.0; n * nc];
    let mut mu = vec![0.0; nc];
    let mut stiffness = vec![0.0; nc];
    for (c, contact) in system.contacts.iter().enumerate() {
        let Some(friction) = &contact.friction else {
            continue;
        };
        if !(friction.mu.is_finite() && friction.mu >= 0.0) {
            return Err(Error::field(
                source,
                "mu",
                format!(
                    "contact {c}: the friction coefficient must be finite and ≥ 0, got {}",
                    friction.mu
                ),
            ));
        }
        if friction.w.is_empty() {
            return Err(Error::field(
                source,
                "mu",
                format!("the tangent of contact {c} has no free DOF"),
            ));
        }
        for &(dof, coeff) in &friction.w {
            let Some(i) = system.nonlinear_dofs.iter().position(|&d| d == dof) else {
                return Err(Error::field(
                    source,
                    "mu",
                    format!("the tangent of contact {c} acts on system DOF {dof}, which is not a DOF of a contact node"),
                ));
            };
            tangent[i * nc + c] += coeff;
        }
        let t: Vec<f64> = (0..n).map(|i| tangent[i * nc + c]).collect();
        let tt: f64 = t.iter().map(|v| v * v).sum();
        let tkt: f64 = k_nn.iter().map(|(i, j, v)| t[i] * v * t[j]).sum();
        mu[c] = friction.mu;
        stiffness[c] = match tangential {
            None => penalty[c],
            Some(Penalty::Stiffness(v)) => v,
            Some(Penalty::Relative(f)) => {
                if tt == 0.0 || tkt.is_nan() || tkt <= 0.0 {
                    return Err(Error::field(
                        source,
                        "mu",
                        format!("contact {c}: the structure has no stiffness along its tangent (tᵀ K_NN t = {tkt:e}); a tangential penalty relative to it is undefined"),
                    ));
                }
                f * tkt / (tt * tt)
            }
        };
    }
    Ok(Jenkins {
        tangent,
        mu,
        stiffness,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slider_is_periodic_after_one_pass_and_centred_when_stuck_all_period() {
        // u = cos τ with a constant limit: the Masing loop, slips twice a period
        let ns = 64;
        let u: Vec<f64> = (0..ns)
            .map(|j| (2.0 * std::f64::consts::PI * j as f64 / ns as f64).cos())
            .collect();
        let p = periodic_slider(&u, &vec![0.5; ns], 1.0);
        // the periodic state repeats: a march from its end position gives itself
        let again = {
            let mut a = p.position[ns - 1];
            (0..ns)
                .map(|j| {
                    a = project(a, u[j] - 0.5, u[j] + 0.5);
                    a
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(again, p.position);
        assert!(p.force.iter().all(|f| f.abs() <= 0.5 + 1e-15));
        assert!(p.modes.contains(&SliderMode::SlipPositive));
        assert!(p.modes.contains(&SliderMode::SlipNegative));
        // symmetric loop: the forces at τ and τ + π are opposite
        for j in 0..ns / 2 {
            assert!((p.force[j] + p.force[j + ns / 2]).abs() < 1e-14);
        }
        // a limit above the excursion: stuck all period, centred (zero mean force here)
        let stuck = periodic_slider(&u, &vec![5.0; ns], 1.0);
        assert!(stuck.modes.iter().all(|&m| m == SliderMode::Stick));
        assert!(matches!(stuck.start, SliderStart::Centred { .. }));
        assert!(stuck.force.iter().sum::<f64>().abs() < 1e-12);
        // a zero limit frees the slider
        let free = periodic_slider(&u, &vec![0.0; ns], 1.0);
        assert!(free.force.iter().all(|&f| f == 0.0));
    }
}
