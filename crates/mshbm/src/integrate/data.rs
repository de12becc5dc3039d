//! The system data the schemes share: contacts and friction elements in system numbering,
//! the matrices and loads of one [`System`](crate::model::System) ([`Data`]) and the
//! integration state ([`State`]).

use crate::sparse::SparseMatrix;

/// The tangent `w_T` (sparse: DOF, weight) and `μ` of one contact's friction.
pub(crate) type ContactFriction = (Vec<(usize, f64)>, f64);

/// Contacts in system numbering: `g = Σ w q + g0`, with Coulomb friction along a tangent
/// `y_T = Σ w_T q` where given (docs/theory.md (T170)).
#[derive(Clone, Debug)]
pub(crate) struct Contacts {
    pub(crate) w: Vec<Vec<(usize, f64)>>,
    pub(crate) gap: Vec<f64>,
    /// Per contact: the tangent `w_T` and `μ` of its friction, `None` without.
    pub(crate) friction: Vec<Option<ContactFriction>>,
}

impl Contacts {
    pub(crate) fn len(&self) -> usize {
        self.gap.len()
    }

    /// Some contact has Coulomb friction (possibly `μ = 0`).
    pub(crate) fn has_friction(&self) -> bool {
        self.friction.iter().any(Option::is_some)
    }

    /// `μ` per contact, `None` without friction.
    pub(crate) fn mu(&self) -> Vec<Option<f64>> {
        self.friction
            .iter()
            .map(|f| f.as_ref().map(|f| f.1))
            .collect()
    }

    /// The tangential coordinate `w_Tᵀ x` of contact `i` (0 without friction).
    pub(crate) fn tangent_dot(&self, i: usize, x: &[f64]) -> f64 {
        self.friction[i]
            .as_ref()
            .map_or(0.0, |(w, _)| w.iter().map(|&(d, w)| w * x[d]).sum())
    }

    /// The columns `[W, W_T]` of the contact coordinates (T170): every normal, then the
    /// tangent of every frictional contact, each dense of length `n`.
    pub(crate) fn coordinate_columns(&self, n: usize) -> Vec<Vec<f64>> {
        let mut columns: Vec<Vec<f64>> = (0..self.len()).map(|i| self.column(i, n)).collect();
        for (w, _) in self.friction.iter().flatten() {
            let mut c = vec![0.0; n];
            for &(d, v) in w {
                c[d] += v;
            }
            columns.push(c);
        }
        columns
    }

    /// `Wᵢᵀ x` (without `g0`).
    pub(crate) fn dot(&self, i: usize, x: &[f64]) -> f64 {
        self.w[i].iter().map(|&(d, w)| w * x[d]).sum()
    }

    /// Gaps `Wᵀ q + g0`.
    pub(crate) fn gaps_into(&self, q: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.dot(i, q) + self.gap[i];
        }
    }

    /// Column `i` of `W` as a dense vector of length `n`.
    pub(crate) fn column(&self, i: usize, n: usize) -> Vec<f64> {
        let mut c = vec![0.0; n];
        for &(d, w) in &self.w[i] {
            c[d] += w;
        }
        c
    }
}

/// Friction elements in system numbering (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Frictions {
    pub(crate) w: Vec<Vec<(usize, f64)>>,
    pub(crate) mu: Vec<f64>,
    /// `Ok(F_N)` prescribed normal force, `Err(i)` the force of contact `i`.
    pub(crate) normal: Vec<std::result::Result<f64, usize>>,
}

impl Frictions {
    pub(crate) fn len(&self) -> usize {
        self.mu.len()
    }

    pub(crate) fn dot(&self, i: usize, x: &[f64]) -> f64 {
        self.w[i].iter().map(|&(d, w)| w * x[d]).sum()
    }

    pub(crate) fn column(&self, i: usize, n: usize) -> Vec<f64> {
        let mut c = vec![0.0; n];
        for &(d, w) in &self.w[i] {
            c[d] += w;
        }
        c
    }
}

/// The immutable data of an integration: matrices, loads, contacts.
pub(crate) struct Data {
    pub(crate) n: usize,
    pub(crate) dt: f64,
    pub(crate) mass: SparseMatrix,
    pub(crate) stiffness: SparseMatrix,
    pub(crate) damping: SparseMatrix,
    pub(crate) constant_load: Vec<f64>,
    /// Amplitudes of `f_harm cos ωt`; empty when there is none.
    pub(crate) harmonic_load: Vec<f64>,
    pub(crate) omega: f64,
    pub(crate) contacts: Contacts,
    pub(crate) frictions: Frictions,
    /// Harmonics and coefficients (harmonic-major, `c·n + i`) of the periodic load.
    pub(crate) periodic_load: Option<(usize, Vec<f64>)>,
    pub(crate) massless: Vec<usize>,
    pub(crate) massive: Vec<usize>,
    pub(crate) energy_offset: f64,
}

impl Data {
    /// `f(t) = f_const + f_harm cos ωt` into `out`.
    pub(crate) fn load_into(&self, t: f64, out: &mut [f64]) {
        out.copy_from_slice(&self.constant_load);
        // an unforced system keeps no harmonic load (no cosine per step)
        if self.omega != 0.0 && !self.harmonic_load.is_empty() {
            let c = (self.omega * t).cos();
            for (o, f) in out.iter_mut().zip(&self.harmonic_load) {
                *o += c * f;
            }
        }
        if let Some((h, coef)) = &self.periodic_load {
            crate::harmonic::add_series_at(*h, self.omega * t, coef, self.n, out);
        }
    }
}

/// The evolving state.
pub(crate) struct State {
    pub(crate) t0: f64,
    pub(crate) steps: u64,
    pub(crate) q: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) gaps: Vec<f64>,
    pub(crate) forces: Vec<f64>,
    /// Friction forces (impulse of the last step / h).
    pub(crate) friction_forces: Vec<f64>,
    /// Tangential forces `λ_T` of the contacts at the current time (zero without friction;
    /// docs/theory.md (T171)).
    pub(crate) tangential_forces: Vec<f64>,
}

impl State {
    pub(crate) fn time(&self, dt: f64) -> f64 {
        self.t0 + self.steps as f64 * dt
    }
}
