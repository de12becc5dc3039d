//! The frictional contact problem of one step of the position-level scheme with Coulomb
//! friction on massless contact nodes (docs/theory.md §9, (T170)–(T174)).
//!
//! In the contact coordinates `y = [y_N; y_T]` (one normal row per contact, then one
//! tangential row per frictional contact) the end-of-step positions are affine in the
//! forces, `y = y_free + D λ` (T170), and each contact ends the step in one mode of the
//! incremental (backward-Euler) Coulomb law (T171) with the anchor `a_c = y_T,c` at the start
//! of the step:
//!
//! ```text
//! open:    λ_N = λ_T = 0,                 y_N ≥ 0
//! stick:   y_N = 0, y_T = a,              λ_N ≥ 0, |λ_T| ≤ μ λ_N
//! slip±:   y_N = 0, λ_T = ∓ μ λ_N,        λ_N ≥ 0, ±(y_T − a) ≥ 0
//! ```
//!
//! A contact without friction has no tangential row (open or closed), one with `μ = 0` is
//! closed in slip+ without the direction condition (`λ_T = 0`), as in (T151).
//!
//! [`CoulombContacts::solve`] (T173): the modes of the last solution are tried first (one
//! exact linear solve (T172) and the checks of (T171)); when a condition fails, projected
//! block Gauss–Seidel sweeps over the contacts (each contact's 2 × 2 problem solved exactly
//! by enumerating its modes, the others' forces fixed) find the modes, which are then
//! polished by the exact solve. The result satisfies every condition of (T171) to
//! round-off; `λ_N ≥ 0` and `|λ_T| ≤ μ λ_N` hold exactly (clamped).

use crate::dense::solve_small_lu_into;

/// The mode of one contact at the end of a step (T171).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    Open,
    /// Closed and stuck at the anchor (a frictionless contact: closed).
    Stick,
    /// Closed, sliding in `+t` (`λ_T = −μ λ_N`); with `μ = 0` every closed contact.
    SlipPlus,
    /// Closed, sliding in `−t` (`λ_T = +μ λ_N`).
    SlipMinus,
}

/// Relative size below which a condition of (T171) counts as met (round-off).
const TOLERANCE: f64 = 1e-10;
/// Gauss–Seidel sweeps before the problem is reported as not converged.
const MAX_SWEEPS: usize = 10_000;

/// The per-step problem `y = y_free + D λ` with the incremental Coulomb law (module docs).
pub(crate) struct CoulombContacts {
    nc: usize,
    /// Per contact: its tangential row (`≥ nc`) and `μ`; `None` without friction.
    tangent: Vec<Option<(usize, f64)>>,
    /// Rows: `nc` normals, then the tangents.
    m: usize,
    /// `D` (`m × m`, row-major).
    d: Vec<f64>,
    /// The modes of the last solution (the next start).
    modes: Vec<Mode>,
    lambda: Vec<f64>,
    y: Vec<f64>,
    // buffers of the exact solve
    unknowns: Vec<usize>,
    a: Vec<f64>,
    rhs: Vec<f64>,
    z: Vec<f64>,
    trial: Vec<f64>,
    /// The forces of the Gauss–Seidel sweeps.
    sweep: Vec<f64>,
}

impl CoulombContacts {
    /// `mu[c]`: the friction coefficient of contact `c`, `None` without friction; its
    /// tangential rows follow the normals in the order of the contacts. `d`: `D` of (T170).
    pub(crate) fn new(mu: &[Option<f64>], d: Vec<f64>) -> Self {
        let nc = mu.len();
        let mut next = nc;
        let tangent: Vec<Option<(usize, f64)>> = mu
            .iter()
            .map(|m| {
                m.map(|m| {
                    next += 1;
                    (next - 1, m)
                })
            })
            .collect();
        let m = next;
        debug_assert_eq!(d.len(), m * m);
        CoulombContacts {
            nc,
            tangent,
            m,
            d,
            modes: vec![Mode::Open; nc],
            lambda: vec![0.0; m],
            y: vec![0.0; m],
            unknowns: Vec::new(),
            a: Vec::new(),
            rhs: Vec::new(),
            z: Vec::new(),
            trial: vec![0.0; m],
            sweep: vec![0.0; m],
        }
    }

    /// The tangential row of contact `c` (`None` without friction).
    pub(crate) fn tangent_row(&self, c: usize) -> Option<usize> {
        self.tangent[c].map(|(r, _)| r)
    }

    /// The forces of the last solution (`m`: normals, then tangents).
    pub(crate) fn lambda(&self) -> &[f64] {
        &self.lambda
    }

    /// The contact coordinates of the last solution: closed gaps exactly 0, stuck tangents
    /// exactly at their anchors.
    pub(crate) fn y(&self) -> &[f64] {
        &self.y
    }

    fn dot_row(&self, r: usize, lambda: &[f64]) -> f64 {
        self.d[r * self.m..(r + 1) * self.m]
            .iter()
            .zip(lambda)
            .map(|(a, b)| a * b)
            .sum()
    }

    /// Solve the step's problem (T171) for the free coordinates `y_free` (`m`) and the
    /// anchors `anchor` (per contact, the tangential coordinate at the start of the step;
    /// read for frictional contacts only). On failure, a sentence saying why.
    pub(crate) fn solve(&mut self, y_free: &[f64], anchor: &[f64]) -> Result<(), String> {
        debug_assert_eq!(y_free.len(), self.m);
        let length = y_free
            .iter()
            .chain(
                (0..self.nc)
                    .filter(|&c| self.tangent[c].is_some())
                    .map(|c| &anchor[c]),
            )
            .fold(0.0f64, |s, v| s.max(v.abs()));
        // (a) the last step's modes
        let modes = self.modes.clone();
        if self.polish(&modes, y_free, anchor, length) {
            return Ok(());
        }
        // (b) block Gauss–Seidel from the last forces, then (c) the polish of its modes
        let mut lambda = std::mem::take(&mut self.sweep);
        lambda.copy_from_slice(&self.lambda);
        let mut modes = modes;
        let scale = (0..self.nc)
            .map(|c| (y_free[c] / self.d[c * self.m + c]).abs())
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut converged = false;
        for _ in 0..MAX_SWEEPS {
            let mut change = 0.0f64;
            for c in 0..self.nc {
                let (mode, ln, lt) = self.local(c, y_free, anchor, &lambda)?;
                modes[c] = mode;
                change = change.max((ln - lambda[c]).abs());
                lambda[c] = ln;
                if let Some(t) = self.tangent_row(c) {
                    change = change.max((lt - lambda[t]).abs());
                    lambda[t] = lt;
                }
            }
            if change <= 1e-14 * scale {
                converged = true;
                break;
            }
        }
        let polished = self.polish(&modes, y_free, anchor, length);
        if !polished {
            if !converged {
                self.sweep = lambda;
                return Err(format!(
                    "the frictional contact problem did not converge in {MAX_SWEEPS} sweeps"
                ));
            }
            // the sweeps' fixed point, exactly feasible
            for c in 0..self.nc {
                lambda[c] = lambda[c].max(0.0);
                if let Some((t, mu)) = self.tangent[c] {
                    lambda[t] = lambda[t].clamp(-mu * lambda[c], mu * lambda[c]);
                }
            }
            #[allow(clippy::needless_range_loop)] // `dot_row` borrows `self` beside `self.y`
            for r in 0..self.m {
                self.y[r] = y_free[r] + self.dot_row(r, &lambda);
            }
            self.lambda.copy_from_slice(&lambda);
            self.modes = modes;
        }
        self.sweep = lambda;
        Ok(())
    }

    /// Contact `c`'s own problem with the other forces fixed, solved exactly by its modes:
    /// `(mode, λ_N, λ_T)`.
    fn local(
        &self,
        c: usize,
        y_free: &[f64],
        anchor: &[f64],
        lambda: &[f64],
    ) -> Result<(Mode, f64, f64), String> {
        let m = self.m;
        let own = |r: usize, j: usize| self.d[r * m + j];
        let tangent = self.tangent[c];
        // the coordinates with this contact's forces removed
        let rest = |r: usize| {
            let mut v = y_free[r] + self.dot_row(r, lambda) - own(r, c) * lambda[c];
            if let Some((t, _)) = tangent {
                v -= own(r, t) * lambda[t];
            }
            v
        };
        let rn = rest(c);
        let Some((t, mu)) = tangent else {
            return Ok(if rn >= 0.0 {
                (Mode::Open, 0.0, 0.0)
            } else {
                (Mode::Stick, -rn / own(c, c), 0.0)
            });
        };
        if rn >= 0.0 {
            return Ok((Mode::Open, 0.0, 0.0));
        }
        let rt = rest(t) - anchor[c];
        let (dnn, dnt, dtn, dtt) = (own(c, c), own(c, t), own(t, c), own(t, t));
        if mu > 0.0 {
            let det = dnn * dtt - dnt * dtn;
            let ln = (-rn * dtt + rt * dnt) / det;
            let lt = (-rt * dnn + rn * dtn) / det;
            if ln >= 0.0 && lt.abs() <= mu * ln {
                return Ok((Mode::Stick, ln, lt));
            }
        }
        for (mode, s) in [(Mode::SlipPlus, 1.0), (Mode::SlipMinus, -1.0)] {
            let k = dnn - s * mu * dnt;
            if k <= 0.0 {
                continue;
            }
            let ln = -rn / k;
            let slide = rt + (dtn - s * mu * dtt) * ln;
            if mu == 0.0 || s * slide >= 0.0 {
                return Ok((mode, ln, -s * mu * ln));
            }
        }
        Err(format!(
            "contact {c} has no admissible mode in its step problem: the step's Delassus matrix couples its \
             normal and tangential compliances too strongly for mu = {mu} (docs/theory.md (T159))"
        ))
    }

    /// The exact solve (T172) of the modes `modes`; kept (forces, coordinates and modes
    /// stored) when it satisfies (T171) to round-off.
    fn polish(&mut self, modes: &[Mode], y_free: &[f64], anchor: &[f64], length: f64) -> bool {
        let (m, nc) = (self.m, self.nc);
        let mut unknowns = std::mem::take(&mut self.unknowns);
        let mut a = std::mem::take(&mut self.a);
        let mut rhs = std::mem::take(&mut self.rhs);
        let mut z = std::mem::take(&mut self.z);
        let mut lambda = std::mem::take(&mut self.trial);
        // unknowns: the normal rows of the closed contacts, the tangential rows of the stuck
        unknowns.clear();
        for (c, &mode) in modes.iter().enumerate() {
            if mode != Mode::Open {
                unknowns.push(c);
                if let (Mode::Stick, Some((t, mu))) = (mode, self.tangent[c]) {
                    if mu > 0.0 {
                        unknowns.push(t);
                    }
                }
            }
        }
        let nz = unknowns.len();
        // λ = E z: column k of E is the unit vector of its row, plus ∓μ on the tangent of a
        // slipping contact's normal
        let column = |j: usize| -> Option<(usize, f64)> {
            if j >= nc {
                return None;
            }
            match (modes[j], self.tangent[j]) {
                (Mode::SlipPlus, Some((t, mu))) => Some((t, -mu)),
                (Mode::SlipMinus, Some((t, mu))) => Some((t, mu)),
                _ => None,
            }
        };
        a.clear();
        a.resize(nz * nz, 0.0);
        rhs.clear();
        for (i, &r) in unknowns.iter().enumerate() {
            for (k, &j) in unknowns.iter().enumerate() {
                let mut v = self.d[r * m + j];
                if let Some((t, e)) = column(j) {
                    v += e * self.d[r * m + t];
                }
                a[i * nz + k] = v;
            }
            // y_N = 0 on a closed contact, y_T = a on a stuck one
            let target = if r < nc {
                0.0
            } else {
                let c = (0..nc)
                    .find(|&c| self.tangent_row(c) == Some(r))
                    .expect("a tangential row belongs to a contact");
                anchor[c]
            };
            rhs.push(target - y_free[r]);
        }
        let solved = solve_small_lu_into(&a, &rhs, 1e-14, &mut z).is_ok();
        let mut valid = false;
        if solved {
            lambda.iter_mut().for_each(|l| *l = 0.0);
            for (&j, &zk) in unknowns.iter().zip(&z) {
                lambda[j] += zk;
                if let Some((t, e)) = column(j) {
                    lambda[t] += e * zk;
                }
            }
            let force = lambda.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let (tol_f, tol_y) = (TOLERANCE * force, TOLERANCE * length);
            let y: Vec<f64> = (0..m)
                .map(|r| y_free[r] + self.dot_row(r, &lambda))
                .collect();
            valid = (0..nc).all(|c| {
                let ln = lambda[c];
                match (modes[c], self.tangent[c]) {
                    (Mode::Open, _) => y[c] >= -tol_y,
                    (_, None) => ln >= -tol_f,
                    (Mode::Stick, Some((t, mu))) => {
                        ln >= -tol_f && lambda[t].abs() <= mu * ln.max(0.0) + tol_f
                    }
                    (mode, Some((t, mu))) => {
                        let s = if mode == Mode::SlipPlus { 1.0 } else { -1.0 };
                        ln >= -tol_f && (mu == 0.0 || s * (y[t] - anchor[c]) >= -tol_y)
                    }
                }
            });
            if valid {
                self.lambda.copy_from_slice(&lambda);
                self.y.copy_from_slice(&y);
                for c in 0..nc {
                    self.lambda[c] = self.lambda[c].max(0.0);
                    if modes[c] != Mode::Open {
                        self.y[c] = 0.0;
                    }
                    if let Some((t, mu)) = self.tangent[c] {
                        let b = mu * self.lambda[c];
                        self.lambda[t] = self.lambda[t].clamp(-b, b);
                        if modes[c] == Mode::Stick && mu > 0.0 {
                            self.y[t] = anchor[c];
                        }
                    }
                }
                self.modes.copy_from_slice(modes);
            }
        }
        self.unknowns = unknowns;
        self.a = a;
        self.rhs = rhs;
        self.z = z;
        self.trial = lambda;
        valid
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One contact with `D = diag(1/k_N, 1/k_T)`: the Jenkins element's step (T160 (i)).
    #[test]
    fn one_contact_sticks_slips_and_opens_as_its_closed_form() {
        let (kn, kt, mu) = (4.0, 2.0, 0.5);
        let mut p = CoulombContacts::new(&[Some(mu)], vec![1.0 / kn, 0.0, 0.0, 1.0 / kt]);
        // pressed by 2 (λ_N = 2, limit 1); a tangential pull of 0.8 < 1 sticks
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-14);
        p.solve(&[-2.0 / kn, 0.8 / kt], &[0.0]).unwrap();
        assert!(close(p.lambda(), &[2.0, -0.8]), "{:?}", p.lambda());
        assert_eq!(p.y(), &[0.0, 0.0]);
        // a pull of 3 > 1 slips forward: λ_T = −1, y_T = (3 − 1)/k_T
        p.solve(&[-2.0 / kn, 3.0 / kt], &[0.0]).unwrap();
        assert!(close(p.lambda(), &[2.0, -1.0]), "{:?}", p.lambda());
        assert!(close(p.y(), &[0.0, 2.0 / kt]), "{:?}", p.y());
        // and backward from an anchor ahead
        p.solve(&[-2.0 / kn, 0.0], &[5.0]).unwrap();
        assert!(close(p.lambda(), &[2.0, 1.0]), "{:?}", p.lambda());
        assert!(close(p.y(), &[0.0, 1.0 / kt]), "{:?}", p.y());
        // lifted off: no force
        p.solve(&[0.1, 3.0], &[0.0]).unwrap();
        assert_eq!(p.lambda(), &[0.0, 0.0]);
    }

    #[test]
    fn coupled_contacts_satisfy_the_law() {
        // two contacts with a full, symmetric positive definite D (normal–tangent coupled)
        let d = vec![
            1.0, 0.3, 0.1, 0.05, //
            0.3, 1.2, -0.05, 0.1, //
            0.1, -0.05, 0.8, 0.2, //
            0.05, 0.1, 0.2, 0.9,
        ];
        let mu = 0.3;
        let mut p = CoulombContacts::new(&[Some(mu), Some(mu)], d.clone());
        for (yf, a) in [
            ([-1.0, -0.5, 0.4, -0.2], [0.0, 0.0]),
            ([-1.0, 0.2, 2.0, -0.2], [0.0, 0.0]),
            ([-1.0, -0.5, 0.0, 0.0], [1.0, -1.0]),
            ([-0.1, -2.0, 3.0, 0.0], [0.0, 0.0]),
        ] {
            p.solve(&yf, &a).unwrap();
            let l = p.lambda().to_vec();
            for c in 0..2 {
                let t = 2 + c;
                let y: Vec<f64> = (0..4)
                    .map(|r| yf[r] + (0..4).map(|j| d[r * 4 + j] * l[j]).sum::<f64>())
                    .collect();
                assert!(l[c] >= 0.0 && y[c] >= -1e-12 && (l[c] * y[c]).abs() < 1e-12);
                assert!(l[t].abs() <= mu * l[c]);
                let slide = y[t] - a[c];
                if l[c] > 0.0 && l[t].abs() < mu * l[c] * (1.0 - 1e-9) {
                    assert!(slide.abs() < 1e-12, "stuck contact {c} moved by {slide}");
                }
                if slide.abs() > 1e-12 {
                    assert!((l[t] + mu * l[c] * slide.signum()).abs() < 1e-12);
                }
            }
        }
    }
}
