//! The per-frequency maps of the residual (T128) and its Jacobian (T129): `P R_k⁻¹` per
//! harmonic `k = 0..=H` for `P = I` (the structure's force), `P = D` (its free gap) and
//! `P = Λ` (the residual's scaling), in two forms:
//!
//! - **dense**: `R_k⁻¹` formed by an LU of the `n_c × n_c` receptance, then the products
//!   (`≈ 4 n_c³` complex multiply-adds per harmonic and frequency), for any receptance;
//! - **static plus low rank** (docs/theory.md (T136)): when the receptance is
//!   `R_k = R_s + B X_k Bᵀ` (the modal receptance (T130), `m` modes),
//!   `R_k⁻¹ = R_s⁻¹ − E Z_k Eᵀ` with `E = R_s⁻¹ B`, `G = Bᵀ E` and
//!   `Z_k = (I + X_k G)⁻¹ X_k`. `P R_s⁻¹` and `P E` are real and formed once per method;
//!   per frequency only the `m × m` matrices `Z_k` are (`O(m³)`, no `n_c³`).

use std::borrow::Cow;
use std::rc::Rc;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};

use crate::error::{Error, Result};
use crate::linear::{complex_harmonic, store_harmonic, ReceptanceAtFrequency, StaticPlusLowRank};

/// Contacts up to which the dense maps are applied by a direct loop (above, by faer's
/// matrix–vector products on complex copies of each harmonic).
const DIRECT_PRODUCT_CONTACTS: usize = 8;

/// Which map `P R_k⁻¹`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Map {
    /// `R_k⁻¹`.
    Inverse = 0,
    /// `D R_k⁻¹` (`D` the Delassus matrix).
    Scaled = 1,
    /// `Λ R_k⁻¹` (`Λ` the residual's scale).
    Residual = 2,
}

/// The maps `P R_k⁻¹` at one frequency (module docs).
pub(super) enum FrequencyMatrices {
    /// `[R_k⁻¹, D R_k⁻¹, Λ R_k⁻¹]` per harmonic (`n_c × n_c` complex).
    Dense(Vec<[Mat<c64>; 3]>),
    /// `R_k⁻¹ = R_s⁻¹ − E Z_k Eᵀ`, with `Z_k` per harmonic.
    StaticPlusLowRank {
        parts: Rc<StaticMaps>,
        corrections: Vec<Mat<c64>>,
    },
}

/// The frequency-independent parts of the static-plus-low-rank maps (T136): for
/// `P = I, D, Λ`, `P R_s⁻¹` (`n_c × n_c`) and `P E` (`n_c × m`), and `G = Bᵀ R_s⁻¹ B`.
pub(super) struct StaticMaps {
    static_inverse: [Mat<f64>; 3],
    shapes: [Mat<f64>; 3],
    gram: Mat<f64>,
}

impl StaticMaps {
    /// The parts for the receptance `R_s + B X_k Bᵀ`, the Delassus matrix `D` and the scale
    /// `Λ` (both `n_c × n_c`, row-major). `None` when `R_s` is not positive definite (then
    /// the dense form is used).
    pub(super) fn new(
        parts: &StaticPlusLowRank<'_>,
        delassus: &[f64],
        scale: &[f64],
    ) -> Option<Self> {
        let nc = parts.static_receptance.nrows();
        let llt = parts.static_receptance.llt(faer::Side::Lower).ok()?;
        let inverse = llt.solve(Mat::<f64>::identity(nc, nc));
        let e = llt.solve(parts.contact_shapes);
        let gram = parts.contact_shapes.transpose() * &e;
        let d = MatRef::from_row_major_slice(delassus, nc, nc);
        let l = MatRef::from_row_major_slice(scale, nc, nc);
        let finite = |m: &Mat<f64>| m.col_iter().all(|c| c.iter().all(|v| v.is_finite()));
        if !(finite(&inverse) && finite(&e)) {
            return None;
        }
        // in the order of `Map`: I, D, Λ
        Some(StaticMaps {
            static_inverse: [inverse.clone(), d * &inverse, l * &inverse],
            shapes: [e.clone(), d * &e, l * &e],
            gram,
        })
    }

    fn n_modes(&self) -> usize {
        self.gram.nrows()
    }
}

impl FrequencyMatrices {
    /// The dense maps at the frequency of `receptance` (an LU per harmonic).
    pub(super) fn dense(
        receptance: &dyn ReceptanceAtFrequency,
        delassus: &[f64],
        scale: &[f64],
        n: usize,
    ) -> Result<Self> {
        let zeros = || Mat::<c64>::zeros(n, n);
        let mut maps = FrequencyMatrices::Dense(
            (0..=receptance.harmonics())
                .map(|_| [zeros(), zeros(), zeros()])
                .collect(),
        );
        maps.refill_dense(receptance, delassus, scale, n)?;
        Ok(maps)
    }

    /// Whether these are dense maps of `n` contacts and `harmonics` harmonics (which
    /// [`FrequencyMatrices::refill_dense`] can overwrite).
    pub(super) fn is_dense_of(&self, n: usize, harmonics: usize) -> bool {
        matches!(self, FrequencyMatrices::Dense(maps)
            if maps.len() == harmonics + 1 && maps[0][0].nrows() == n)
    }

    /// The dense maps at the frequency of `receptance`, written over these
    /// ([`FrequencyMatrices::is_dense_of`] holds): for one contact the maps are numbers and
    /// nothing is allocated.
    pub(super) fn refill_dense(
        &mut self,
        receptance: &dyn ReceptanceAtFrequency,
        delassus: &[f64],
        scale: &[f64],
        n: usize,
    ) -> Result<()> {
        let FrequencyMatrices::Dense(maps) = self else {
            unreachable!("refill_dense on dense maps only")
        };
        // D and Λ as complex matrices, for the products of more than one contact
        let real = |v: &[f64]| Mat::<c64>::from_fn(n, n, |i, j| c64::new(v[i * n + j], 0.0));
        let (d, l) = if n == 1 {
            (Mat::zeros(0, 0), Mat::zeros(0, 0))
        } else {
            (real(delassus), real(scale))
        };
        for (k, [r_inv, scaled, residual]) in maps.iter_mut().enumerate() {
            if n == 1 {
                // one contact: the maps are numbers
                let inverse = c64::new(1.0, 0.0) / receptance.receptance(k)[0];
                if !(inverse.re.is_finite() && inverse.im.is_finite()) {
                    return Err(singular_receptance(k, receptance.omega()));
                }
                r_inv[(0, 0)] = inverse;
                scaled[(0, 0)] = inverse * delassus[0];
                residual[(0, 0)] = inverse * scale[0];
                continue;
            }
            let r = MatRef::from_row_major_slice(receptance.receptance(k), n, n);
            *r_inv = r.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
            check_finite(r_inv, k, receptance.omega())?;
            *scaled = &d * &*r_inv;
            *residual = &l * &*r_inv;
        }
        Ok(())
    }

    /// The static-plus-low-rank maps at the frequency of `receptance`, whose `X_k` are
    /// [`ReceptanceAtFrequency::modal_correction`]; `None` if it has none.
    pub(super) fn static_plus_low_rank(
        receptance: &dyn ReceptanceAtFrequency,
        parts: &Rc<StaticMaps>,
    ) -> Result<Option<Self>> {
        let m = parts.n_modes();
        let gram = Mat::<c64>::from_fn(m, m, |i, j| c64::new(parts.gram[(i, j)], 0.0));
        let mut corrections = Vec::with_capacity(receptance.harmonics() + 1);
        for k in 0..=receptance.harmonics() {
            let Some(x) = receptance.modal_correction(k) else {
                return Ok(None);
            };
            // Z_k = (I + X_k G)⁻¹ X_k
            let a = Mat::<c64>::identity(m, m) + x * &gram;
            let z = a.partial_piv_lu().solve(x);
            check_finite(&z, k, receptance.omega())?;
            corrections.push(z);
        }
        Ok(Some(FrequencyMatrices::StaticPlusLowRank {
            parts: Rc::clone(parts),
            corrections,
        }))
    }

    /// `P R_k⁻¹ z` per harmonic for harmonic-major real coefficients `z` of `n` contacts
    /// (the real form (T15)).
    pub(super) fn apply(&self, map: Map, n: usize, z: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; z.len()];
        self.apply_into(map, n, z, &mut out);
        out
    }

    /// [`FrequencyMatrices::apply`] into `out` (as long as `z`); the dense maps of up to
    /// [`DIRECT_PRODUCT_CONTACTS`] contacts allocate nothing.
    pub(super) fn apply_into(&self, map: Map, n: usize, z: &[f64], out: &mut [f64]) {
        match self {
            FrequencyMatrices::Dense(maps) if n <= DIRECT_PRODUCT_CONTACTS => {
                // z_k = a − i b per harmonic, read and written in place (no temporaries)
                for (k, m) in maps.iter().enumerate() {
                    let m = &m[map as usize];
                    let (re, im) = if k == 0 {
                        (0, None)
                    } else {
                        (2 * k - 1, Some(2 * k))
                    };
                    for i in 0..n {
                        let mut sum = c64::new(0.0, 0.0);
                        for j in 0..n {
                            let zj = c64::new(z[re * n + j], im.map_or(0.0, |s| -z[s * n + j]));
                            sum += m[(i, j)] * zj;
                        }
                        out[re * n + i] = sum.re;
                        if let Some(s) = im {
                            out[s * n + i] = -sum.im;
                        }
                    }
                }
            }
            FrequencyMatrices::Dense(maps) => {
                for (k, m) in maps.iter().enumerate() {
                    let zk = complex_harmonic(z, n, k);
                    let product = &m[map as usize] * faer::ColRef::from_slice(&zk);
                    let v: Vec<c64> = product.iter().copied().collect();
                    store_harmonic(&v, n, k, out);
                }
            }
            FrequencyMatrices::StaticPlusLowRank { parts, corrections } => {
                let columns = z.len() / n;
                let m = parts.n_modes();
                let zm = MatRef::from_column_major_slice(z, n, columns);
                let mut result = &parts.static_inverse[map as usize] * zm;
                // Eᵀ z, then Z_k per harmonic, then P E
                let projected = parts.shapes[Map::Inverse as usize].transpose() * zm;
                let projected: Vec<f64> = (0..m * columns)
                    .map(|q| projected[(q % m, q / m)])
                    .collect();
                let mut corrected = vec![0.0; m * columns];
                for (k, zk) in corrections.iter().enumerate() {
                    let yk = complex_harmonic(&projected, m, k);
                    let product = zk * faer::ColRef::from_slice(&yk);
                    let v: Vec<c64> = product.iter().copied().collect();
                    store_harmonic(&v, m, k, &mut corrected);
                }
                result -= &parts.shapes[map as usize]
                    * MatRef::from_column_major_slice(&corrected, m, columns);
                for (q, o) in out.iter_mut().enumerate() {
                    *o = result[(q % n, q / n)];
                }
            }
        }
    }

    /// `P R_k⁻¹` as a dense complex matrix (for the dense Jacobian).
    pub(super) fn matrix(&self, map: Map, k: usize) -> Cow<'_, Mat<c64>> {
        match self {
            FrequencyMatrices::Dense(maps) => Cow::Borrowed(&maps[k][map as usize]),
            FrequencyMatrices::StaticPlusLowRank { parts, corrections } => {
                let z = &corrections[k];
                let pe = &parts.shapes[map as usize];
                let e = &parts.shapes[Map::Inverse as usize];
                let (m, n) = (z.nrows(), pe.nrows());
                let re = Mat::<f64>::from_fn(m, m, |i, j| z[(i, j)].re);
                let im = Mat::<f64>::from_fn(m, m, |i, j| z[(i, j)].im);
                let re = &parts.static_inverse[map as usize] - (pe * &re) * e.transpose();
                let im = (pe * &im) * e.transpose();
                Cow::Owned(Mat::from_fn(n, n, |i, j| c64::new(re[(i, j)], -im[(i, j)])))
            }
        }
    }
}

fn check_finite(m: &Mat<c64>, k: usize, omega: f64) -> Result<()> {
    if m.col_iter()
        .any(|c| c.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())))
    {
        return Err(singular_receptance(k, omega));
    }
    Ok(())
}

fn singular_receptance(k: usize, omega: f64) -> Error {
    Error::Singular(format!(
        "the receptance of the structure at its contacts is singular at harmonic {k} ({:.6} Hz)",
        k as f64 * omega / (2.0 * std::f64::consts::PI)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::{ModalReceptance, Receptance};
    use crate::model::MassKind;

    /// A real `n × n` matrix (row-major) with entries in `[−1, 1]` plus `n` on the diagonal.
    fn matrix(n: usize, seed: f64) -> Vec<f64> {
        (0..n * n)
            .map(|e| {
                (seed * (e as f64 + 1.0)).sin() + if e % (n + 1) == 0 { n as f64 } else { 0.0 }
            })
            .collect()
    }

    /// The direct product of few contacts is the complex product per harmonic (T15): real
    /// coefficients to `z = a − i b`, times the map, back.
    #[test]
    fn the_direct_product_is_the_complex_product() {
        let (n, harmonics) = (3, 4);
        let map = |k: usize, p: usize| {
            Mat::<c64>::from_fn(n, n, |i, j| {
                let e = (i * n + j + 7 * k + 31 * p) as f64;
                c64::new((0.3 * e).sin(), (0.7 * e).cos())
            })
        };
        let maps = FrequencyMatrices::Dense(
            (0..=harmonics)
                .map(|k| [map(k, 0), map(k, 1), map(k, 2)])
                .collect(),
        );
        let z: Vec<f64> = (0..n * (2 * harmonics + 1))
            .map(|i| (1.1 * i as f64).cos())
            .collect();
        for (p, which) in [Map::Inverse, Map::Scaled, Map::Residual]
            .into_iter()
            .enumerate()
        {
            let out = maps.apply(which, n, &z);
            let mut expected = vec![0.0; z.len()];
            for k in 0..=harmonics {
                let zk = complex_harmonic(&z, n, k);
                let product: Vec<c64> = (0..n)
                    .map(|i| (0..n).map(|j| map(k, p)[(i, j)] * zk[j]).sum())
                    .collect();
                store_harmonic(&product, n, k, &mut expected);
            }
            for (a, b) in out.iter().zip(&expected) {
                assert!((a - b).abs() <= 1e-14, "{which:?}: {a} vs {b}");
            }
        }
    }

    /// The static-plus-low-rank maps (T136) against the dense ones, which invert the formed
    /// receptance `R_s + B X_k Bᵀ` by an LU: every map, applied and as a matrix, on a plate
    /// with 20 contacts and 12 modes, below, near and above its first resonance.
    #[test]
    fn the_low_rank_maps_equal_the_dense_inverse() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/block_3d/model.toml");
        let model = crate::model::file::load_model(&file, &["solid.divisions=[4,4,4]".to_string()])
            .unwrap();
        let system = model.system(MassKind::Redistributed).unwrap();
        let receptance = ModalReceptance::new(&system, 12).unwrap();
        let n = receptance.n_contacts();
        assert_eq!(n, 20);
        let (delassus, scale) = (matrix(n, 0.37), matrix(n, 1.3));
        let parts = receptance.static_plus_low_rank().unwrap();
        let maps = Rc::new(StaticMaps::new(&parts, &delassus, &scale).unwrap());
        let harmonics = 3;
        let z: Vec<f64> = (0..n * (2 * harmonics + 1))
            .map(|i| (0.7 * i as f64).cos())
            .collect();
        let first = receptance.eigenvalues()[0].sqrt();
        for omega in [0.3 * first, 0.99 * first, 2.7 * first] {
            let at = receptance.at(omega, harmonics).unwrap();
            let dense = FrequencyMatrices::dense(at.as_ref(), &delassus, &scale, n).unwrap();
            let low_rank = FrequencyMatrices::static_plus_low_rank(at.as_ref(), &maps)
                .unwrap()
                .unwrap();
            for map in [Map::Inverse, Map::Scaled, Map::Residual] {
                let (a, b) = (dense.apply(map, n, &z), low_rank.apply(map, n, &z));
                let size = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let e = a
                    .iter()
                    .zip(&b)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                assert!(e <= 1e-10 * size, "{map:?} at {omega}: {e:e} of {size:e}");
                for k in 0..=harmonics {
                    let (a, b) = (dense.matrix(map, k), low_rank.matrix(map, k));
                    let size = a
                        .col_iter()
                        .flat_map(|c| c.iter().map(|v| v.norm()))
                        .fold(0.0, f64::max);
                    let e = (a.as_ref() - b.as_ref())
                        .col_iter()
                        .flat_map(|c| c.iter().map(|v| v.norm()).collect::<Vec<_>>())
                        .fold(0.0, f64::max);
                    assert!(
                        e <= 1e-10 * size,
                        "{map:?}, k = {k}, at {omega}: {e:e} of {size:e}"
                    );
                }
            }
        }
    }
}
