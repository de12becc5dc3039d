//! One active set of the event-driven N-subsystem (docs/theory.md §8, (T143)–(T145)):
//! between two events the closed contacts keep their gaps at zero and the N-subsystem is a
//! linear, time-invariant ODE in the coordinates that keep them closed, forced by the
//! periodic load `F(θ)`. Its solution is a periodic particular part plus modes, both in
//! closed form.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatMut, MatRef};

use crate::dense::mat_vec;
use crate::error::{Error, Result};

/// The N-subsystem's matrices (dense, N numbering) and its frictionless contacts.
pub(super) struct DenseSubsystem {
    pub mass: Mat<f64>,
    pub damping: Mat<f64>,
    pub stiffness: Mat<f64>,
    pub mass_inv: Mat<f64>,
    /// Contact normals `w_c = ∂g_c/∂q` as columns (`n × n_contacts`).
    pub normals: Mat<f64>,
    /// Initial gaps `g0_c` (`g_c = g0_c + w_cᵀ q`).
    pub gaps: Vec<f64>,
}

impl DenseSubsystem {
    pub fn n(&self) -> usize {
        self.mass.nrows()
    }

    pub fn n_contacts(&self) -> usize {
        self.gaps.len()
    }

    /// `g_c(q)`.
    pub fn gap(&self, c: usize, q: &[f64]) -> f64 {
        self.gaps[c]
            + (0..q.len())
                .map(|i| self.normals[(i, c)] * q[i])
                .sum::<f64>()
    }

    /// `w_cᵀ v`.
    pub fn normal_velocity(&self, c: usize, v: &[f64]) -> f64 {
        (0..v.len()).map(|i| self.normals[(i, c)] * v[i]).sum()
    }

    /// `r = F − K q − C v`.
    pub fn unbalanced_force(&self, f: &[f64], q: &[f64], v: &[f64]) -> Vec<f64> {
        let n = self.n();
        (0..n)
            .map(|i| {
                f[i] - (0..n)
                    .map(|j| self.stiffness[(i, j)] * q[j] + self.damping[(i, j)] * v[j])
                    .sum::<f64>()
            })
            .collect()
    }

    /// The velocity projector of a perfectly plastic impact on the contacts `set`
    /// (docs/theory.md (T144)): `Π = I − M⁻¹W (WᵀM⁻¹W)⁻¹ Wᵀ`, which removes the normal
    /// velocities of `set` with the least kinetic energy lost.
    pub fn impact_projector(&self, set: &[usize]) -> Result<Mat<f64>> {
        let n = self.n();
        let w = Mat::<f64>::from_fn(n, set.len(), |i, j| self.normals[(i, set[j])]);
        let minv_w = &self.mass_inv * &w;
        let delassus = w.transpose() * &minv_w;
        let inner = invert(
            &delassus,
            "the Delassus matrix WᵀM⁻¹W of the closed contacts",
        )?;
        Ok(Mat::<f64>::identity(n, n) - &minv_w * &inner * w.transpose())
    }
}

/// The inverse of a small square matrix, refused when it is singular.
fn invert(a: &Mat<f64>, what: &str) -> Result<Mat<f64>> {
    let n = a.nrows();
    let inv = a.partial_piv_lu().solve(Mat::<f64>::identity(n, n));
    let scale = a.norm_max();
    if inv.norm_max() * scale > 1e13 || inv.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return Err(Error::Singular(format!(
            "{what} is singular or nearly so (dependent contacts, or no mass or stiffness along a motion)"
        )));
    }
    Ok(inv)
}

/// The flow of one active set (docs/theory.md (T143)): `q = q̄ + N y`, `q̇ = N ẏ`, with `N`
/// an orthonormal basis of the motions that keep the closed gaps and `q̄` the point of
/// least norm on them, and the reduced dynamics
/// `M_r ÿ + C_r ẏ + K_r y = Nᵀ (F(θ) − K q̄)` as `ṡ = A s + B (F(θ) − K q̄)`,
/// `s = (y, ẏ)`.
pub(super) struct SetFlow {
    /// The closed contacts.
    pub closed: Vec<usize>,
    /// `N` (`n × m`).
    null: Mat<f64>,
    /// `q̄` (`n`).
    offset: Vec<f64>,
    /// `G = N M_r⁻¹ Nᵀ`: acceleration `G r` for the unbalanced force `r = F − Kq − Cv`.
    acceleration: Mat<f64>,
    /// `(W_IᵀW_I)⁻¹ W_Iᵀ (M G − I)`: the closed contacts' forces `λ = L r`.
    force: Mat<f64>,
    /// `A` (`2m × 2m`).
    state: Mat<f64>,
    /// `B = [0; M_r⁻¹ Nᵀ]` (`2m × n`).
    input: Mat<f64>,
    /// `K q̄` (`n`), the load the closed gaps' offset adds.
    offset_force: Vec<f64>,
    /// Eigenvalues `Λ` and eigenvectors `V` of `A`, and `V⁻¹`.
    pub eigenvalues: Vec<c64>,
    modes: Mat<c64>,
    modes_inv: Mat<c64>,
}

impl SetFlow {
    /// The flow of `sub` with the contacts `closed` kept closed.
    pub fn new(sub: &DenseSubsystem, closed: &[usize]) -> Result<Self> {
        let n = sub.n();
        let r = closed.len();
        let w = Mat::<f64>::from_fn(n, r, |i, j| sub.normals[(i, closed[j])]);
        let (null, offset, wtw_inv) = if r == 0 {
            (
                Mat::<f64>::identity(n, n),
                vec![0.0; n],
                Mat::<f64>::zeros(0, 0),
            )
        } else {
            if r > n {
                return Err(Error::Singular(format!(
                    "{r} contacts closed on {n} nonlinear DOFs: dependent contacts"
                )));
            }
            let svd = w.svd().map_err(|e| {
                Error::Numerical(format!("null space of the contact normals: {e:?}"))
            })?;
            let s = svd.S().column_vector();
            let smax = (0..r).fold(0.0f64, |m, i| m.max(s[i]));
            if (0..r).any(|i| s[i] <= 1e-10 * smax) {
                return Err(Error::Singular(
                    "the normals of the closed contacts are linearly dependent".into(),
                ));
            }
            let u = svd.U();
            let null = Mat::<f64>::from_fn(n, n - r, |i, j| u[(i, r + j)]);
            let wtw_inv = invert(&(w.transpose() * &w), "WᵀW")?;
            let g = Mat::<f64>::from_fn(r, 1, |i, _| sub.gaps[closed[i]]);
            let qbar = -(&w * &wtw_inv * &g);
            (null, (0..n).map(|i| qbar[(i, 0)]).collect(), wtw_inv)
        };
        let m = n - r;
        let reduce = |a: &Mat<f64>| null.transpose() * a * &null;
        let (mr, cr, kr) = (
            reduce(&sub.mass),
            reduce(&sub.damping),
            reduce(&sub.stiffness),
        );
        let mr_inv = if m == 0 {
            Mat::<f64>::zeros(0, 0)
        } else {
            invert(
                &mr,
                "the mass of the nonlinear subsystem along the free motions",
            )?
        };
        let acceleration = &null * &mr_inv * null.transpose();
        let force = if r == 0 {
            Mat::<f64>::zeros(0, n)
        } else {
            &wtw_inv * w.transpose() * (&sub.mass * &acceleration - Mat::<f64>::identity(n, n))
        };
        let mut state = Mat::<f64>::zeros(2 * m, 2 * m);
        let (minv_k, minv_c) = (&mr_inv * &kr, &mr_inv * &cr);
        for i in 0..m {
            state[(i, m + i)] = 1.0;
            for j in 0..m {
                state[(m + i, j)] = -minv_k[(i, j)];
                state[(m + i, m + j)] = -minv_c[(i, j)];
            }
        }
        let minv_nt = &mr_inv * null.transpose();
        let input = Mat::<f64>::from_fn(
            2 * m,
            n,
            |i, j| if i < m { 0.0 } else { minv_nt[(i - m, j)] },
        );
        let kq = &sub.stiffness * Mat::<f64>::from_fn(n, 1, |i, _| offset[i]);
        let (eigenvalues, modes, modes_inv) = if m == 0 {
            (vec![], Mat::<c64>::zeros(0, 0), Mat::<c64>::zeros(0, 0))
        } else {
            modal_form(&state)?
        };
        Ok(SetFlow {
            closed: closed.to_vec(),
            null,
            offset,
            acceleration,
            force,
            state,
            input,
            offset_force: (0..n).map(|i| kq[(i, 0)]).collect(),
            eigenvalues,
            modes,
            modes_inv,
        })
    }

    /// Reduced state size `2m`.
    pub fn reduced(&self) -> usize {
        self.state.nrows()
    }

    /// The largest `|λ|` of the modes (0 without free motion).
    pub fn fastest(&self) -> f64 {
        self.eigenvalues.iter().fold(0.0f64, |m, l| m.max(l.norm()))
    }

    /// `s = (Nᵀ(q − q̄), Nᵀ q̇)`.
    pub fn reduce(&self, q: &[f64], v: &[f64]) -> Vec<f64> {
        let (n, m) = (self.null.nrows(), self.null.ncols());
        let mut s = vec![0.0; 2 * m];
        for j in 0..m {
            for i in 0..n {
                s[j] += self.null[(i, j)] * (q[i] - self.offset[i]);
                s[m + j] += self.null[(i, j)] * v[i];
            }
        }
        s
    }

    /// `(q, q̇) = (q̄ + N y, N ẏ)`.
    pub fn expand(&self, s: &[f64], q: &mut [f64], v: &mut [f64]) {
        let (n, m) = (self.null.nrows(), self.null.ncols());
        for i in 0..n {
            q[i] = self.offset[i];
            v[i] = 0.0;
            for j in 0..m {
                q[i] += self.null[(i, j)] * s[j];
                v[i] += self.null[(i, j)] * s[m + j];
            }
        }
    }

    /// `Tᵀ X` for `T = diag(N, N)`: the reduced rows of a full-state sensitivity `X`
    /// (`2n × p`).
    pub fn reduce_rows(&self, x: &Mat<f64>) -> Mat<f64> {
        let (n, m) = (self.null.nrows(), self.null.ncols());
        let nt = self.null.transpose();
        let top = nt * x.subrows(0, n);
        let bottom = nt * x.subrows(n, n);
        Mat::<f64>::from_fn(2 * m, x.ncols(), |i, j| {
            if i < m {
                top[(i, j)]
            } else {
                bottom[(i - m, j)]
            }
        })
    }

    /// `T X` (`2m × p` → `2n × p`).
    pub fn expand_rows(&self, x: &Mat<f64>) -> Mat<f64> {
        let (n, m) = (self.null.nrows(), self.null.ncols());
        let top = &self.null * x.subrows(0, m);
        let bottom = &self.null * x.subrows(m, m);
        Mat::<f64>::from_fn(2 * n, x.ncols(), |i, j| {
            if i < n {
                top[(i, j)]
            } else {
                bottom[(i - n, j)]
            }
        })
    }

    /// `N X` (`m × p` → `n × p`: the position rows of [`SetFlow::expand_rows`]) into
    /// `out`, on the calling thread and without allocating.
    pub fn expand_positions_into(&self, x: MatRef<'_, f64>, out: MatMut<'_, f64>) {
        faer::linalg::matmul::matmul(
            out,
            faer::Accum::Replace,
            self.null.as_ref(),
            x,
            1.0,
            faer::Par::Seq,
        );
    }

    /// The acceleration `G r` for the unbalanced force `r = F − K q − C q̇`.
    pub fn acceleration(&self, r: &[f64]) -> Vec<f64> {
        mat_vec(&self.acceleration, r)
    }

    /// The closed contacts' forces `L r` (order of [`Self::closed`]).
    pub fn contact_forces(&self, r: &[f64]) -> Vec<f64> {
        mat_vec(&self.force, r)
    }

    /// Row `row` of [`SetFlow::contact_forces`]: the force of the `row`-th closed contact.
    pub fn contact_force(&self, row: usize, r: &[f64]) -> f64 {
        (0..r.len()).map(|j| self.force[(row, j)] * r[j]).sum()
    }

    /// `X_k = (ikω − A)⁻¹ B` (`2m × n`) for `k = 0..=H`: the reduced periodic response to a
    /// load `Re(F̂ e^{ikωθ})` is `Re(X_k F̂ e^{ikωθ})` (docs/theory.md (T143)).
    pub fn harmonic_responses(&self, omega: f64, harmonics: usize) -> Result<Vec<Mat<c64>>> {
        let m2 = self.reduced();
        let n = self.input.ncols();
        let input = Mat::<c64>::from_fn(m2, n, |i, j| c64::new(self.input[(i, j)], 0.0));
        (0..=harmonics)
            .map(|k| {
                let s = c64::new(0.0, k as f64 * omega);
                // in modal coordinates: X_k = V (s − Λ)⁻¹ V⁻¹ B
                let mut y = &self.modes_inv * &input;
                for (i, l) in self.eigenvalues.iter().enumerate() {
                    let d = s - l;
                    if d.norm() <= 1e-12 * l.norm().max(omega) {
                        return Err(Error::Singular(format!(
                            "harmonic {k} is in resonance with an undamped mode of the nonlinear subsystem (add damping or move the frequency)"
                        )));
                    }
                    for j in 0..n {
                        y[(i, j)] /= d;
                    }
                }
                Ok(&self.modes * y)
            })
            .collect()
    }

    /// The constant load the offset `q̄` adds: `−K q̄`.
    pub fn offset_load(&self) -> &[f64] {
        &self.offset_force
    }

    /// `V`.
    pub fn modes(&self) -> &Mat<c64> {
        &self.modes
    }

    /// `V⁻¹`.
    pub fn modes_inv(&self) -> &Mat<c64> {
        &self.modes_inv
    }
}

/// `A = V Λ V⁻¹`, refused when `V` is too ill-conditioned to reproduce `A` to `1e-9`
/// relative (a defective or nearly defective `A`: critically damped modes).
fn modal_form(a: &Mat<f64>) -> Result<(Vec<c64>, Mat<c64>, Mat<c64>)> {
    let n = a.nrows();
    let (l, v) = crate::dense::eigen(a.as_ref())
        .map_err(|e| Error::Numerical(format!("modes of the nonlinear subsystem: {e}")))?;
    let v_inv = v.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
    let mut worst = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let mut s = c64::new(0.0, 0.0);
            for k in 0..n {
                s += v[(i, k)] * l[k] * v_inv[(k, j)];
            }
            worst = worst.max((s.re - a[(i, j)]).abs() + s.im.abs());
        }
    }
    // (a NaN in the reconstruction is refused too)
    if worst.is_nan() || worst > 1e-9 * a.norm_max().max(f64::MIN_POSITIVE) {
        return Err(Error::Singular(
            "the nonlinear subsystem has (nearly) defective modes (critical damping); use Moreau–Jean time stepping".into(),
        ));
    }
    Ok((l, v, v_inv))
}
