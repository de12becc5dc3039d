//! The condensation of the linear part onto the nonlinear DOFs (`mshbm::linear`, paper
//! eqs. 6 and 25) against an independent reference: dense complex matrices built entry by
//! entry from the system matrices, dense LU solves of the partitioned dynamic stiffness
//! `A_k(ω) = K − (kω)² M + i kω C`, and central finite differences in ω.

mod common;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use mshbm::linear::{
    complex_harmonic, Condensation, CondensedFrequency, ExactCondensation, LinearResponse,
    PartitionedSystem,
};
use mshbm::model::lattice::lattice_model;
use mshbm::{MassKind, Model, System};

const HARMONICS: usize = 3;

/// The lattice (3 × 2 cells, 8 contact-node DOFs) with consistent mass and Rayleigh damping
/// `α M + β K`, so that every coupling block `M_NL`, `C_NL`, `M_NN`, `C_NN` is nonzero, and
/// constant and harmonic loads on both parts.
fn lattice() -> Model {
    let mut model = lattice_model(3, 2, 1.0, 10.0);
    model.damping.beta = 1e-4;
    // node (1, 1) is in L, node (0, 0) carries a contact (N)
    model.constant_load[10] = 0.3;
    model.constant_load[1] = -0.2;
    model.harmonic_load[0] = 0.4;
    model
}

/// `A_k(ω)` of rows `rows` and columns `cols` of `system`, dense, entry by entry.
fn dense_block(system: &System, rows: &[usize], cols: &[usize], k: usize, omega: f64) -> Mat<c64> {
    let kw = k as f64 * omega;
    Mat::from_fn(rows.len(), cols.len(), |i, j| {
        let (r, c) = (rows[i], cols[j]);
        c64::new(
            system.stiffness.get(r, c) - kw * kw * system.mass.get(r, c),
            kw * system.damping.get(r, c),
        )
    })
}

/// The complex load amplitude of harmonic `k` on `dofs`.
fn load(system: &System, dofs: &[usize], k: usize) -> Mat<c64> {
    Mat::from_fn(dofs.len(), 1, |i, _| {
        let v = match k {
            0 => system.constant_load[dofs[i]],
            1 => system.harmonic_load[dofs[i]],
            _ => 0.0,
        };
        c64::new(v, 0.0)
    })
}

/// The dense reference of one harmonic: `G_k`, `u0_k` and the linear response
/// `q̂_L,k(z) = A_LL⁻¹ (f_L − A_LN z)`.
struct Reference {
    g: Mat<c64>,
    u0: Mat<c64>,
    a_ll: Mat<c64>,
    a_ln: Mat<c64>,
    a_nl: Mat<c64>,
    f_l: Mat<c64>,
}

impl Reference {
    fn new(system: &System, k: usize, omega: f64) -> Self {
        let (l, n) = (&system.linear_dofs, &system.nonlinear_dofs);
        let a_ll = dense_block(system, l, l, k, omega);
        let a_ln = dense_block(system, l, n, k, omega);
        let a_nl = dense_block(system, n, l, k, omega);
        let f_l = load(system, l, k);
        let lu = a_ll.partial_piv_lu();
        let g = &a_nl * lu.solve(&a_ln);
        let u0 = &a_nl * lu.solve(&f_l);
        Reference {
            g,
            u0,
            a_ll,
            a_ln,
            a_nl,
            f_l,
        }
    }

    fn linear_response(&self, z: &[c64]) -> Mat<c64> {
        let zm = column(z);
        self.a_ll
            .partial_piv_lu()
            .solve(&self.f_l - &self.a_ln * &zm)
    }

    /// `A_NL q̂_L(z) = u0 − G z`.
    fn coupling_force(&self, z: &[c64]) -> Vec<c64> {
        to_vec(&(&self.a_nl * self.linear_response(z)))
    }
}

fn column(v: &[c64]) -> Mat<c64> {
    Mat::from_fn(v.len(), 1, |i, _| v[i])
}

fn to_vec(m: &Mat<c64>) -> Vec<c64> {
    (0..m.nrows()).map(|i| m[(i, 0)]).collect()
}

fn max_abs(v: impl IntoIterator<Item = c64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.norm()))
}

use common::complex_rel_diff as rel_diff;

fn entries(m: &Mat<c64>) -> Vec<c64> {
    (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect()
}

/// Unknowns `x` (harmonic-major, `n` DOFs) with all harmonics present.
fn unknowns(n: usize) -> Vec<f64> {
    (0..n * (2 * HARMONICS + 1))
        .map(|i| 1e-2 * (1.0 + 0.7 * (1.3 * i as f64).sin()))
        .collect()
}

fn condensed(system: &System, response: LinearResponse, omega: f64) -> Box<dyn CondensedFrequency> {
    ExactCondensation::new(PartitionedSystem::new(system), response)
        .unwrap()
        .at(omega, HARMONICS)
        .unwrap()
}

#[test]
fn interface_stiffness_and_load_equal_the_dense_condensation() {
    let system = lattice().system(MassKind::Consistent).unwrap();
    let n = system.nonlinear_dofs.len();
    assert_eq!(n, 8);
    // the couplings are frequency dependent: mass and damping act between L and N
    let p = PartitionedSystem::new(&system);
    assert!(p.nl.mass.max_abs() > 0.0 && p.nl.damping.max_abs() > 0.0);
    assert!(p.nn.mass.max_abs() > 0.0 && p.nn.damping.max_abs() > 0.0);
    let omega = 200.0;
    for response in [LinearResponse::Solve, LinearResponse::Stored] {
        let c = condensed(&system, response, omega);
        assert_eq!(c.harmonics(), HARMONICS);
        for k in 0..=HARMONICS {
            let r = Reference::new(&system, k, omega);
            let eg = rel_diff(c.interface_stiffness(k), &entries(&r.g));
            println!("{response:?} G_{k}: relative deviation {eg:.1e}");
            assert!(eg < 1e-12, "{response:?} G_{k}: {eg:e}");
            if k <= 1 {
                let eu = rel_diff(c.interface_load(k), &to_vec(&r.u0));
                assert!(eu < 1e-12, "{response:?} u0_{k}: {eu:e}");
            } else {
                assert!(c.interface_load(k).iter().all(|v| v.norm() == 0.0));
            }
            // the linear response q̂_L for given N amplitudes z
            let z = complex_harmonic(&unknowns(n), n, k);
            let eq = rel_diff(
                &c.linear_amplitudes(k, &z).unwrap(),
                &to_vec(&r.linear_response(&z)),
            );
            assert!(eq < 1e-12, "{response:?} q_L,{k}: {eq:e}");
        }
    }
}

/// With the redistributed (massless boundary) mass and damping off the contact nodes,
/// `M_NL = C_NL = 0` and `G_k` is `K_NL A_LL,k⁻¹ K_LN` (eq. 25).
#[test]
fn with_the_redistributed_mass_the_couplings_are_the_stiffness_only() {
    let system = common::rayleigh_damped_bar(12)
        .system(MassKind::Redistributed)
        .unwrap();
    let p = PartitionedSystem::new(&system);
    assert_eq!(p.nl.mass.max_abs(), 0.0);
    assert_eq!(p.nl.damping.max_abs(), 0.0);
    let omega = common::hz(30e3);
    let c = condensed(&system, LinearResponse::Solve, omega);
    let (l, n) = (&system.linear_dofs, &system.nonlinear_dofs);
    let real = |a: &mshbm::sparse::SparseMatrix, rows: &[usize], cols: &[usize]| {
        Mat::<c64>::from_fn(rows.len(), cols.len(), |i, j| {
            c64::new(a.get(rows[i], cols[j]), 0.0)
        })
    };
    let (k_nl, k_ln) = (real(&system.stiffness, n, l), real(&system.stiffness, l, n));
    for k in 0..=HARMONICS {
        let a_ll = dense_block(&system, l, l, k, omega);
        let g = &k_nl * a_ll.partial_piv_lu().solve(&k_ln);
        let e = rel_diff(c.interface_stiffness(k), &entries(&g));
        assert!(e < 1e-12, "G_{k}: {e:e}");
    }
}

/// `H̃_k = A_NN,k − G_k` and `F̃_k = f_N,k − u0_k` give the N part of the full system's
/// response (dense solve of `A_k q = f_k`), and `q̂_L,k` of that N part is its L part.
#[test]
fn condensed_system_reproduces_the_full_dense_solve() {
    let system = lattice().system(MassKind::Consistent).unwrap();
    let (l, n) = (&system.linear_dofs, &system.nonlinear_dofs);
    let all: Vec<usize> = (0..system.n_dofs()).collect();
    let omega = 200.0;
    let c = condensed(&system, LinearResponse::Solve, omega);
    for k in 0..=1 {
        let q = dense_block(&system, &all, &all, k, omega)
            .partial_piv_lu()
            .solve(load(&system, &all, k));
        let q_n: Vec<c64> = n.iter().map(|&d| q[(d, 0)]).collect();
        let q_l: Vec<c64> = l.iter().map(|&d| q[(d, 0)]).collect();
        let h = c.condensed_dynamic_stiffness(k);
        let hq = to_vec(&(&h * column(&q_n)));
        let e = rel_diff(&hq, &c.condensed_load(k));
        assert!(e < 1e-10, "H̃_{k} q_N = F̃_{k}: {e:e}");
        let e = rel_diff(&c.linear_amplitudes(k, &q_n).unwrap(), &q_l);
        assert!(e < 1e-10, "q_L,{k}: {e:e}");
        // one L DOF's Fourier coefficients (harmonic k only, all others zero here)
        let mut x = vec![0.0; n.len() * (2 * HARMONICS + 1)];
        mshbm::linear::store_harmonic(&q_n, n.len(), k, &mut x);
        let li = 3;
        let coefficients = c.linear_dof_coefficients(&x, li).unwrap();
        let expected = if k == 0 {
            [q_l[li].re, 0.0]
        } else {
            [q_l[li].re, -q_l[li].im]
        };
        let got = if k == 0 {
            [coefficients[0], 0.0]
        } else {
            [coefficients[1], coefficients[2]]
        };
        for (a, b) in got.iter().zip(&expected) {
            assert!(
                (a - b).abs() < 1e-10 * q_l[li].norm(),
                "{got:?} vs {expected:?}"
            );
        }
    }
}

/// `∂(A_NL q̂_L)/∂ω = ∂u0/∂ω − ∂G/∂ω z` against central differences in ω of the dense
/// reference `A_NL(ω) A_LL(ω)⁻¹ (f_L − A_LN(ω) z)`; for `k ≥ 2` (no load) it is `−∂G/∂ω z`.
#[test]
fn coupling_force_derivative_equals_central_differences() {
    let system = lattice().system(MassKind::Consistent).unwrap();
    let n = system.nonlinear_dofs.len();
    let omega = 200.0;
    let x = unknowns(n);
    for response in [LinearResponse::Solve, LinearResponse::Stored] {
        let c = condensed(&system, response, omega);
        for k in 1..=HARMONICS {
            let z = complex_harmonic(&x, n, k);
            let mut analytic = vec![c64::new(0.0, 0.0); n];
            c.add_coupling_force_derivative(k, &z, &mut analytic)
                .unwrap();
            let h = 1e-5 * omega;
            let fp = Reference::new(&system, k, omega + h).coupling_force(&z);
            let fm = Reference::new(&system, k, omega - h).coupling_force(&z);
            let fd: Vec<c64> = fp
                .iter()
                .zip(&fm)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect();
            let e = rel_diff(&analytic, &fd);
            println!(
                "{response:?} harmonic {k}: |∂(A_NL q_L)/∂ω| = {:.3e}, relative deviation from central differences {e:.1e}",
                max_abs(analytic.iter().copied())
            );
            assert!(e < 1e-7, "{response:?} harmonic {k}: {e:e}");
            // `out +=`: it adds to what is there
            let mut shifted = vec![c64::new(1.0, -2.0); n];
            c.add_coupling_force_derivative(k, &z, &mut shifted)
                .unwrap();
            let back: Vec<c64> = shifted.iter().map(|v| v - c64::new(1.0, -2.0)).collect();
            assert!(rel_diff(&back, &analytic) < 1e-12);
        }
    }
}

/// The load on N, `B_k(x) = f_N,k − A_NL,k q̂_L,k(z_k)` (harmonic-major real coefficients),
/// against the dense reference, and `∂B/∂ω` against central differences of `B` in ω.
#[test]
fn interface_load_coefficients_and_their_frequency_derivative() {
    let system = lattice().system(MassKind::Consistent).unwrap();
    let n = system.nonlinear_dofs.len();
    let omega = 200.0;
    let x = unknowns(n);
    let c = condensed(&system, LinearResponse::Solve, omega);
    let b = c.interface_load_coefficients(&x);
    let mut expected = vec![0.0; b.len()];
    for k in 0..=HARMONICS {
        let r = Reference::new(&system, k, omega);
        let f_n = load(&system, &system.nonlinear_dofs, k);
        let z = complex_harmonic(&x, n, k);
        let bk: Vec<c64> = r
            .coupling_force(&z)
            .iter()
            .enumerate()
            .map(|(i, p)| f_n[(i, 0)] - p)
            .collect();
        mshbm::linear::store_harmonic(&bk, n, k, &mut expected);
    }
    let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e = b
        .iter()
        .zip(&expected)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale;
    assert!(e < 1e-12, "B: {e:e}");

    let db = c.interface_load_frequency_derivative(&x).unwrap();
    let h = 1e-5 * omega;
    let bp = condensed(&system, LinearResponse::Solve, omega + h).interface_load_coefficients(&x);
    let bm = condensed(&system, LinearResponse::Solve, omega - h).interface_load_coefficients(&x);
    let fd: Vec<f64> = bp
        .iter()
        .zip(&bm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect();
    let scale = fd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e = db
        .iter()
        .zip(&fd)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale;
    println!("∂B/∂ω: relative deviation from central differences {e:.1e}");
    assert!(e < 1e-7, "∂B/∂ω: {e:e}");
    // the mean does not depend on ω (A_0 = K)
    assert!(db[..n].iter().all(|&v| v == 0.0));
}

/// `W` of the system's contacts as a dense `n × n_c` matrix.
fn contact_matrix(system: &System) -> Mat<c64> {
    let mut w = Mat::<c64>::zeros(system.n_dofs(), system.contacts.len());
    for (c, contact) in system.contacts.iter().enumerate() {
        for &(i, v) in &contact.w {
            w[(i, c)] += c64::new(v, 0.0);
        }
    }
    w
}

/// The receptance at the contacts (docs/theory.md (T125)) against the dense reference
/// `Wᵀ A_k⁻¹ W`, `Wᵀ A_k⁻¹ f_k` and `A_k⁻¹ (f_k + W λ)` (dense LU of the whole `A_k`), for the
/// redistributed mass (massless contact nodes, as the MS-HBM uses it) and the consistent
/// one; and its frequency derivative against central differences of the dense reference.
#[test]
fn the_receptance_at_the_contacts_equals_the_dense_solve() {
    use mshbm::linear::{ExactReceptance, Receptance};
    let mut model = lattice();
    model.damping.beta = 0.0;
    model.damping.alpha = 3.0;
    for mass in [MassKind::Redistributed, MassKind::Consistent] {
        let system = model.system(mass).unwrap();
        let all: Vec<usize> = (0..system.n_dofs()).collect();
        let nc = system.contacts.len();
        let w = contact_matrix(&system);
        let omega = 200.0;
        let receptance = ExactReceptance::new(&system).unwrap();
        let at = receptance.at(omega, HARMONICS).unwrap();
        let force: Vec<c64> = (0..nc)
            .map(|c| c64::new(0.3 + 0.1 * c as f64, -0.2 * c as f64))
            .collect();
        let dense_response = |k: usize, omega: f64, with_load: bool| -> Mat<c64> {
            let a = dense_block(&system, &all, &all, k, omega);
            let mut rhs = &w * column(&force);
            if with_load {
                rhs += load(&system, &all, k);
            }
            a.partial_piv_lu().solve(&rhs)
        };
        for k in 0..=HARMONICS {
            let a = dense_block(&system, &all, &all, k, omega);
            let lu = a.partial_piv_lu();
            let r = w.transpose() * lu.solve(&w);
            let e = rel_diff(at.receptance(k), &entries(&r));
            assert!(e < 1e-12, "{mass:?} harmonic {k}: R_k {e:e}");
            let g = w.transpose() * lu.solve(load(&system, &all, k));
            if k <= 1 {
                let e = rel_diff(at.load_response(k), &to_vec(&g));
                assert!(e < 1e-12, "{mass:?} harmonic {k}: load {e:e}");
            } else {
                assert!(max_abs(at.load_response(k).iter().copied()) == 0.0);
            }
            let q = dense_response(k, omega, true);
            let e = rel_diff(&at.response(k, &force).unwrap(), &to_vec(&q));
            assert!(e < 1e-12, "{mass:?} harmonic {k}: response {e:e}");
            if k == 0 {
                continue;
            }
            let h = 1e-4 * omega;
            for with_load in [true, false] {
                let gather =
                    |omega: f64| to_vec(&(w.transpose() * dense_response(k, omega, with_load)));
                let fd = common::richardson_derivative(gather, omega, h);
                let analytic = at.frequency_derivative(k, &force, with_load).unwrap();
                let e = rel_diff(&analytic, &fd);
                println!("{mass:?} harmonic {k} (load {with_load}): ∂(Wᵀq)/∂ω vs central differences {e:.1e}");
                assert!(e < 1e-7, "{mass:?} harmonic {k}: derivative {e:e}");
            }
        }
    }
}
