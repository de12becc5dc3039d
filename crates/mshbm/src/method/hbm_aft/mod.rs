//! Classical harmonic balance with the alternating frequency–time method (AFT, Cameron &
//! Griffin 1989) and penalty contact (docs/theory.md §7): the baseline of the paper's Fig. 11, the
//! method users of NLvib and pyHarm know.
//!
//! **Unknowns** are the Fourier coefficients `x = q̂_N` of the DOFs of the contact nodes,
//! harmonic-major as everywhere (docs/theory.md (T8)), exactly as for the redistributed MS-HBM, so
//! the length scale, the response DOF and [`PeriodicSolution`] mean the same. Unlike the
//! MS-HBM, `q_N(τ)` *is* the truncated series here.
//!
//! **Exact condensation** of the linear part. Per harmonic `k` the full dynamic stiffness
//! `A_k = K − (kω)² M + i kω C` (complex form of eq. 8, `z = a − i b` for
//! `a cos kτ + b sin kτ`) is split into the blocks `LL, LN, NL, NN`. With the consistent
//! mass `M_NL`, `M_NN` (and with mass-proportional damping `C_NL`, `C_NN`) are nonzero, so
//! every block is frequency dependent. Per frequency ([`crate::linear::ExactCondensation`]
//! with [`crate::linear::LinearResponse::Stored`]), `A_LL,k` is factored once and
//!
//! ```text
//! Y_k = A_LL,k⁻¹ A_LN,k,   u_k = A_LL,k⁻¹ F_L,k,
//! H̃_k = A_NN,k − A_NL,k Y_k,   F̃_k = F_N,k − A_NL,k u_k      (n_N × n_N, n_N)
//! ```
//!
//! are precomputed; `q̂_L,k = u_k − Y_k z_k` gives the linear DOFs for free.
//!
//! **Residual.** In `M q'' + C q' + K q = f + W λ` the contact force is on the right-hand
//! side, so
//!
//! ```text
//! R(x, ω) = (H̃(ω) x − F̃(ω) − F̂_c(x)) / k_ref,                                   (T51)
//! F̂_c = E_dft [W λ(τ_j)]_j,   λ_c(τ_j) = k_p,c · max(0, −g_c(τ_j)),   g = Wᵀ q_N + g0, (T49)
//! q_N(τ_j) = E_idft x                      (the AFT: [`Sampling`] in both directions).
//! ```
//!
//! `k_ref` is the largest diagonal entry of `K_NN` (the contact DOF's stiffness, `EA/h`
//! for the bar). Dividing by it turns the force residual into a displacement, so that
//! [`crate::newton::NewtonOptions::tolerance`] (relative to
//! [`PeriodicProblem::length_scale`]) means the same as for the MS-HBM, whose residual
//! `x − FFT(q_N)` is a displacement: with the redistributed mass and no contact the two
//! residuals of the bar are identical (`x − q_N(x) = K_NN⁻¹ × force residual`).
//!
//! **Jacobian** (analytic, docs/theory.md (T53)): `∂R/∂x = (H̃ + Σ_A Γ_A ⊗ K_A) / k_ref`,
//! where `H̃` acts per harmonic as the real block `[[Re H̃_k, Im H̃_k], [−Im H̃_k, Re H̃_k]]`,
//! the samples are grouped by their set `A` of penetrating contacts, `Γ_A` is the DFT Gram
//! block of the group (`E_dft diag(1_A) E_idft`, [`Sampling::add_sample_gram`]) and
//! `K_A = Σ_{c∈A} k_p,c w_c w_cᵀ` (T52). A sample with `g = 0` counts as open (derivative 0).
//! **Frequency derivative**: `∂R_k/∂ω = (∂A_NN z + ∂A_NL q̂_L + A_NL ∂q̂_L) / k_ref` with
//! `∂q̂_L = −A_LL⁻¹ (∂A_LL q̂_L + ∂A_LN z)` and `∂A/∂ω = −2k²ω M + i k C` (one sparse
//! solve per harmonic) — equal to `∂H̃/∂ω z − ∂F̃/∂ω` of docs/theory.md (T24), (T54)
//! without forming `∂H̃/∂ω`. The contact force does not depend on ω (sampled in `τ = ωt`).
//!
//! **Penalty.** `k_p` is either given (force per length, every contact) or a multiple of
//! the contact's own stiffness `k_c = w_cᵀ K_NN w_c / (w_cᵀ w_c)²` (T50) (so that `k_p w_c w_cᵀ`
//! adds `factor × ` the structure's stiffness along the contact normal); the default is
//! [`DEFAULT_PENALTY_FACTOR`]` = 100 × k_c` (`1.05e8 N/mm` for the paper's bar, whose
//! `K_NN = EA/h = 1.05e6 N/mm`). The solution depends on `k_p`: the contact is only
//! approximately satisfied (penetration `max(−g) ~ λ/k_p`), and large `k_p` makes the
//! residual stiff and kinked, so Newton and continuation need more, smaller steps — the
//! paper's point in Fig. 11.
//!
//! **Quadrature.** [`Quadrature::Sampled`] (default) is the classical AFT above. Its
//! residual is piecewise linear in `x`: the Jacobian jumps whenever a sample enters or
//! leaves penetration, by an amount that grows with `k_p`, so FRD branches are polylines
//! whose folds sit on kinks, where continuation may stop (from `k_p ≈ 10 k_c` on the bar).
//! [`Quadrature::Exact`] integrates the penalty force `−k_p g_c(τ)` in closed form over the
//! intervals where the series `g_c(τ)` is negative (roots located on the sample grid, Gram
//! blocks of [`crate::harmonic::add_interval_gram`]); the force vanishes at the interval
//! ends, so the residual is continuously differentiable and `∂R/∂x` keeps the form above
//! with interval Gram blocks. It is the limit of the sampled AFT as `N_s → ∞` (T48).
//!
//! **Friction** (docs/theory.md §20, "HBM-AFT with Jenkins elements", (T161)–(T169)). A
//! contact with friction gets a Jenkins element along its tangent: a tangential penalty
//! spring `k_t` ([`HbmAftOptions::tangential_penalty`], default `k_t = k_p`) in series with a
//! Coulomb slider of limit `μ λ_N`. `jenkins.rs` moves the slider over the samples by the
//! return mapping, finds its periodic state without iteration (the period map is a
//! projection onto an interval), and adds the slider's forces and their exact
//! piecewise-linear derivative (per-sample stiffnesses, and per run of stuck samples the
//! coupling to the sample where the slider stopped) to the residual and the Jacobian. Only
//! the sampled quadrature; no Floquet multipliers with friction.
//!
//! **Starting point.** From the linear response, Newton on a stiff penalty cycles between
//! contact states; [`PeriodicProblem::initial_guess`] is therefore a homotopy in `k_p`
//! ([`HbmAft::penalty_homotopy`]).
//!
//! **Mass.** The consistent mass by default (the classical method); the redistributed
//! (massless boundary) mass is available. Without contact, with the redistributed mass,
//! the result is the MS-HBM's. With contact the two methods differ at finite `H` even as
//! `k_p → ∞`: the HBM-AFT constrains the *truncated* series `q_N(τ)`, the MS-HBM the
//! non-harmonic `q_N(t)` (for the bar `min(q_99(t), g0)`); on the gap-0 bar at 60 kHz the
//! min displacement of the contact DOF differs by 2.1 % at `H = 5` and 0.7 % at `H = 10`
//! (see `tests/hbm_aft.rs`). Any damping is accepted (the contact DOFs need not be static).
//!
//! **Files**: this one holds the settings, the construction, the residual, the Jacobian,
//! the linear response and the [`PeriodicProblem`] implementation; `penalty.rs` the penalty
//! law at the samples and its exact quadrature between penetration times (the contact
//! state, the penalty groups, the penetration); `jenkins.rs` the Jenkins elements of the
//! frictional contacts; `homotopy.rs` the penalty homotopy of the initial guess (which scales
//! `k_t` with `k_p`).

mod floquet;
mod homotopy;
pub mod jenkins;
mod penalty;
mod periodic_problem;
mod samples;

use samples::{ContactState, PenaltyGroup};

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

use super::partition::{contact_directions, Partition, SingularStiffness};
use super::{check_dimension, complex_harmonic, store_harmonic, zero};
use crate::error::{Error, Result};
use crate::harmonic::{n_coefficients, Quadrature, Sampling};
use crate::limits::Limits;
use crate::linear::PartitionedSystem;
use crate::linear::{Condensation, CondensedFrequency, ExactCondensation, LinearResponse};
use crate::method::default_samples;
use crate::model::{MassKind, Model, System};
use crate::problem::PeriodicProblem;

/// Default penalty stiffness as a multiple of the contact's own stiffness
/// (`k_p = 100 k_c`; see the module docs).
pub const DEFAULT_PENALTY_FACTOR: f64 = 100.0;

/// The penalty stiffness `k_p` of the contact law `λ = k_p max(0, −g)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Penalty {
    /// The same `k_p` (force per length, e.g. N/mm) for every contact.
    Stiffness(f64),
    /// `k_p,c = factor · k_c` with `k_c = w_cᵀ K_NN w_c / (w_cᵀ w_c)²` the stiffness of the
    /// structure at the contact along its normal (`K_NN = EA/h` for the bar).
    Relative(f64),
}

impl Default for Penalty {
    fn default() -> Self {
        Penalty::Relative(DEFAULT_PENALTY_FACTOR)
    }
}

impl Penalty {
    fn value(&self) -> f64 {
        match *self {
            Penalty::Stiffness(v) | Penalty::Relative(v) => v,
        }
    }
}

/// Settings of the HBM-AFT.
#[derive(Clone, Debug)]
pub struct HbmAftOptions {
    /// Number of harmonics `H ≥ 1`.
    pub harmonics: usize,
    /// Samples per period of the AFT, `N_s ≥ 2H + 1` (`None`: the MS-HBM's
    /// [`default_samples`]).
    pub samples: Option<usize>,
    /// Mass matrix (the classical method: [`MassKind::Consistent`]).
    pub mass: MassKind,
    pub penalty: Penalty,
    /// The tangential penalty `k_t` of the Jenkins element of every frictional contact
    /// (docs/theory.md (T161)): a stiffness, or a multiple of the structure's stiffness along
    /// the contact's tangent (`t_cᵀ K_NN t_c / (t_cᵀ t_c)²`); `None`: `k_t = k_p` of the same
    /// contact. Ignored without friction.
    pub tangential_penalty: Option<Penalty>,
    /// Fourier coefficients of the penalty force: [`Quadrature::Sampled`] is the classical
    /// AFT (DFT of the force samples); [`Quadrature::Exact`] integrates the force in closed
    /// form between the located penetration times of the series `q_N(τ)`.
    pub quadrature: Quadrature,
}

impl HbmAftOptions {
    /// Consistent mass, default samples, default penalty, sampled AFT.
    pub fn new(harmonics: usize) -> Self {
        HbmAftOptions {
            harmonics,
            samples: None,
            mass: MassKind::Consistent,
            penalty: Penalty::default(),
            tangential_penalty: None,
            quadrature: Quadrature::Sampled,
        }
    }
}

/// The condensation at one frequency with the condensed blocks the residual uses.
struct FrequencyData {
    condensed: Box<dyn CondensedFrequency>,
    /// `H̃_k = A_NN,k − G_k` (`n × n`).
    htilde: Vec<Mat<c64>>,
    /// `F̃_k = F_N,k − u0_k` (`n`).
    ftilde: Vec<Vec<c64>>,
}

/// Classical HBM with AFT and penalty contact for one model.
pub struct HbmAft {
    system: System,
    harmonics: usize,
    sampling: Sampling,
    quadrature: Quadrature,
    /// The linear part condensed onto the contact-node DOFs (`H̃_k`, `F̃_k`).
    condensation: Box<dyn Condensation>,
    /// `L | N` partition and length scale.
    partition: Partition,
    /// `W` (`n × n_c`, row-major).
    w: Vec<f64>,
    gap: Vec<f64>,
    penalty: Vec<f64>,
    contact_stiffness: Vec<f64>,
    reference_stiffness: f64,
    frequency: Option<FrequencyData>,
    /// Newton iterations spent by the last [`PeriodicProblem::initial_guess`].
    guess_iterations: usize,
    /// The variational system of the Floquet analysis (built when first asked).
    stability: Option<floquet::PenaltyStability>,
    /// The Jenkins elements of the frictional contacts (docs/theory.md §20, (T161)); `None` without
    /// friction.
    jenkins: Option<jenkins::Jenkins>,
}

fn mat_vec(a: &Mat<c64>, x: &[c64]) -> Vec<c64> {
    (0..a.nrows())
        .map(|i| (0..a.ncols()).fold(zero(), |s, j| s + a[(i, j)] * x[j]))
        .collect()
}

impl HbmAft {
    /// Set up the method for `model` (mass choice, partition, penalty, checks) within the
    /// default [`Limits`] (the machine's memory).
    pub fn new(model: &Model, options: &HbmAftOptions) -> Result<Self> {
        Self::within(model, options, &Limits::default())
    }

    /// [`HbmAft::new`], refusing before allocating when the method's memory estimate
    /// ([`super::memory::hbm_aft`]) exceeds `limits`.
    pub fn within(model: &Model, options: &HbmAftOptions, limits: &Limits) -> Result<Self> {
        let h = options.harmonics;
        let samples = options.samples.unwrap_or_else(|| default_samples(h));
        super::check_resolution(h, samples, "samples")?;
        let pv = options.penalty.value();
        if !(pv.is_finite() && pv > 0.0) {
            return Err(Error::argument(
                "penalty",
                format!("the penalty stiffness must be a positive number, got {pv}"),
            ));
        }
        if model.contacts.is_empty() {
            return Err(Error::argument(
                "model",
                "the model has no contact; the HBM-AFT with penalty contact needs at least one",
            ));
        }
        if !model.frictions.is_empty() {
            return Err(Error::field(
                &model.source,
                "frictions",
                "the HBM-AFT baseline models friction on contacts (`mu` of an interface, as Jenkins elements) but not friction elements (`[[frictions]]`); use the general MS-HBM",
            ));
        }
        model.refuse_cone_friction("the HBM-AFT baseline (Jenkins elements)")?;
        let frictional = model.contacts.iter().any(|c| c.friction.is_some());
        if frictional && options.quadrature == Quadrature::Exact {
            return Err(Error::argument(
                "quadrature",
                "the exact quadrature of the HBM-AFT integrates the normal penalty force only; with friction on contacts (Jenkins elements) use the sampled AFT",
            ));
        }
        if let Some(Penalty::Stiffness(v) | Penalty::Relative(v)) = options.tangential_penalty {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::argument(
                    "tangential penalty",
                    format!("the tangential penalty stiffness must be a positive number, got {v}"),
                ));
            }
        }
        let system = model.system_cancellable(options.mass, limits.cancel)?;
        super::memory::hbm_aft(&system, h, samples).check(
            &format!("HBM-AFT with {h} harmonics and {samples} samples"),
            limits,
        )?;
        let nl_dofs = &system.nonlinear_dofs;
        let n = nl_dofs.len();
        let nc = system.contacts.len();
        let w = contact_directions(&system);
        let gap: Vec<f64> = system.contacts.iter().map(|c| c.gap).collect();
        let k_nn = system.stiffness.submatrix(nl_dofs, nl_dofs);
        let mut contact_stiffness = Vec::with_capacity(nc);
        for c in 0..nc {
            let wc: Vec<f64> = (0..n).map(|i| w[i * nc + c]).collect();
            let ww: f64 = wc.iter().map(|v| v * v).sum();
            let wkw: f64 = k_nn.iter().map(|(i, j, v)| wc[i] * v * wc[j]).sum();
            if ww == 0.0 || wkw.is_nan() || wkw <= 0.0 {
                return Err(Error::field(
                    &model.source,
                    "contacts",
                    format!(
                        "contact {c}: the structure has no stiffness along its normal (wᵀ K_NN w = {wkw:e}); a penalty relative to it is undefined"
                    ),
                ));
            }
            contact_stiffness.push(wkw / (ww * ww));
        }
        let penalty: Vec<f64> = match options.penalty {
            Penalty::Stiffness(kp) => vec![kp; nc],
            Penalty::Relative(f) => contact_stiffness.iter().map(|k| f * k).collect(),
        };
        let jenkins = if frictional {
            Some(jenkins::jenkins_elements(
                &system,
                &model.source,
                &k_nn,
                &penalty,
                options.tangential_penalty,
            )?)
        } else {
            None
        };
        let reference_stiffness = (0..n).fold(0.0f64, |m, i| m.max(k_nn.get(i, i)));
        let condensation =
            ExactCondensation::new(PartitionedSystem::new(&system), LinearResponse::Stored)?;
        // the same length scale as the redistributed MS-HBM, so that tolerances mean the same
        let partition = Partition::new(&system, SingularStiffness::Refuse)?;
        Ok(HbmAft {
            condensation: Box::new(condensation),
            partition,
            harmonics: h,
            sampling: Sampling::within(h, samples, limits)?,
            quadrature: options.quadrature,
            w,
            gap,
            penalty,
            contact_stiffness,
            reference_stiffness,
            frequency: None,
            guess_iterations: 0,
            stability: None,
            jenkins,
            system,
        })
    }

    /// The system (mass choice applied, Dirichlet DOFs removed).
    pub fn system(&self) -> &System {
        &self.system
    }

    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    pub fn samples(&self) -> usize {
        self.sampling.len()
    }

    pub fn quadrature(&self) -> Quadrature {
        self.quadrature
    }

    /// Penalty stiffness `k_p` of each contact (force per length).
    pub fn penalties(&self) -> &[f64] {
        &self.penalty
    }

    /// Tangential penalty `k_t` of each contact's Jenkins element (force per length; 0 for a
    /// contact without friction); empty without friction.
    pub fn tangential_penalties(&self) -> &[f64] {
        self.jenkins
            .as_ref()
            .map(|j| j.stiffness.as_slice())
            .unwrap_or(&[])
    }

    /// Stiffness `k_c = w_cᵀ K_NN w_c / (w_cᵀ w_c)²` of each contact, the unit of
    /// [`Penalty::Relative`].
    pub fn contact_stiffness(&self) -> &[f64] {
        &self.contact_stiffness
    }

    /// `k_ref`, the largest diagonal entry of `K_NN`: the residual is the force balance
    /// divided by it (a displacement).
    pub fn reference_stiffness(&self) -> f64 {
        self.reference_stiffness
    }

    fn n(&self) -> usize {
        self.system.nonlinear_dofs.len()
    }

    fn n_contacts(&self) -> usize {
        self.gap.len()
    }

    fn prepare(&mut self, omega: f64) -> Result<()> {
        if self
            .frequency
            .as_ref()
            .is_some_and(|f| f.condensed.omega() == omega)
        {
            return Ok(());
        }
        super::check_frequency(omega)?;
        let condensed = self.condensation.at(omega, self.harmonics)?;
        let htilde = (0..=self.harmonics)
            .map(|k| condensed.condensed_dynamic_stiffness(k))
            .collect();
        let ftilde = (0..=self.harmonics)
            .map(|k| condensed.condensed_load(k))
            .collect();
        self.frequency = Some(FrequencyData {
            condensed,
            htilde,
            ftilde,
        });
        Ok(())
    }

    fn evaluate(
        &mut self,
        x: &[f64],
        omega: f64,
    ) -> Result<(Vec<f64>, ContactState, Vec<PenaltyGroup>)> {
        check_dimension(x, self.dimension())?;
        self.prepare(omega)?;
        let f = self.frequency.as_ref().expect("prepared");
        let n = self.n();
        let mut r = vec![0.0; x.len()];
        let mut rk = vec![zero(); n];
        for k in 0..=self.harmonics {
            let z = complex_harmonic(x, n, k);
            let hz = mat_vec(&f.htilde[k], &z);
            rk.iter_mut()
                .zip(hz.iter().zip(&f.ftilde[k]))
                .for_each(|(r, (a, b))| *r = *a - *b);
            store_harmonic(&rk, n, k, &mut r);
        }
        let state = self.contact_state(x);
        let (fc, groups) = match self.quadrature {
            // the AFT: DFT of the force samples
            Quadrature::Sampled => (
                self.contact_force_coefficients(&state),
                self.sample_groups(&state),
            ),
            Quadrature::Exact => self.exact_penalty(x, &state),
        };
        let s = 1.0 / self.reference_stiffness;
        r.iter_mut().zip(&fc).for_each(|(r, f)| *r = (*r - f) * s);
        Ok((r, state, groups))
    }

    /// `∂R/∂x = (H̃ + Σ_A Γ_A ⊗ K_A) / k_ref`.
    fn jacobian_matrix(&self, groups: &[PenaltyGroup]) -> Mat<f64> {
        let f = self.frequency.as_ref().expect("prepared");
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let dim = n * nc;
        let mut jac = Mat::<f64>::zeros(dim, dim);
        for k in 0..=self.harmonics {
            let ht = &f.htilde[k];
            if k == 0 {
                for i in 0..n {
                    for j in 0..n {
                        jac[(i, j)] = ht[(i, j)].re;
                    }
                }
                continue;
            }
            let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
            for i in 0..n {
                for j in 0..n {
                    let (re, im) = (ht[(i, j)].re, ht[(i, j)].im);
                    jac[(ci + i, ci + j)] = re;
                    jac[(ci + i, si + j)] = im;
                    jac[(si + i, ci + j)] = -im;
                    jac[(si + i, si + j)] = re;
                }
            }
        }
        for group in groups {
            for m in 0..nc {
                for c in 0..nc {
                    let g = group.gram[m * nc + c];
                    if g == 0.0 {
                        continue;
                    }
                    for i in 0..n {
                        for l in 0..n {
                            jac[(m * n + i, c * n + l)] += g * group.stiffness[i * n + l];
                        }
                    }
                }
            }
        }
        let s = 1.0 / self.reference_stiffness;
        for j in 0..dim {
            for i in 0..dim {
                jac[(i, j)] *= s;
            }
        }
        jac
    }

    /// `∂R/∂ω` at `x`: `∂R_k/∂ω = (∂A_NN,k/∂ω z_k + ∂(A_NL,k q̂_L,k)/∂ω) / k_ref` (one
    /// sparse solve per harmonic).
    fn frequency_derivative(&self, x: &[f64]) -> Result<Vec<f64>> {
        let f = &self.frequency.as_ref().expect("prepared").condensed;
        let omega = f.omega();
        let n = self.n();
        let nn = &self.condensation.system().nn;
        let mut dr = vec![0.0; x.len()];
        for k in 1..=self.harmonics {
            let z = complex_harmonic(x, n, k);
            let mut d = vec![zero(); n];
            nn.add_derivative_times(k, omega, &z, &mut d);
            f.add_coupling_force_derivative(k, &z, &mut d)?;
            store_harmonic(&d, n, k, &mut dr);
        }
        let s = 1.0 / self.reference_stiffness;
        dr.iter_mut().for_each(|v| *v *= s);
        Ok(dr)
    }

    /// The contact-free linear response at `ω` (`H̃_k z_k = F̃_k` per harmonic): the
    /// initial guess, and the solution when no contact closes.
    pub fn linear_response(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.prepare(omega)?;
        let f = self.frequency.as_ref().expect("prepared");
        let n = self.n();
        let mut x = vec![0.0; self.dimension()];
        for k in 0..=self.harmonics {
            if f.ftilde[k].iter().all(|v| *v == zero()) {
                continue;
            }
            let rhs = Mat::<c64>::from_fn(n, 1, |i, _| f.ftilde[k][i]);
            let z = f.htilde[k].partial_piv_lu().solve(&rhs);
            let z: Vec<c64> = (0..n).map(|i| z[(i, 0)]).collect();
            if z.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
                return Err(Error::Singular(format!(
                    "the condensed dynamic stiffness is singular at harmonic {k} (k·f = {:.6} Hz is an eigenfrequency of the structure; add damping or move the frequency)",
                    k as f64 * omega / (2.0 * std::f64::consts::PI)
                )));
            }
            store_harmonic(&z, n, k, &mut x);
        }
        Ok(x)
    }
}
