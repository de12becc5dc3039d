//! The modes' exponentials of an evaluation and a sample's position sensitivity, into
//! buffers kept per period (the event integration's per-sample work, BENCHMARKS.md §13).

use faer::{c64, Mat, MatRef};

use super::{Integration, Interval};

/// `e^{λ_m τ}` for every mode into `out`. The second of a complex-conjugate pair (adjacent
/// and exactly conjugate in [`crate::dense::eigen`]'s order) is taken as the conjugate of
/// the first's, the same number bit for bit (`cos` even, `sin` odd): half the exponentials
/// of the scan's and the root finders' evaluations.
pub(super) fn modal_exponentials(eigenvalues: &[c64], tau: f64, out: &mut Vec<c64>) {
    out.clear();
    let mut m = 0;
    while m < eigenvalues.len() {
        let l = eigenvalues[m];
        let g = (l * tau).exp();
        out.push(g);
        if l.im != 0.0 && eigenvalues.get(m + 1) == Some(&l.conj()) {
            out.push(g.conj());
            m += 2;
        } else {
            m += 1;
        }
    }
}

impl Integration<'_> {
    /// `∂q(θ)/∂p` (the position rows of [`Integration::sensitivity`]) into rows
    /// `row..row + n` of `out` (phases already at `θ`), from buffers kept per period: a
    /// sample's sensitivity allocates nothing.
    pub(super) fn position_sensitivity_into(
        &self,
        iv: &Interval,
        theta: f64,
        out: &mut Mat<f64>,
        row: usize,
    ) {
        let a = &self.sets[iv.set];
        let (n, p) = (self.n, self.n_params);
        let m = a.flow.reduced() / 2;
        let mut guard = self.scratch.borrow_mut();
        let sc = &mut *guard;
        // the reduced positions' rows of `∂s_p/∂p` (as `particular_sensitivity`) …
        sc.ds.clear();
        sc.ds.resize(m * p, 0.0);
        for (k, x) in a.responses.iter().enumerate() {
            for j in 0..n {
                for i in 0..m {
                    let v = x[(i, j)] * self.e[k];
                    if k == 0 {
                        sc.ds[j * m + i] = v.re;
                    } else {
                        sc.ds[((2 * k - 1) * n + j) * m + i] = v.re;
                        sc.ds[(2 * k * n + j) * m + i] = v.im;
                    }
                }
            }
        }
        // … plus the modes' part (as `sensitivity`)
        modal_exponentials(&a.flow.eigenvalues, theta - iv.start, &mut sc.growth);
        let v = a.flow.modes();
        for i in 0..m {
            for j in 0..p {
                let mut acc = 0.0;
                for (mode, g) in sc.growth.iter().enumerate() {
                    acc += (v[(i, mode)] * g * iv.sensitivity[(mode, j)]).re;
                }
                sc.ds[j * m + i] += acc;
            }
        }
        a.flow.expand_positions_into(
            MatRef::from_column_major_slice(&sc.ds, m, p),
            out.as_mut().submatrix_mut(row, 0, n, p),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The conjugate of a pair's exponential is that of the conjugate eigenvalue, bit for
    /// bit (the scan's results do not change); a real eigenvalue and a lone complex one
    /// are exponentiated themselves.
    #[test]
    fn conjugate_pairs_share_one_exponential() {
        let values = [
            c64::new(-3.0e2, 4.2e7),
            c64::new(-3.0e2, -4.2e7),
            c64::new(-7.5, 0.0),
            c64::new(-1.0, 2.0),
        ];
        let mut out = Vec::new();
        for tau in [0.0, 1.3e-9, 2.7e-6, 0.1] {
            modal_exponentials(&values, tau, &mut out);
            assert_eq!(out.len(), values.len());
            for (l, g) in values.iter().zip(&out) {
                let direct = (l * tau).exp();
                assert_eq!(g.re.to_bits(), direct.re.to_bits(), "{l} {tau}");
                assert_eq!(g.im.to_bits(), direct.im.to_bits(), "{l} {tau}");
            }
        }
    }
}
