//! The redistributed MS-HBM with Coulomb friction on its contacts (docs/theory.md §20):
//! the contact coordinates are the normals and then the tangents (T150), so the
//! receptance, the Delassus matrix and the residual (T128) are those of §16 on `2n_c`
//! coordinates, and the frictional law ([`super::friction`]) replaces the static contact
//! problem: `λ̂(u)` and its derivative `S = dλ̂/du` (T158) in the Jacobian (T129).

use std::collections::HashMap;
use std::path::Path;

use faer::Mat;

use std::cell::OnceCell;
use std::rc::Rc;

use super::frequency_maps::{FrequencyMatrices, Map};
use super::friction::cone::{AnchorResponse, ConeContacts, ConePeriodic};
use super::friction::{FrictionalContacts, PeriodicContact};
use super::outputs::{dof_response, NodeHarmonics};
use super::{n_dof_coefficients, refine_extremum, RedistributedMsHbm, MAX_CACHED_INSTANTS};
use crate::error::{Error, Result};
use crate::harmonic::{basis_into, n_coefficients};
use crate::method::partition::DofLocation;
use crate::model::{System, SystemContact};
use crate::solution::{
    ContactSeries, ContactState, FrictionSeries, PeriodicSolution, StateFractions,
};

/// The friction coefficients and which law the tangents make: one tangent per contact (the
/// plane law, (T150)) or two (the Coulomb cone, (T185)).
pub(super) struct FrictionCoordinates {
    pub mu: Vec<f64>,
    pub cone: bool,
}

/// `system` with its contacts' tangents appended as contact coordinates (T150), (T185) —
/// every first tangent, then in space every second one — and the friction coefficients,
/// when its contacts have friction; `system` unchanged otherwise. Either every contact has
/// friction or none (`mu = 0` for a frictionless one), and all have one tangent or all two.
pub(super) fn with_tangent_coordinates(
    mut system: System,
    source: &Path,
) -> Result<(System, Option<FrictionCoordinates>)> {
    let with = system
        .contacts
        .iter()
        .filter(|c| c.friction.is_some())
        .count();
    if with == 0 {
        return Ok((system, None));
    }
    if with < system.contacts.len() {
        let c = system
            .contacts
            .iter()
            .position(|c| c.friction.is_none())
            .expect("some contact has no friction");
        return Err(Error::field(
            source,
            "mu",
            format!(
                "contact {c} has no friction while others have; give every interface a friction coefficient (mu = 0 for a frictionless one)"
            ),
        ));
    }
    let cone = system
        .contacts
        .iter()
        .any(|c| c.friction.as_ref().is_some_and(|f| f.second.is_some()));
    let mut mu = Vec::with_capacity(with);
    let mut tangents = Vec::with_capacity(with);
    let mut seconds = Vec::with_capacity(if cone { with } else { 0 });
    let coordinate = |w: &[(usize, f64)]| SystemContact {
        w: w.to_vec(),
        gap: 0.0,
        friction: None,
    };
    for (c, contact) in system.contacts.iter().enumerate() {
        let friction = contact.friction.as_ref().expect("counted above");
        let second = friction.second.as_deref();
        if friction.w.is_empty() || second.is_some_and(<[_]>::is_empty) {
            return Err(Error::field(
                source,
                "mu",
                format!("a tangent of contact {c} has no free DOF"),
            ));
        }
        match (cone, second) {
            (true, Some(t)) => seconds.push(coordinate(t)),
            (true, None) => {
                return Err(Error::field(
                    source,
                    "mu",
                    format!(
                        "contact {c} has friction along one tangent while others have the Coulomb cone (two tangents); one model mixes plane and 3D friction"
                    ),
                ))
            }
            _ => {}
        }
        mu.push(friction.mu);
        tangents.push(coordinate(&friction.w));
    }
    system.contacts.extend(tangents);
    system.contacts.extend(seconds);
    Ok((system, Some(FrictionCoordinates { mu, cone })))
}

/// The frictional law of the contacts: the plane law (§20) or the Coulomb cone (T185).
pub(super) enum Law {
    Plane(FrictionalContacts),
    Cone(Rc<ConeContacts>),
}

/// The periodic frictional state of one free gap, with the law's derivative `S = dλ̂/dγ̂`.
#[derive(Debug)]
pub(super) enum PeriodicFriction {
    Plane(PeriodicContact),
    Cone {
        law: Rc<ConeContacts>,
        periodic: ConePeriodic,
        /// `S`, row-major (T220), computed when first asked (a residual alone needs none).
        jacobian: OnceCell<Vec<f64>>,
        /// The anchors' response for products `S v` (T225), computed when first asked.
        anchors: OnceCell<AnchorResponse>,
        cells: usize,
    },
}

impl Law {
    pub(super) fn new(delassus: Vec<f64>, coordinates: FrictionCoordinates) -> Result<Self> {
        Ok(if coordinates.cone {
            Law::Cone(Rc::new(ConeContacts::new(delassus, coordinates.mu)?))
        } else {
            Law::Plane(FrictionalContacts::new(delassus, coordinates.mu)?)
        })
    }

    pub(super) fn mu(&self) -> Vec<f64> {
        match self {
            Law::Plane(law) => law.mu().to_vec(),
            Law::Cone(law) => law.mu().to_vec(),
        }
    }

    /// The periodic state of the free gap `gamma` and its derivative (T155)–(T158), (T190),
    /// (T220); `cells` as the laws' `periodic`.
    pub(super) fn periodic(
        &self,
        harmonics: usize,
        gamma: &[f64],
        cells: usize,
    ) -> Result<PeriodicFriction> {
        Ok(match self {
            Law::Plane(law) => PeriodicFriction::Plane(law.periodic(harmonics, gamma, cells)?),
            Law::Cone(law) => PeriodicFriction::Cone {
                law: Rc::clone(law),
                periodic: law.periodic(harmonics, gamma, cells)?,
                jacobian: OnceCell::new(),
                anchors: OnceCell::new(),
                cells,
            },
        })
    }
}

/// The periodic state's values at one instant: the forces `λ`, the contact coordinates `y`
/// and the contacts' states.
pub(super) type StateAt = (Vec<f64>, Vec<f64>, Vec<ContactState>);

impl PeriodicFriction {
    /// `λ̂`, harmonic-major.
    pub(super) fn forces(&self) -> &[f64] {
        match self {
            PeriodicFriction::Plane(p) => &p.forces,
            PeriodicFriction::Cone { periodic, .. } => &periodic.forces,
        }
    }

    /// `S = dλ̂/dγ̂`, row-major (T158), (T220).
    pub(super) fn jacobian(&self) -> Result<&[f64]> {
        match self {
            PeriodicFriction::Plane(p) => Ok(&p.jacobian),
            PeriodicFriction::Cone {
                law,
                periodic,
                jacobian,
                anchors,
                cells,
            } => {
                if jacobian.get().is_none() {
                    let s = match anchors.get() {
                        Some(response) => law.jacobian_with(periodic, response, *cells)?,
                        None => {
                            let (s, response) = law.jacobian_and_response(periodic, *cells)?;
                            let _ = anchors.set(response);
                            s
                        }
                    };
                    let _ = jacobian.set(s);
                }
                Ok(jacobian.get().expect("set above"))
            }
        }
    }

    /// `S v` (T158), (T225): by the dense `S` (formed if need be), or for the cone where
    /// `marched` and `S` is not formed, one tangent march of `v` with the anchors' response
    /// of the periodic state.
    pub(super) fn product(&self, v: &[f64], marched: bool) -> Result<Vec<f64>> {
        let dense = |s: &[f64]| -> Vec<f64> {
            s.chunks_exact(v.len())
                .map(|row| crate::dense::dot(row, v))
                .collect()
        };
        match self {
            PeriodicFriction::Cone {
                law,
                periodic,
                jacobian,
                anchors,
                cells,
            } if marched && jacobian.get().is_none() => {
                if anchors.get().is_none() {
                    let _ = anchors.set(law.anchor_response(periodic, *cells)?);
                }
                let response = anchors.get().expect("set above");
                let mut columns = law.tangent_with(periodic, response, &[v.to_vec()], *cells)?;
                Ok(columns.pop().expect("one direction"))
            }
            _ => Ok(dense(self.jacobian()?)),
        }
    }

    /// The forces at `τ`.
    pub(super) fn force_at(&self, tau: f64) -> Result<Vec<f64>> {
        match self {
            PeriodicFriction::Plane(p) => Ok(p.force_at(tau)),
            PeriodicFriction::Cone { law, periodic, .. } => law.force_at(periodic, tau),
        }
    }

    /// The state at each of `taus`.
    pub(super) fn states_at(&self, taus: &[f64]) -> Result<Vec<StateAt>> {
        match self {
            PeriodicFriction::Plane(p) => Ok(taus
                .iter()
                .map(|&t| {
                    let (lambda, y) = p.state_at(t);
                    let modes = p.modes_at(t).iter().map(|&m| m.into()).collect();
                    (lambda, y, modes)
                })
                .collect()),
            PeriodicFriction::Cone { law, periodic, .. } => Ok(law
                .states_at(periodic, taus)?
                .into_iter()
                .map(|s| (s.lambda, s.y, s.modes.into_iter().map(Into::into).collect()))
                .collect()),
        }
    }

    /// The energy the friction dissipates per period (T180), (T221).
    pub(super) fn dissipated_energy(&self) -> Result<f64> {
        match self {
            PeriodicFriction::Plane(p) => Ok(p.dissipated_energy()),
            PeriodicFriction::Cone { law, periodic, .. } => law.dissipated_energy(periodic),
        }
    }

    pub(super) fn state_fractions(&self) -> Vec<StateFractions> {
        match self {
            PeriodicFriction::Plane(p) => p.state_fractions(),
            PeriodicFriction::Cone { periodic, .. } => periodic.state_fractions(),
        }
    }

    /// The plane law's state (its Floquet analysis, (T182)–(T184), exists for it alone).
    pub(super) fn plane(&self) -> Option<&PeriodicContact> {
        match self {
            PeriodicFriction::Plane(p) => Some(p),
            PeriodicFriction::Cone { .. } => None,
        }
    }
}

/// The dense Jacobian (T129) with the frictional law's `S = dλ̂/du` (T158):
/// `J = blockdiag(Λ R_k⁻¹) − (I ⊗ Λ) S blockdiag(I − D R_k⁻¹)`, by matrix products: `S`
/// times the block-diagonal complement one coefficient's columns at a time (the real form
/// (T15) of `C_k = I − D R_k⁻¹` couples a harmonic's cosine and sine columns), then each
/// coefficient's rows times `Λ`.
pub(super) fn dense_jacobian(
    n: usize,
    harmonics: usize,
    matrices: &FrequencyMatrices,
    residual_scale: &[f64],
    law_jacobian: &[f64],
) -> Mat<f64> {
    use faer::linalg::matmul::matmul;
    use faer::{Accum, MatRef, Par};
    let ncoef = n_coefficients(harmonics);
    let size = n * ncoef;
    let s = MatRef::from_row_major_slice(law_jacobian, size, size);
    let real_form = |k: usize, map: Map| -> (Mat<f64>, Mat<f64>) {
        let m = matrices.matrix(map, k);
        (
            Mat::from_fn(n, n, |i, j| m[(i, j)].re),
            Mat::from_fn(n, n, |i, j| m[(i, j)].im),
        )
    };
    // S C: the column block of coefficient `col` gathers the blocks of its harmonic
    let mut sc = Mat::<f64>::zeros(size, size);
    for k in 0..=harmonics {
        let (re, im) = real_form(k, Map::Scaled);
        let c_re = Mat::<f64>::identity(n, n) - &re;
        if k == 0 {
            matmul(
                sc.as_mut().subcols_mut(0, n),
                Accum::Replace,
                s.subcols(0, n),
                &c_re,
                1.0,
                Par::Seq,
            );
            continue;
        }
        let (cc, ss) = (2 * k - 1, 2 * k);
        // the real form of C on (cos, sin): [[Re, Im], [−Im, Re]] acting on a column pair,
        // with Re C = I − Re(D R⁻¹) and Im C = −Im(D R⁻¹)
        let (s_cos, s_sin) = (s.subcols(cc * n, n), s.subcols(ss * n, n));
        let mut cos_cols = Mat::<f64>::zeros(size, n);
        matmul(
            cos_cols.as_mut(),
            Accum::Replace,
            s_cos,
            &c_re,
            1.0,
            Par::Seq,
        );
        matmul(cos_cols.as_mut(), Accum::Add, s_sin, &im, 1.0, Par::Seq);
        let mut sin_cols = Mat::<f64>::zeros(size, n);
        matmul(
            sin_cols.as_mut(),
            Accum::Replace,
            s_cos,
            &im,
            -1.0,
            Par::Seq,
        );
        matmul(sin_cols.as_mut(), Accum::Add, s_sin, &c_re, 1.0, Par::Seq);
        sc.as_mut().subcols_mut(cc * n, n).copy_from(&cos_cols);
        sc.as_mut().subcols_mut(ss * n, n).copy_from(&sin_cols);
    }
    // J = blockdiag(Λ R⁻¹) − (I ⊗ Λ) S C
    let scale = MatRef::from_row_major_slice(residual_scale, n, n);
    let mut jacobian = Mat::<f64>::zeros(size, size);
    for m in 0..ncoef {
        matmul(
            jacobian.as_mut().subrows_mut(m * n, n),
            Accum::Replace,
            scale,
            sc.as_ref().subrows(m * n, n),
            -1.0,
            Par::Seq,
        );
    }
    for k in 0..=harmonics {
        let (re, im) = real_form(k, Map::Residual);
        if k == 0 {
            let mut b = jacobian.as_mut().submatrix_mut(0, 0, n, n);
            b += &re;
            continue;
        }
        let (cc, ss) = (2 * k - 1, 2 * k);
        {
            let mut b = jacobian.as_mut().submatrix_mut(cc * n, cc * n, n, n);
            b += &re;
        }
        {
            let mut b = jacobian.as_mut().submatrix_mut(cc * n, ss * n, n, n);
            b += &im;
        }
        {
            let mut b = jacobian.as_mut().submatrix_mut(ss * n, cc * n, n, n);
            b -= &im;
        }
        {
            let mut b = jacobian.as_mut().submatrix_mut(ss * n, ss * n, n, n);
            b += &re;
        }
    }
    jacobian
}

impl RedistributedMsHbm {
    /// [`crate::problem::PeriodicProblem::solution`] with friction: the contact-node DOFs
    /// from the periodic frictional state of the evaluation (T152), the normal force and
    /// gap of every contact, and its friction force with its limit `μ λ_N`.
    pub(super) fn frictional_solution(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
        every_contact: bool,
    ) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        let (residual, forces, law) = {
            let e = self.evaluation(x, omega)?;
            let law = e.friction.clone().expect("a frictional evaluation");
            (e.residual.clone(), e.forces.clone(), law)
        };
        let n = self.n();
        let cone = matches!(self.friction, Some(Law::Cone(_)));
        let n_c = if cone { n / 3 } else { n / 2 };
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        let NodeHarmonics {
            q_rows,
            width,
            q_n,
            load,
        } = self.node_harmonics(&forces, location)?;
        let n_n = self.system.nonlinear_dofs.len();
        // the static displacement of the contact nodes under their load
        let zero_force = vec![0.0; n];
        let mut load_displacement = Vec::with_capacity(n_n * ncoef);
        for m in 0..ncoef {
            load_displacement.extend(
                self.contact
                    .displacement(&load[m * n_n..(m + 1) * n_n], &zero_force),
            );
        }
        let taus = self.sampling.taus.clone();
        let mut basis_buf = vec![0.0; ncoef];
        let contact = &self.contact;
        let mut cache: HashMap<u64, Vec<f64>> = HashMap::new();
        // the law's first failure at an instant (the cone re-integrates its slip flow)
        let failure: std::cell::RefCell<Option<Error>> = Default::default();
        let mut q_at = |i: usize, tau: f64| -> f64 {
            let key = tau.to_bits();
            if cache.len() >= MAX_CACHED_INSTANTS {
                cache.clear();
            }
            let lambda = cache.entry(key).or_insert_with(|| match law.force_at(tau) {
                Ok(lambda) => lambda,
                Err(e) => {
                    failure.borrow_mut().get_or_insert(e);
                    vec![f64::NAN; n]
                }
            });
            basis_into(h, tau, &mut basis_buf);
            let u: f64 = (0..ncoef)
                .map(|m| basis_buf[m] * load_displacement[m * n_n + i])
                .sum();
            u + contact.force_displacement_of(i, lambda)
        };
        let states: Vec<StateAt> = if every_contact || matches!(location, DofLocation::Nonlinear(_))
        {
            law.states_at(&taus)?
        } else {
            Vec::new()
        };
        let mut extremes = |i: usize| -> (Vec<f64>, f64, f64) {
            let samples: Vec<f64> = taus.iter().map(|&t| q_at(i, t)).collect();
            let mx = refine_extremum(&taus, &samples, 1.0, |t| q_at(i, t));
            let mn = refine_extremum(&taus, &samples, -1.0, |t| q_at(i, t));
            (samples, mx, mn)
        };
        let mut contacts = Vec::new();
        let mut frictions = Vec::new();
        let mu = self.friction.as_ref().map(Law::mu).unwrap_or_default();
        let extreme = |v: &[f64]| {
            (
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                v.iter().copied().fold(f64::INFINITY, f64::min),
            )
        };
        for c in (0..n_c).filter(|_| every_contact) {
            let i = self.partition.contact_n_index(&self.system, c);
            let (displacement, max, min) = extremes(i);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[self.system.contacts[c].w[0].0],
                coefficients: n_dof_coefficients(&q_n, n_n, h, i),
                displacement,
                gap: states.iter().map(|(_, y, _)| y[c]).collect(),
                force: states.iter().map(|(l, _, _)| l[c]).collect(),
                max,
                min,
            });
            let force: Vec<f64> = states.iter().map(|(l, _, _)| l[n_c + c]).collect();
            let (max, min) = extreme(&force);
            frictions.push(FrictionSeries {
                dof: self.system.model_dof[self.system.contacts[n_c + c].w[0].0],
                max,
                min,
                limit: states.iter().map(|(l, _, _)| mu[c] * l[c]).collect(),
                force,
                force2: if cone {
                    states.iter().map(|(l, _, _)| l[2 * n_c + c]).collect()
                } else {
                    Vec::new()
                },
                state: states.iter().map(|(_, _, s)| s[c]).collect(),
            });
        }
        let response = dof_response(
            location,
            response_dof,
            (&q_n, n_n),
            (&q_rows, width),
            &taus,
            |i| {
                let (_, max, min) = extremes(i);
                (max, min)
            },
        );
        if let Some(e) = failure.into_inner() {
            return Err(e);
        }
        let mut solution = self.solution_of(omega, &taus, &residual, contacts, frictions, response);
        solution.contact_node_harmonics = Some(q_n);
        solution.contact_dofs.truncate(n_c);
        solution.dissipated_energy = Some(law.dissipated_energy()?);
        solution.state_fractions = Some(law.state_fractions());
        Ok(solution)
    }
}
