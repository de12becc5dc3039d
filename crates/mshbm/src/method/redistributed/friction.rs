//! Coulomb friction on massless contact nodes, in contact coordinates (docs/theory.md §20,
//! (T150)–(T160)): the rate-independent law that maps the free-gap signal `γ(τ)` of one
//! period to the periodic contact forces `λ(τ)`, their exact Fourier coefficients `λ̂` and
//! the derivative `∂λ̂/∂γ̂`.
//!
//! Each contact has a normal and one tangential coordinate (plane problems), ordered
//! `[normals; tangents]`, and is open, stuck at an anchor (its tangential displacement when
//! it stuck), or slipping in one direction ([`Mode`]). For a fixed mode of every contact
//! the forces are affine in the free gap and the anchors (T152), so between the instants
//! where a mode changes the forces are trigonometric polynomials and the Fourier integrals
//! are exact Gram blocks, as for frictionless contact (§6). The instants are the first
//! roots of the mode's validity indicators (T153), located cell by cell with the scan of
//! the frictionless quadrature; a contact that sticks takes its tangential displacement of
//! that instant as its anchor (T154). The state at `τ = 0` is found as the fixed point of
//! one period's march (T156), with the convention (T157) for contacts that stay stuck all
//! period. The derivative follows the anchors' sensitivities through the period (T155) and
//! the fixed point (T158); the interval ends drop out because `λ` is continuous in time.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;
use std::f64::consts::PI;

use faer::Mat;

use super::quadrature::{derivative_into, CellScan};
use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::dense::solve_small_lu_columns;
use crate::error::{Error, Result};
use crate::harmonic::{add_interval_gram, basis_derivative, basis_into, n_coefficients};

/// The state of one contact (docs/theory.md (T151)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Gap open, no force.
    Open,
    /// Closed, the tangential displacement held at the contact's anchor.
    Stick,
    /// Closed, slipping with a positive tangential velocity: `λ_T = −μ λ_N`. A contact
    /// without friction (`μ = 0`) is closed in this mode, with no velocity condition.
    SlipPositive,
    /// Closed, slipping with a negative tangential velocity: `λ_T = +μ λ_N`.
    SlipNegative,
}

/// What an indicator of a mode measures; its first root ends the mode (T153).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// The gap of an open contact.
    Gap,
    /// The normal force of a closed contact.
    Normal,
    /// `μ λ_N − λ_T` of a stuck contact (its root starts a negative slip).
    ConeUpper,
    /// `μ λ_N + λ_T` of a stuck contact (its root starts a positive slip).
    ConeLower,
    /// `± ẏ_T` of a slipping contact (its root sticks it).
    Velocity,
}

struct Indicator {
    contact: usize,
    kind: Kind,
    /// `h = κᵀ γ(τ) + θᵀ a`, or `κᵀ γ̇(τ)` for a velocity.
    kappa: Vec<f64>,
    theta: Vec<f64>,
}

/// The affine solution of one set of modes (T152): `λ = F γ + G a`, `y = Y_F γ + Y_G a`.
struct ModeData {
    /// `m × m`, `m × n`, `m × m`, `m × n`, row-major.
    f: Vec<f64>,
    g: Vec<f64>,
    yf: Vec<f64>,
    yg: Vec<f64>,
    indicators: Vec<Indicator>,
}

/// One interval of constant modes and anchors.
#[derive(Clone, Debug)]
pub struct Phase {
    pub start: f64,
    pub end: f64,
    pub modes: Vec<Mode>,
    /// Anchors of every contact (meaningful for the stuck ones).
    pub anchors: Vec<f64>,
    /// Their sensitivities to `[γ̂, a₀]` (`n × (2n(2H+1) + n)`).
    d_anchors: Vec<f64>,
    data: usize,
}

/// Contacts with Coulomb friction on massless nodes: the Delassus matrix of the normal and
/// tangential contact coordinates and the friction coefficients.
#[derive(Clone, Debug)]
pub struct FrictionalContacts {
    n: usize,
    /// `2n × 2n`, row-major, coordinates `[normals; tangents]` (T150).
    delassus: Vec<f64>,
    mu: Vec<f64>,
}

/// The periodic contact forces of a free-gap signal (T156).
#[derive(Clone, Debug)]
pub struct PeriodicContact {
    pub harmonics: usize,
    /// `λ̂`, harmonic-major, `2n` per coefficient.
    pub forces: Vec<f64>,
    /// `dλ̂/dγ̂` (square, `2n(2H+1)`, row-major), the fixed point's dependence included.
    pub jacobian: Vec<f64>,
    /// The period cut at the mode changes, in order.
    pub phases: Vec<Phase>,
    /// Marches of one period the fixed point needed.
    pub passes: usize,
    gamma: Vec<f64>,
    /// `(F, G, Y_F, Y_G)` of each set of modes met (T152).
    data: Vec<[Vec<f64>; 4]>,
}

/// Relative tolerance of the indicators (T153).
const INDICATOR_TOLERANCE: f64 = 1e-11;

/// Passes of one period before the fixed point of the state at `τ = 0` is given up.
const MAX_PASSES: usize = 50;

impl FrictionalContacts {
    /// `delassus` is `2n × 2n` row-major in the coordinates `[normals; tangents]`, `mu` the
    /// `n` friction coefficients (finite, non-negative).
    pub fn new(delassus: Vec<f64>, mu: Vec<f64>) -> Result<Self> {
        let n = mu.len();
        if delassus.len() != 4 * n * n {
            return Err(Error::Numerical(format!(
                "friction: the Delassus matrix has {} entries, 4n² = {} expected for {n} contacts",
                delassus.len(),
                4 * n * n
            )));
        }
        if let Some(c) = mu.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(Error::Numerical(format!(
                "friction: the friction coefficient of contact {c} is {} (finite and ≥ 0 expected)",
                mu[c]
            )));
        }
        Ok(FrictionalContacts { n, delassus, mu })
    }

    pub fn contacts(&self) -> usize {
        self.n
    }

    /// The friction coefficients.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    fn d(&self, i: usize, j: usize) -> f64 {
        self.delassus[i * 2 * self.n + j]
    }

    /// The affine solution and the indicators of one set of modes (T152), (T153).
    fn mode_data(&self, modes: &[Mode]) -> Result<ModeData> {
        let (n, m) = (self.n, 2 * self.n);
        let closed: Vec<usize> = (0..n).filter(|&c| modes[c] != Mode::Open).collect();
        let stuck: Vec<usize> = (0..n).filter(|&c| modes[c] == Mode::Stick).collect();
        let nz = closed.len() + stuck.len();
        // λ = E z, z = [λ_N of the closed; λ_T of the stuck]
        let mut e = vec![0.0; m * nz];
        for (k, &c) in closed.iter().enumerate() {
            e[c * nz + k] = 1.0;
            match modes[c] {
                Mode::SlipPositive => e[(n + c) * nz + k] = -self.mu[c],
                Mode::SlipNegative => e[(n + c) * nz + k] = self.mu[c],
                _ => {}
            }
        }
        for (j, &c) in stuck.iter().enumerate() {
            e[(n + c) * nz + closed.len() + j] = 1.0;
        }
        let rows: Vec<usize> = closed
            .iter()
            .copied()
            .chain(stuck.iter().map(|&c| n + c))
            .collect();
        let mut k_mat = vec![0.0; nz * nz];
        for (i, &row) in rows.iter().enumerate() {
            for k in 0..nz {
                k_mat[i * nz + k] = (0..m).map(|r| self.d(row, r) * e[r * nz + k]).sum();
            }
        }
        // right-hand sides: −Sᵀ γ (columns 0..m) and R a (columns m..m+n)
        let rhs = Mat::<f64>::from_fn(nz, m + n, |i, col| {
            if col < m {
                if rows[i] == col {
                    -1.0
                } else {
                    0.0
                }
            } else if i >= closed.len() && stuck[i - closed.len()] == col - m {
                1.0
            } else {
                0.0
            }
        });
        let x = if nz == 0 {
            Mat::zeros(0, m + n)
        } else {
            solve_small_lu_columns(&k_mat, rhs.as_ref(), 1e-13).map_err(|_| {
                Error::Singular(format!(
                    "friction: the contact problem of the modes {modes:?} is singular (the friction coefficient is too large for the coupling of the normal and tangential compliances, docs/theory.md (T159))"
                ))
            })?
        };
        let mut f = vec![0.0; m * m];
        let mut g = vec![0.0; m * n];
        for i in 0..m {
            for k in 0..nz {
                let eik = e[i * nz + k];
                if eik == 0.0 {
                    continue;
                }
                for r in 0..m {
                    f[i * m + r] += eik * x[(k, r)];
                }
                for c in 0..n {
                    g[i * n + c] += eik * x[(k, m + c)];
                }
            }
        }
        let mut yf = vec![0.0; m * m];
        let mut yg = vec![0.0; m * n];
        for i in 0..m {
            yf[i * m + i] = 1.0;
            for k in 0..m {
                let dik = self.d(i, k);
                if dik == 0.0 {
                    continue;
                }
                for r in 0..m {
                    yf[i * m + r] += dik * f[k * m + r];
                }
                for c in 0..n {
                    yg[i * n + c] += dik * g[k * n + c];
                }
            }
        }
        let row = |a: &[f64], i: usize, w: usize| a[i * w..(i + 1) * w].to_vec();
        let combine = |a: &[f64], b: &[f64], sb: f64| -> Vec<f64> {
            a.iter().zip(b).map(|(x, y)| x + sb * y).collect()
        };
        let mut indicators = Vec::new();
        for c in 0..n {
            let mu = self.mu[c];
            match modes[c] {
                Mode::Open => indicators.push(Indicator {
                    contact: c,
                    kind: Kind::Gap,
                    kappa: row(&yf, c, m),
                    theta: row(&yg, c, n),
                }),
                closed_mode => {
                    indicators.push(Indicator {
                        contact: c,
                        kind: Kind::Normal,
                        kappa: row(&f, c, m),
                        theta: row(&g, c, n),
                    });
                    match closed_mode {
                        Mode::Stick => {
                            let (fn_, ft) = (row(&f, c, m), row(&f, n + c, m));
                            let (gn, gt) = (row(&g, c, n), row(&g, n + c, n));
                            let scaled = |v: &[f64]| v.iter().map(|x| mu * x).collect::<Vec<_>>();
                            indicators.push(Indicator {
                                contact: c,
                                kind: Kind::ConeUpper,
                                kappa: combine(&scaled(&fn_), &ft, -1.0),
                                theta: combine(&scaled(&gn), &gt, -1.0),
                            });
                            indicators.push(Indicator {
                                contact: c,
                                kind: Kind::ConeLower,
                                kappa: combine(&scaled(&fn_), &ft, 1.0),
                                theta: combine(&scaled(&gn), &gt, 1.0),
                            });
                        }
                        slip if mu > 0.0 => {
                            let sign = if slip == Mode::SlipPositive {
                                1.0
                            } else {
                                -1.0
                            };
                            indicators.push(Indicator {
                                contact: c,
                                kind: Kind::Velocity,
                                kappa: row(&yf, n + c, m).iter().map(|v| sign * v).collect(),
                                theta: vec![0.0; n],
                            });
                        }
                        _ => {}
                    }
                }
            }
        }
        Ok(ModeData {
            f,
            g,
            yf,
            yg,
            indicators,
        })
    }

    /// The state at `τ = 0` without friction forces: the normal LCP on `D_NN`, closed
    /// contacts stuck where they are (T156).
    fn initial_state(&self, gamma0: &[f64]) -> Result<(Vec<Mode>, Vec<f64>)> {
        let n = self.n;
        let dnn: Vec<f64> = (0..n * n).map(|k| self.d(k / n, k % n)).collect();
        let solution = LcpSolver::new(LcpMatrix::new(n, dnn))
            .solve(&gamma0[..n])
            .map_err(|e| Error::Numerical(format!("friction: initial state: {e}")))?;
        let modes = (0..n)
            .map(|c| match (solution.active[c], self.mu[c] > 0.0) {
                (false, _) => Mode::Open,
                (true, true) => Mode::Stick,
                (true, false) => Mode::SlipPositive,
            })
            .collect();
        let anchors = (0..n)
            .map(|c| {
                gamma0[n + c]
                    + (0..n)
                        .map(|k| self.d(n + c, k) * solution.lambda[k])
                        .sum::<f64>()
            })
            .collect();
        Ok((modes, anchors))
    }

    /// The periodic contact forces for the free gap with coefficients `gamma` (harmonic-major,
    /// `2n` per coefficient, `harmonics` harmonics), with switching times located on a grid
    /// of `cells` cells (T153), and their derivative (T155), (T158).
    pub fn periodic(
        &self,
        harmonics: usize,
        gamma: &[f64],
        cells: usize,
    ) -> Result<PeriodicContact> {
        let (n, m) = (self.n, 2 * self.n);
        let ncoef = n_coefficients(harmonics);
        if gamma.len() != m * ncoef {
            return Err(Error::Numerical(format!(
                "friction: {} free-gap coefficients, {} expected",
                gamma.len(),
                m * ncoef
            )));
        }
        if gamma.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "friction: the free gap is not finite".into(),
            ));
        }
        let mut gamma0 = vec![0.0; m];
        let b0 = {
            let mut b = vec![0.0; ncoef];
            basis_into(harmonics, 0.0, &mut b);
            b
        };
        for k in 0..ncoef {
            for r in 0..m {
                gamma0[r] += b0[k] * gamma[k * m + r];
            }
        }
        let (mut modes0, mut anchors0) = self.initial_state(&gamma0)?;
        let scale = gamma
            .iter()
            .fold(0.0f64, |s, v| s.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let mut march = March::new(self, harmonics, gamma, cells.max(1));
        for pass in 1..=MAX_PASSES {
            let out = march.run(&modes0, &anchors0)?;
            if out.modes_end != modes0 {
                modes0 = out.modes_end.clone();
                anchors0 = out.anchors_end.clone();
                continue;
            }
            // (T156)–(T158): residual of the stuck contacts' anchors at τ = 0
            let nu = m * ncoef;
            let nv = nu + n;
            let stuck: Vec<usize> = (0..n).filter(|&c| modes0[c] == Mode::Stick).collect();
            let ns = stuck.len();
            let mut residual = vec![0.0; ns];
            let mut j_a = vec![0.0; ns * ns];
            let mut r_u = Mat::<f64>::zeros(ns, nu);
            for (i, &c) in stuck.iter().enumerate() {
                if out.released[c] {
                    residual[i] = anchors0[c] - out.anchors_end[c];
                    for (l, &c2) in stuck.iter().enumerate() {
                        j_a[i * ns + l] =
                            f64::from(u8::from(i == l)) - out.d_anchors_end[c * nv + nu + c2];
                    }
                    for col in 0..nu {
                        r_u[(i, col)] = -out.d_anchors_end[c * nv + col];
                    }
                } else {
                    // (T157): a contact stuck all period is centred in its cone
                    let (value, row) = march.centring(&out.phases, c);
                    residual[i] = value;
                    for (l, &c2) in stuck.iter().enumerate() {
                        j_a[i * ns + l] = row[nu + c2];
                    }
                    for col in 0..nu {
                        r_u[(i, col)] = row[col];
                    }
                }
            }
            let mut rhs = Mat::<f64>::zeros(ns, nu + 1);
            for i in 0..ns {
                rhs[(i, 0)] = residual[i];
                for col in 0..nu {
                    rhs[(i, col + 1)] = r_u[(i, col)];
                }
            }
            let solved = if ns == 0 {
                Mat::zeros(0, nu + 1)
            } else {
                solve_small_lu_columns(&j_a, rhs.as_ref(), 1e-13).map_err(|_| {
                    Error::Singular(
                        "friction: the periodicity of the stuck contacts' anchors is singular"
                            .into(),
                    )
                })?
            };
            let step = (0..ns).fold(0.0f64, |s, i| s.max(solved[(i, 0)].abs()));
            let size = anchors0.iter().fold(scale, |s, a| s.max(a.abs()));
            if step <= 1e-12 * size || pass == MAX_PASSES {
                if step > 1e-12 * size {
                    return Err(Error::Numerical(format!(
                        "friction: no periodic contact state after {MAX_PASSES} periods (anchor change {step:e})"
                    )));
                }
                // (T158): dλ̂/dγ̂ = ∂λ̂/∂γ̂ − ∂λ̂/∂a₀ J_a⁻¹ ∂r/∂γ̂
                let mut jacobian = vec![0.0; nu * nu];
                for row in 0..nu {
                    for col in 0..nu {
                        let mut v = out.d_forces[row * nv + col];
                        for (l, &c2) in stuck.iter().enumerate() {
                            v -= out.d_forces[row * nv + nu + c2] * solved[(l, col + 1)];
                        }
                        jacobian[row * nu + col] = v;
                    }
                }
                return Ok(PeriodicContact {
                    harmonics,
                    forces: out.forces,
                    jacobian,
                    phases: out.phases,
                    passes: pass,
                    gamma: gamma.to_vec(),
                    data: march
                        .data
                        .iter()
                        .map(|d| [d.f.clone(), d.g.clone(), d.yf.clone(), d.yg.clone()])
                        .collect(),
                });
            }
            for (i, &c) in stuck.iter().enumerate() {
                anchors0[c] -= solved[(i, 0)];
            }
        }
        Err(Error::Numerical(format!(
            "friction: the contact modes at τ = 0 did not repeat within {MAX_PASSES} periods"
        )))
    }
}

/// One period's march and its results.
struct Marched {
    modes_end: Vec<Mode>,
    anchors_end: Vec<f64>,
    /// `n × (2n(2H+1) + n)`: anchors at the end against `[γ̂, a₀]`.
    d_anchors_end: Vec<f64>,
    /// Contacts whose anchor was set during the period.
    released: Vec<bool>,
    forces: Vec<f64>,
    /// `2n(2H+1) × (2n(2H+1) + n)`.
    d_forces: Vec<f64>,
    phases: Vec<Phase>,
}

struct March<'a> {
    contacts: &'a FrictionalContacts,
    harmonics: usize,
    gamma: &'a [f64],
    cells: usize,
    data: Vec<ModeData>,
    index: HashMap<Vec<Mode>, usize>,
}

impl<'a> March<'a> {
    fn new(
        contacts: &'a FrictionalContacts,
        harmonics: usize,
        gamma: &'a [f64],
        cells: usize,
    ) -> Self {
        March {
            contacts,
            harmonics,
            gamma,
            cells,
            data: Vec::new(),
            index: HashMap::new(),
        }
    }

    fn data_of(&mut self, modes: &[Mode]) -> Result<usize> {
        if let Some(&i) = self.index.get(modes) {
            return Ok(i);
        }
        let d = self.contacts.mode_data(modes)?;
        self.data.push(d);
        self.index.insert(modes.to_vec(), self.data.len() - 1);
        Ok(self.data.len() - 1)
    }

    /// `Σ_r κ_r γ_r(τ)` and its slope.
    fn combination_at(&self, kappa: &[f64], tau: f64) -> (f64, f64, Vec<f64>) {
        let m = kappa.len();
        let ncoef = n_coefficients(self.harmonics);
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let db = basis_derivative(self.harmonics, tau);
        let (mut v, mut s) = (0.0, 0.0);
        for k in 0..ncoef {
            let ck: f64 = (0..m).map(|r| kappa[r] * self.gamma[k * m + r]).sum();
            v += ck * b[k];
            s += ck * db[k];
        }
        (v, s, b)
    }

    /// The indicators' coefficient rows for the modes `data` and anchors `a`.
    fn indicator_coefficients(
        &self,
        data: usize,
        a: &[f64],
        out: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
    ) {
        let ncoef = n_coefficients(self.harmonics);
        let m = 2 * self.contacts.n;
        out.clear();
        let mut row = vec![0.0; ncoef];
        for ind in &self.data[data].indicators {
            for (k, r) in row.iter_mut().enumerate() {
                *r = (0..m).map(|i| ind.kappa[i] * self.gamma[k * m + i]).sum();
            }
            let start = out.len();
            if ind.kind == Kind::Velocity {
                derivative_into(&row, scratch);
                out.extend_from_slice(scratch);
            } else {
                row[0] += ind.theta.iter().zip(a).map(|(t, x)| t * x).sum::<f64>();
                out.extend_from_slice(&row);
            }
            // (T153): an indicator ends its mode where it falls below −ε of its size, so that
            // a contact resting at zero gap and zero force (or a slip at zero velocity) is
            // not flipped back and forth by round-off
            let size: f64 = out[start..].iter().map(|v| v.abs()).sum();
            out[start] += INDICATOR_TOLERANCE * size;
        }
    }

    /// Add the phase `[a, b]` of modes `data` with anchors `anchors` (sensitivities
    /// `d_anchors`) to the forces and their derivative (T155).
    #[allow(clippy::too_many_arguments)]
    fn add_phase(
        &self,
        data: usize,
        a: f64,
        b: f64,
        anchors: &[f64],
        d_anchors: &[f64],
        forces: &mut [f64],
        d_forces: &mut [f64],
        gram: &mut Vec<f64>,
    ) {
        let (n, m) = (self.contacts.n, 2 * self.contacts.n);
        let ncoef = n_coefficients(self.harmonics);
        let nv = m * ncoef + n;
        gram.clear();
        gram.resize(ncoef * ncoef, 0.0);
        add_interval_gram(self.harmonics, a, b, gram);
        let d = &self.data[data];
        // F γ_c per coefficient c, G a
        let mut fg = vec![0.0; ncoef * m];
        for c in 0..ncoef {
            for i in 0..m {
                fg[c * m + i] = (0..m).map(|r| d.f[i * m + r] * self.gamma[c * m + r]).sum();
            }
        }
        let ga: Vec<f64> = (0..m)
            .map(|i| (0..n).map(|c| d.g[i * n + c] * anchors[c]).sum())
            .collect();
        // G ∂a/∂[γ̂, a₀]
        let mut gda = vec![0.0; m * nv];
        for i in 0..m {
            for c in 0..n {
                let gic = d.g[i * n + c];
                if gic == 0.0 {
                    continue;
                }
                for col in 0..nv {
                    gda[i * nv + col] += gic * d_anchors[c * nv + col];
                }
            }
        }
        for mc in 0..ncoef {
            for i in 0..m {
                let row = mc * m + i;
                let mut v = gram[mc * ncoef] * ga[i];
                for c in 0..ncoef {
                    let w = gram[mc * ncoef + c];
                    if w == 0.0 {
                        continue;
                    }
                    v += w * fg[c * m + i];
                    for r in 0..m {
                        d_forces[row * nv + c * m + r] += w * d.f[i * m + r];
                    }
                }
                forces[row] += v;
                let w0 = gram[mc * ncoef];
                if w0 != 0.0 {
                    for col in 0..nv {
                        d_forces[row * nv + col] += w0 * gda[i * nv + col];
                    }
                }
            }
        }
    }

    /// March one period from the modes and anchors at `τ = 0` (T153)–(T155).
    fn run(&mut self, modes0: &[Mode], anchors0: &[f64]) -> Result<Marched> {
        let n = self.contacts.n;
        let m = 2 * n;
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        let nu = m * ncoef;
        let nv = nu + n;
        let mut modes = modes0.to_vec();
        let mut anchors = anchors0.to_vec();
        let mut d_anchors = vec![0.0; n * nv];
        for c in 0..n {
            if modes[c] == Mode::Stick {
                d_anchors[c * nv + nu + c] = 1.0;
            }
        }
        let mut released = vec![false; n];
        let mut forces = vec![0.0; nu];
        let mut d_forces = vec![0.0; nu * nv];
        let mut phases = Vec::new();
        let mut scan = CellScan::new(h);
        let (mut coefs, mut scratch, mut gram) = (Vec::new(), Vec::new(), Vec::new());
        let mut current = self.data_of(&modes)?;
        let mut phase_start = 0.0;
        let mut tau = 0.0;
        let (mut flips_here, mut last_flip) = (0usize, f64::NAN);
        let mut cascade: Option<Cascade> = None;
        // the (contact, mode) pairs left at the current instant
        let mut left: Vec<(usize, Mode)> = Vec::new();
        let mut stale = true;
        for cell in 0..self.cells {
            let end = 2.0 * PI * (cell + 1) as f64 / self.cells as f64;
            loop {
                if tau >= end {
                    break;
                }
                // the indicators change only with the modes and anchors, i.e. at a flip
                if stale {
                    self.indicator_coefficients(current, &anchors, &mut coefs, &mut scratch);
                    stale = false;
                }
                if coefs.is_empty() {
                    break;
                }
                scan.fill(&coefs, tau, end);
                let Some((t, which)) = scan.earliest_root(&coefs, ncoef) else {
                    break;
                };
                if t - last_flip <= 1e-13 * 2.0 * PI {
                    flips_here += 1;
                    if flips_here > 4 * n + 8 {
                        return Err(Error::Numerical(format!(
                            "friction: the contact modes cycle at τ = {t} (modes {modes:?})"
                        )));
                    }
                } else {
                    flips_here = 0;
                    left.clear();
                    cascade = Some(Cascade {
                        tau: t,
                        data: current,
                        indicator: which,
                        anchors: anchors.clone(),
                        d_anchors: d_anchors.clone(),
                    });
                }
                last_flip = t;
                stale = true;
                self.add_phase(
                    current,
                    phase_start,
                    t,
                    &anchors,
                    &d_anchors,
                    &mut forces,
                    &mut d_forces,
                    &mut gram,
                );
                phases.push(Phase {
                    start: phase_start,
                    end: t,
                    modes: modes.clone(),
                    anchors: anchors.clone(),
                    d_anchors: d_anchors.clone(),
                    data: current,
                });
                let (contact, kind) = {
                    let ind = &self.data[current].indicators[which];
                    (ind.contact, ind.kind)
                };
                let mu = self.contacts.mu[contact];
                let next = match kind {
                    Kind::Gap if mu > 0.0 => Mode::Stick,
                    Kind::Gap => Mode::SlipPositive,
                    Kind::Normal => Mode::Open,
                    Kind::ConeUpper => Mode::SlipNegative,
                    Kind::ConeLower => Mode::SlipPositive,
                    Kind::Velocity => Mode::Stick,
                };
                let cascade = cascade
                    .as_ref()
                    .expect("a cascade starts at every new instant");
                if modes[contact] == Mode::Stick {
                    released[contact] = true;
                }
                left.push((contact, modes[contact]));
                if left.contains(&(contact, next)) {
                    // a flip that undoes one at this instant: the indicators' signs there
                    // are round-off (a grazing contact); the mode is the one valid a little
                    // after the instant (T153)
                    let probe = t + 1e-3 * (2.0 * PI / self.cells as f64);
                    let chosen =
                        self.mode_after(cascade, contact, t, probe, &modes, &anchors, &d_anchors)?;
                    modes[contact] = chosen.0;
                    anchors = chosen.1;
                    d_anchors = chosen.2;
                    current = self.data_of(&modes)?;
                    phase_start = t;
                    tau = probe;
                    continue;
                }
                if next == Mode::Stick {
                    // (T154): the anchor is the tangential displacement at the instant
                    self.stick(cascade, contact, t, &mut anchors, &mut d_anchors);
                }
                modes[contact] = next;
                current = self.data_of(&modes)?;
                phase_start = t;
                tau = t;
            }
            tau = tau.max(end);
        }
        self.add_phase(
            current,
            phase_start,
            2.0 * PI,
            &anchors,
            &d_anchors,
            &mut forces,
            &mut d_forces,
            &mut gram,
        );
        phases.push(Phase {
            start: phase_start,
            end: 2.0 * PI,
            modes: modes.clone(),
            anchors: anchors.clone(),
            d_anchors: d_anchors.clone(),
            data: current,
        });
        // a contact that stuck during the period has a new anchor even if it was stuck at 0
        Ok(Marched {
            modes_end: modes,
            anchors_end: anchors,
            d_anchors_end: d_anchors,
            released,
            forces,
            d_forces,
            phases,
        })
    }

    /// `h(τ) = (e_T,c + s μ_c e_N,c)ᵀ λ(τ)` in `phase`, and its sensitivity to `[γ̂, a₀]` at
    /// fixed `τ` when `row` is given.
    fn cone_side(&self, phase: &Phase, c: usize, s: f64, tau: f64, row: Option<&mut [f64]>) -> f64 {
        let (n, m) = (self.contacts.n, 2 * self.contacts.n);
        let ncoef = n_coefficients(self.harmonics);
        let nu = m * ncoef;
        let nv = nu + n;
        let d = &self.data[phase.data];
        let mu = self.contacts.mu[c];
        let kappa: Vec<f64> = (0..m)
            .map(|r| d.f[(n + c) * m + r] + s * mu * d.f[c * m + r])
            .collect();
        let theta: Vec<f64> = (0..n)
            .map(|k| d.g[(n + c) * n + k] + s * mu * d.g[c * n + k])
            .collect();
        let (value, _, b) = self.combination_at(&kappa, tau);
        if let Some(row) = row {
            for k in 0..ncoef {
                for r in 0..m {
                    row[k * m + r] += b[k] * kappa[r];
                }
            }
            for (k, &t) in theta.iter().enumerate() {
                if t != 0.0 {
                    for col in 0..nv {
                        row[col] += t * phase.d_anchors[k * nv + col];
                    }
                }
            }
        }
        value
            + theta
                .iter()
                .zip(&phase.anchors)
                .map(|(t, a)| t * a)
                .sum::<f64>()
    }

    /// The largest of `sign · h` over the period (`h` of [`March::cone_side`]): the phase and
    /// the instant, by 8 points per phase refined by golden-section search.
    fn extreme(&self, phases: &[Phase], c: usize, s: f64, sign: f64) -> (usize, f64) {
        let mut best = (0, 0.0, f64::NEG_INFINITY);
        for (p, phase) in phases.iter().enumerate() {
            if phase.end <= phase.start {
                continue;
            }
            let width = phase.end - phase.start;
            for l in 0..=8 {
                let tau = phase.start + width * l as f64 / 8.0;
                let v = sign * self.cone_side(phase, c, s, tau, None);
                if v > best.2 {
                    best = (p, tau, v);
                }
            }
        }
        let (p, tau, _) = best;
        let phase = &phases[p];
        let step = (phase.end - phase.start) / 8.0;
        let (lo, hi) = ((tau - step).max(phase.start), (tau + step).min(phase.end));
        let (t, v) = crate::harmonic::golden_section_argmax(
            |t| sign * self.cone_side(phase, c, s, t, None),
            lo,
            hi,
        );
        if v > best.2 {
            (p, t)
        } else {
            (p, tau)
        }
    }

    /// (T157): for a contact stuck all period, `max_τ (λ_T − μ λ_N) + min_τ (λ_T + μ λ_N)`
    /// (zero when the force is centred between the cone's extreme excursions), and its
    /// sensitivity to `[γ̂, a₀]` at the two instants (the envelope theorem).
    fn centring(&self, phases: &[Phase], c: usize) -> (f64, Vec<f64>) {
        let nv = 2 * self.contacts.n * n_coefficients(self.harmonics) + self.contacts.n;
        let mut row = vec![0.0; nv];
        let (p1, t1) = self.extreme(phases, c, -1.0, 1.0);
        let (p2, t2) = self.extreme(phases, c, 1.0, -1.0);
        let upper = self.cone_side(&phases[p1], c, -1.0, t1, Some(&mut row));
        let lower = self.cone_side(&phases[p2], c, 1.0, t2, Some(&mut row));
        (upper + lower, row)
    }

    /// The mode of contact `c` after an instant `t` where its indicators' signs are
    /// round-off (a grazing contact, or a slip reversing with the cone's margin growing only
    /// quadratically): among the modes that keep its forces continuous at `t` (a slip
    /// cannot reverse, nor a loaded contact open, at an instant), the one whose indicators
    /// are largest, relative to their coefficients, at `probe` a little after `t`; the
    /// others' modes kept. With the anchors (`c`'s set at `t` if it sticks).
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn mode_after(
        &mut self,
        cascade: &Cascade,
        c: usize,
        t: f64,
        probe: f64,
        modes: &[Mode],
        anchors: &[f64],
        d_anchors: &[f64],
    ) -> Result<(Mode, Vec<f64>, Vec<f64>)> {
        let candidates: &[Mode] = if self.contacts.mu[c] > 0.0 {
            &[
                Mode::Open,
                Mode::Stick,
                Mode::SlipPositive,
                Mode::SlipNegative,
            ]
        } else {
            &[Mode::Open, Mode::SlipPositive]
        };
        let ncoef = n_coefficients(self.harmonics);
        let n = self.contacts.n;
        let (mut coefs, mut scratch) = (Vec::new(), Vec::new());
        // the contact's forces before the instant
        let force_of = |march: &Self, data: usize, a: &[f64]| -> [f64; 2] {
            let d = &march.data[data];
            let m = 2 * n;
            let at = |row: usize| {
                let (v, _, _) = march.combination_at(&d.f[row * m..(row + 1) * m], t);
                v + (0..n).map(|k| d.g[row * n + k] * a[k]).sum::<f64>()
            };
            [at(c), at(n + c)]
        };
        let before = force_of(self, cascade.data, &cascade.anchors);
        let size = before[0].abs() + before[1].abs();
        let mut best: Option<(bool, f64, Mode, Vec<f64>, Vec<f64>)> = None;
        for &candidate in candidates {
            let mut trial = modes.to_vec();
            trial[c] = candidate;
            let (mut a, mut da) = (anchors.to_vec(), d_anchors.to_vec());
            if candidate == Mode::Stick {
                self.stick(cascade, c, t, &mut a, &mut da);
            }
            let data = self.data_of(&trial)?;
            self.indicator_coefficients(data, &a, &mut coefs, &mut scratch);
            let worst = self.data[data]
                .indicators
                .iter()
                .zip(coefs.chunks_exact(ncoef))
                .filter(|(ind, _)| ind.contact == c)
                .map(|(_, row)| {
                    let size = row
                        .iter()
                        .map(|v| v.abs())
                        .sum::<f64>()
                        .max(f64::MIN_POSITIVE);
                    crate::harmonic::evaluate(row, probe) / size
                })
                .fold(f64::INFINITY, f64::min);
            let after = force_of(self, data, &a);
            let continuous = (after[0] - before[0]).abs() + (after[1] - before[1]).abs()
                <= 1e-8 * size.max(f64::MIN_POSITIVE);
            if best
                .as_ref()
                .is_none_or(|(cont, w, ..)| (continuous, worst) > (*cont, *w))
            {
                best = Some((continuous, worst, candidate, a, da));
            }
        }
        let (_, _, mode, a, da) = best.expect("at least one candidate");
        Ok((mode, a, da))
    }

    /// Contact `c` sticks at `t`, in the cascade of switches `cascade` started at that
    /// instant: its anchor and the anchor's sensitivity (T154). The tangential displacement
    /// arrives along the modes before the cascade, and the instant is the root of the
    /// cascade's first indicator; where the displacement moves there (a closing contact, or a
    /// slip stopped by another contact's switch) the instant's sensitivity enters.
    fn stick(
        &self,
        cascade: &Cascade,
        c: usize,
        t: f64,
        anchors: &mut [f64],
        d_anchors: &mut [f64],
    ) {
        let n = self.contacts.n;
        let m = 2 * n;
        let ncoef = n_coefficients(self.harmonics);
        let nu = m * ncoef;
        let nv = nu + n;
        let d = &self.data[cascade.data];
        let rho = &d.yf[(n + c) * m..(n + c + 1) * m];
        let sigma = &d.yg[(n + c) * n..(n + c + 1) * n];
        let (y, ydot, b) = self.combination_at(rho, t);
        let value = y + sigma
            .iter()
            .zip(&cascade.anchors)
            .map(|(s, a)| s * a)
            .sum::<f64>();
        let mut row = vec![0.0; nv];
        for k in 0..ncoef {
            for r in 0..m {
                row[k * m + r] = b[k] * rho[r];
            }
        }
        for (c2, &s) in sigma.iter().enumerate() {
            if s != 0.0 {
                for col in 0..nv {
                    row[col] += s * cascade.d_anchors[c2 * nv + col];
                }
            }
        }
        let trigger = &d.indicators[cascade.indicator];
        // dτ = −dh/ḣ with h = κᵀγ + θᵀa, or h = κᵀγ̇ for a velocity
        let velocity = trigger.kind == Kind::Velocity;
        let (h_row, hdot) = {
            let db = basis_derivative(self.harmonics, cascade.tau);
            let mut bt = vec![0.0; ncoef];
            basis_into(self.harmonics, cascade.tau, &mut bt);
            let (basis_row, slope_row): (Vec<f64>, Vec<f64>) = if velocity {
                // ḣ = κᵀ γ̈, γ̈ of cos kτ, sin kτ is −k² times them
                let second: Vec<f64> = (0..ncoef)
                    .map(|k| {
                        let kk = k.div_ceil(2) as f64;
                        -kk * kk * bt[k]
                    })
                    .collect();
                (db, second)
            } else {
                (bt, db)
            };
            let mut hdot = 0.0;
            for k in 0..ncoef {
                hdot += slope_row[k]
                    * (0..m)
                        .map(|r| trigger.kappa[r] * self.gamma[k * m + r])
                        .sum::<f64>();
            }
            (basis_row, hdot)
        };
        if hdot != 0.0 && ydot != 0.0 {
            let factor = -ydot / hdot;
            for k in 0..ncoef {
                for r in 0..m {
                    row[k * m + r] += factor * h_row[k] * trigger.kappa[r];
                }
            }
            if !velocity {
                for (c2, &th) in trigger.theta.iter().enumerate() {
                    if th != 0.0 {
                        for col in 0..nv {
                            row[col] += factor * th * cascade.d_anchors[c2 * nv + col];
                        }
                    }
                }
            }
        }
        anchors[c] = value;
        d_anchors[c * nv..(c + 1) * nv].copy_from_slice(&row);
    }
}

/// The switches at one instant: the modes before them, the indicator whose root the
/// instant is, and the anchors then.
struct Cascade {
    tau: f64,
    data: usize,
    indicator: usize,
    anchors: Vec<f64>,
    d_anchors: Vec<f64>,
}

impl PeriodicContact {
    /// The contact forces `λ(τ)` (`[normals; tangents]`) of the periodic state.
    pub fn force_at(&self, tau: f64) -> Vec<f64> {
        self.state_at(tau).0
    }

    /// The forces `λ(τ)` and the contact coordinates `y(τ) = γ(τ) + D λ(τ)` (the gaps, then
    /// the tangential displacements) of the periodic state (T152).
    pub fn state_at(&self, tau: f64) -> (Vec<f64>, Vec<f64>) {
        let ncoef = n_coefficients(self.harmonics);
        let m = self.gamma.len() / ncoef;
        let n = m / 2;
        let tau = tau.rem_euclid(2.0 * PI);
        let phase = self
            .phases
            .iter()
            .find(|p| tau >= p.start && tau <= p.end)
            .unwrap_or(&self.phases[self.phases.len() - 1]);
        let [f, g, yf, yg] = &self.data[phase.data];
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let gamma_at: Vec<f64> = (0..m)
            .map(|r| (0..ncoef).map(|k| b[k] * self.gamma[k * m + r]).sum())
            .collect();
        let affine = |a: &[f64], ga: &[f64]| -> Vec<f64> {
            (0..m)
                .map(|i| {
                    (0..m).map(|r| a[i * m + r] * gamma_at[r]).sum::<f64>()
                        + (0..n)
                            .map(|c| ga[i * n + c] * phase.anchors[c])
                            .sum::<f64>()
                })
                .collect()
        };
        (affine(f, g), affine(yf, yg))
    }

    /// The energy the friction forces dissipate over one period, `−∮ λ_Tᵀ dy_T` (the sum of
    /// `μ λ_N |Δy_T|` over the slip phases), by the trapezoidal rule on `samples` instants.
    pub fn dissipated_energy(&self, samples: usize) -> f64 {
        let m = self.gamma.len() / n_coefficients(self.harmonics);
        let n = m / 2;
        let mut total = 0.0;
        let mut previous = self.state_at(0.0);
        for j in 1..=samples {
            let next = self.state_at(2.0 * PI * j as f64 / samples as f64);
            for c in 0..n {
                let force = 0.5 * (previous.0[n + c] + next.0[n + c]);
                total -= force * (next.1[n + c] - previous.1[n + c]);
            }
            previous = next;
        }
        total
    }
}

#[cfg(test)]
mod tests;
