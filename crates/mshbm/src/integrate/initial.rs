//! Initial states for the integrators from a harmonic (periodic) solution, e.g. one found
//! by the MS-HBM: starting a simulation there is how one checks whether the orbit is reached
//! (and shortens the transient).
//!
//! Given the Fourier coefficients `q̂_K` of a set `K` of DOFs (at least all contact-node DOFs,
//! as `mshbm solve` reports them), the other DOFs `U` follow from the linear equations in the
//! frequency domain (paper eqs. 6/25): `H_UU(kω) q̂_U,k = f̂_U,k − H_UK(kω) q̂_K,k` for each
//! harmonic `k`, with `H(kω) = K − (kω)² M + i kω C` in complex form (the constant load is
//! harmonic 0, the harmonic load `F cos ωt` harmonic 1). The state at `t = 0` is then
//! `q(0) = a0 + Σ a_k`, `v(0) = ω Σ k b_k`.

use faer::{c64, Mat};

use crate::error::{Error, Result};
use crate::harmonic::n_coefficients;
use crate::linear::{LinearPart, StructuralBlock};
use crate::model::System;

/// `(q(0), v(0))` (system numbering) of the harmonic solution whose DOFs `known` (pairs of
/// system DOF and coefficients `[a0, a1, b1, …, aH, bH]`, all with the same `H`) are given;
/// `omega` in rad/s. Every contact-node DOF (`system.nonlinear_dofs`) must be known.
pub fn state_from_harmonics(
    system: &System,
    omega: f64,
    known: &[(usize, Vec<f64>)],
) -> Result<(Vec<f64>, Vec<f64>)> {
    let coef = harmonics_from_known(system, omega, known)?;
    let h = (coef.first().map_or(1, Vec::len) - 1) / 2;
    let q0 = coef
        .iter()
        .map(|c| c[0] + (1..=h).map(|k| c[2 * k - 1]).sum::<f64>())
        .collect();
    let v0 = coef
        .iter()
        .map(|c| omega * (1..=h).map(|k| k as f64 * c[2 * k]).sum::<f64>())
        .collect();
    Ok((q0, v0))
}

/// The coefficients `[a0, a1, b1, …, aH, bH]` of every system DOF of the harmonic solution
/// whose DOFs `known` are given (module docs; the same requirements as
/// [`state_from_harmonics`]).
pub fn harmonics_from_known(
    system: &System,
    omega: f64,
    known: &[(usize, Vec<f64>)],
) -> Result<Vec<Vec<f64>>> {
    let n = system.n_dofs();
    if !(omega.is_finite() && omega > 0.0) {
        return Err(Error::argument(
            "frequency",
            format!("must be positive, got {omega} rad/s"),
        ));
    }
    let Some((_, first)) = known.first() else {
        return Err(Error::argument("solution", "no Fourier coefficients given"));
    };
    let nc = first.len();
    if nc == 0 || nc % 2 == 0 {
        return Err(Error::argument(
            "solution",
            format!("expected 2H+1 Fourier coefficients per DOF, got {nc}"),
        ));
    }
    let h = (nc - 1) / 2;
    debug_assert_eq!(n_coefficients(h), nc);
    let mut is_known = vec![false; n];
    let mut coef = vec![Vec::new(); n];
    for (d, c) in known {
        if *d >= n {
            return Err(Error::argument(
                "solution",
                format!("DOF {d} out of range (system has {n} DOFs)"),
            ));
        }
        if c.len() != nc {
            return Err(Error::argument(
                "solution",
                format!(
                    "all DOFs need the same number of coefficients ({nc}), got {}",
                    c.len()
                ),
            ));
        }
        if c.iter().any(|x| !x.is_finite()) {
            return Err(Error::argument("solution", "coefficients must be finite"));
        }
        is_known[*d] = true;
        coef[*d] = c.clone();
    }
    if let Some(&d) = system.nonlinear_dofs.iter().find(|&&d| !is_known[d]) {
        return Err(Error::argument(
            "solution",
            format!(
                "the solution does not give the contact-node DOF {} (model numbering); \
                 every DOF of the contact nodes is needed",
                system.model_dof[d]
            ),
        ));
    }
    let kk: Vec<usize> = (0..n).filter(|&d| is_known[d]).collect();
    let uu: Vec<usize> = (0..n).filter(|&d| !is_known[d]).collect();
    if uu.is_empty() {
        return Ok(coef);
    }
    for &d in &uu {
        coef[d] = vec![0.0; nc];
    }
    let part = LinearPart::new(StructuralBlock::of(
        &system.stiffness,
        &system.mass,
        &system.damping,
        &uu,
        &uu,
    ))?;
    let factors = part.factor(omega, h)?;
    let m_uk = system.mass.submatrix(&uu, &kk);
    let c_uk = system.damping.submatrix(&uu, &kk);
    let k_uk = system.stiffness.submatrix(&uu, &kk);
    let nu = uu.len();
    for k in 0..=h {
        let kw = k as f64 * omega;
        // complex amplitude z = a − i b of the known DOFs
        let z: Vec<c64> = kk
            .iter()
            .map(|&d| {
                if k == 0 {
                    c64::new(coef[d][0], 0.0)
                } else {
                    c64::new(coef[d][2 * k - 1], -coef[d][2 * k])
                }
            })
            .collect();
        let mut rhs = Mat::<c64>::zeros(nu, 1);
        for (r, &d) in uu.iter().enumerate() {
            let f = match k {
                0 => system.constant_load[d],
                1 => system.harmonic_load[d],
                _ => 0.0,
            };
            rhs[(r, 0)] = c64::new(f, 0.0);
        }
        for (r, j, v) in k_uk.iter() {
            rhs[(r, 0)] -= z[j] * v;
        }
        for (r, j, v) in m_uk.iter() {
            rhs[(r, 0)] += z[j] * (kw * kw * v);
        }
        for (r, j, v) in c_uk.iter() {
            rhs[(r, 0)] -= z[j] * c64::new(0.0, kw * v);
        }
        factors.solve_in_place(k, &mut rhs.as_mut())?;
        for (r, &d) in uu.iter().enumerate() {
            let zu = rhs[(r, 0)];
            if k == 0 {
                coef[d][0] = zu.re;
            } else {
                // z = a − i b
                coef[d][2 * k - 1] = zu.re;
                coef[d][2 * k] = -zu.im;
            }
        }
    }
    Ok(coef)
}
