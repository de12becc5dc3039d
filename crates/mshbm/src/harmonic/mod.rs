//! Fourier basis, sampling and exact interval integrals (paper eqs. 4–5, 9, 33–35;
//! docs/theory.md §2, (T7)–(T10)).
//!
//! Convention: `q(τ) = q⁰ + Σ_{k=1..H} q^{c,k} cos kτ + q^{s,k} sin kτ` in normalised time
//! `τ = ωt ∈ [0, 2π)`; coefficients ordered `[q⁰, q^{c,1}, q^{s,1}, …, q^{c,H}, q^{s,H}]`
//! (index `0`, `2k−1`, `2k`). For a set of DOFs the vector is harmonic-major: coefficient
//! `c` of DOF `i` is entry `c·n + i`. The mean uses `1/2π` (not `2/T` as the paper's
//! eq. 33 prints).
//!
//! A Fourier coefficient is a weighted integral `q̂_m = w_m/(2π) ∫ q(τ) b_m(τ) dτ` with
//! `w_0 = 1`, `w_m = 2`. For a piecewise representation `q(τ) = Σ_c B_c b_c(τ)` on an
//! interval, the contribution is `Σ_c B_c Γ_mc` with the *Gram block*
//! `Γ_mc = w_m/(2π) ∫_I b_m b_c dτ`; with samples, `Γ_mc = w_m/N b_m(τ_j) b_c(τ_j)` (the DFT;
//! docs/theory.md (T16)). Both quadratures of the MS-HBM are sums of such blocks.

use std::f64::consts::PI;

/// Number of coefficients `2H + 1`.
pub fn n_coefficients(harmonics: usize) -> usize {
    2 * harmonics + 1
}

/// `2H + 1`, `None` when it overflows `usize` (a user-given `H`).
pub fn checked_coefficients(harmonics: usize) -> Option<usize> {
    harmonics.checked_mul(2)?.checked_add(1)
}

/// Basis row `b(τ) = [1, cos τ, sin τ, …, cos Hτ, sin Hτ]`, written into `out`.
pub fn basis_into(harmonics: usize, tau: f64, out: &mut [f64]) {
    out[0] = 1.0;
    let mut rotation = Rotation::new(tau);
    for k in 1..=harmonics {
        let (c, s) = rotation.next();
        out[2 * k - 1] = c;
        out[2 * k] = s;
    }
}

/// `(cos kτ, sin kτ)` for `k = 1, 2, …` by the angle-addition recurrence (one `sin_cos`
/// per evaluation instead of one per harmonic; the trigonometric polynomials of the exact
/// quadrature are evaluated millions of times per Newton step). Re-anchored every 16
/// harmonics so that the rounding error stays at a few ulps.
struct Rotation {
    tau: f64,
    k: usize,
    step: (f64, f64),
    current: (f64, f64),
}

impl Rotation {
    fn new(tau: f64) -> Self {
        let (s, c) = tau.sin_cos();
        Rotation {
            tau,
            k: 0,
            step: (c, s),
            current: (1.0, 0.0),
        }
    }

    fn next(&mut self) -> (f64, f64) {
        self.k += 1;
        self.current = if self.k % 16 == 0 {
            let (s, c) = (self.k as f64 * self.tau).sin_cos();
            (c, s)
        } else {
            let (c, s) = self.current;
            let (c1, s1) = self.step;
            (c * c1 - s * s1, s * c1 + c * s1)
        };
        self.current
    }
}

/// Basis row `b(τ)`.
pub fn basis(harmonics: usize, tau: f64) -> Vec<f64> {
    let mut b = vec![0.0; n_coefficients(harmonics)];
    basis_into(harmonics, tau, &mut b);
    b
}

/// Derivative `db/dτ`.
pub fn basis_derivative(harmonics: usize, tau: f64) -> Vec<f64> {
    let mut b = vec![0.0; n_coefficients(harmonics)];
    let mut rotation = Rotation::new(tau);
    for k in 1..=harmonics {
        let (c, s) = rotation.next();
        b[2 * k - 1] = -(k as f64) * s;
        b[2 * k] = k as f64 * c;
    }
    b
}

/// `out[i] += q_i(τ)` for `n` signals whose coefficients are harmonic-major
/// (`coefficients[c·n + i]`, `harmonics` harmonics): the series at any `τ`, by the
/// angle-addition recurrence (one `sin_cos` per call, no allocation).
pub fn add_series_at(harmonics: usize, tau: f64, coefficients: &[f64], n: usize, out: &mut [f64]) {
    let mut rotation = Rotation::new(tau);
    if n == 1 {
        let mut v = coefficients[0];
        for k in 1..=harmonics {
            let (c, s) = rotation.next();
            v += coefficients[2 * k - 1] * c + coefficients[2 * k] * s;
        }
        out[0] += v;
        return;
    }
    for (o, &q) in out[..n].iter_mut().zip(&coefficients[..n]) {
        *o += q;
    }
    for k in 1..=harmonics {
        let (c, s) = rotation.next();
        let (a, b) = (
            &coefficients[(2 * k - 1) * n..2 * k * n],
            &coefficients[2 * k * n..(2 * k + 1) * n],
        );
        for ((o, &a), &b) in out[..n].iter_mut().zip(a).zip(b) {
            *o += a * c + b * s;
        }
    }
}

/// Value of the scalar trigonometric polynomial with coefficients `coef` at `τ`.
pub fn evaluate(coef: &[f64], tau: f64) -> f64 {
    let h = (coef.len() - 1) / 2;
    let mut v = coef[0];
    let mut rotation = Rotation::new(tau);
    for k in 1..=h {
        let (c, s) = rotation.next();
        v += coef[2 * k - 1] * c + coef[2 * k] * s;
    }
    v
}

/// Value and derivative `dq/dτ` of the scalar trigonometric polynomial with coefficients
/// `coef` at `τ` (one pass of the angle-addition recurrence).
pub fn evaluate_with_slope(coef: &[f64], tau: f64) -> (f64, f64) {
    let h = (coef.len() - 1) / 2;
    let (mut v, mut slope) = (coef[0], 0.0);
    let mut rotation = Rotation::new(tau);
    for k in 1..=h {
        let (c, s) = rotation.next();
        let (a, b) = (coef[2 * k - 1], coef[2 * k]);
        v += a * c + b * s;
        slope += k as f64 * (b * c - a * s);
    }
    (v, slope)
}

/// The coefficient vector `x` of `n` signals with `from` harmonics, ordered harmonic-major
/// (docs/theory.md (T8)), as the vector of the same signals with `to` harmonics: the higher
/// harmonics set to zero (`to > from`) or dropped (`to < from`). `None` when `x.len()` is not
/// a multiple of `2 from + 1`. A start for Newton at another `H` from a solved one.
pub fn with_harmonics(x: &[f64], from: usize, to: usize) -> Option<Vec<f64>> {
    let blocks = n_coefficients(from);
    if x.len() % blocks != 0 {
        return None;
    }
    let n = x.len() / blocks;
    let mut out = vec![0.0; n * n_coefficients(to)];
    let kept = n * n_coefficients(from.min(to));
    out[..kept].copy_from_slice(&x[..kept]);
    Some(out)
}

/// Weight `w_m` of coefficient `m` (1 for the mean, 2 otherwise).
pub fn weight(m: usize) -> f64 {
    if m == 0 {
        1.0
    } else {
        2.0
    }
}

/// Equidistant sampling of one period: `τ_j = 2πj/N`.
#[derive(Clone, Debug)]
pub struct Sampling {
    pub harmonics: usize,
    pub taus: Vec<f64>,
    /// `basis[j]` = `b(τ_j)`.
    pub basis: Vec<Vec<f64>>,
}

impl Sampling {
    /// Bytes of the sampling of `H` harmonics at `samples` samples (the basis rows
    /// `b(τ_j)` and the phases), `None` on overflow.
    pub fn memory_bytes(harmonics: usize, samples: usize) -> Option<u64> {
        let row = (checked_coefficients(harmonics)? as u64).checked_add(1)?;
        (samples as u64).checked_mul(row)?.checked_mul(8)
    }

    /// [`Sampling::new`] for sizes from user input: refuses with
    /// [`crate::error::Error::ResourceLimit`] (naming the samples and harmonics) when the
    /// sampling would not fit `limits`, before allocating.
    pub fn within(
        harmonics: usize,
        samples: usize,
        limits: &crate::limits::Limits,
    ) -> crate::error::Result<Self> {
        limits.check_memory(
            &format!("the Fourier basis at {samples} samples × {harmonics} harmonics"),
            Self::memory_bytes(harmonics, samples),
        )?;
        Ok(Self::new(harmonics, samples))
    }

    /// `samples ≥ 2H + 1` is the caller's responsibility (checked by the methods).
    ///
    /// # Panics
    /// When the sampling does not fit in memory; sizes from user input go through
    /// [`Sampling::within`].
    pub fn new(harmonics: usize, samples: usize) -> Self {
        let taus: Vec<f64> = (0..samples)
            .map(|j| 2.0 * PI * j as f64 / samples as f64)
            .collect();
        let basis = taus.iter().map(|&t| basis(harmonics, t)).collect();
        Sampling {
            harmonics,
            taus,
            basis,
        }
    }

    pub fn len(&self) -> usize {
        self.taus.len()
    }

    pub fn is_empty(&self) -> bool {
        self.taus.is_empty()
    }

    /// DFT weight row of sample `j`: `w_m b_m(τ_j) / N` (docs/theory.md (T10)).
    pub fn dft_row(&self, j: usize) -> Vec<f64> {
        let n = self.len() as f64;
        self.basis[j]
            .iter()
            .enumerate()
            .map(|(m, b)| weight(m) * b / n)
            .collect()
    }

    /// Fourier coefficients of scalar samples (the DFT, docs/theory.md (T10)).
    pub fn dft(&self, samples: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; n_coefficients(self.harmonics)];
        let n = self.len() as f64;
        for (j, &v) in samples.iter().enumerate() {
            for (m, b) in self.basis[j].iter().enumerate() {
                out[m] += weight(m) * b * v / n;
            }
        }
        out
    }

    /// Add the Gram block of sample `j` (`Γ_mc += w_m b_m b_c / N`) to `gram` (row-major).
    pub fn add_sample_gram(&self, j: usize, gram: &mut [f64]) {
        let nc = n_coefficients(self.harmonics);
        let n = self.len() as f64;
        let b = &self.basis[j];
        for m in 0..nc {
            let f = weight(m) * b[m] / n;
            for c in 0..nc {
                gram[m * nc + c] += f * b[c];
            }
        }
    }

    /// Values at sample `j` of `n` signals whose coefficients are harmonic-major
    /// (`coefficients[c·n + i]`), written into `out` (`n`): one sample of the inverse DFT,
    /// `q(τ_j) = (b(τ_j) ⊗ I) q̂`.
    pub fn synthesize_into(&self, j: usize, coefficients: &[f64], n: usize, out: &mut [f64]) {
        out[..n].iter_mut().for_each(|v| *v = 0.0);
        for (c, &b) in self.basis[j].iter().enumerate() {
            if b != 0.0 {
                for (o, &q) in out[..n].iter_mut().zip(&coefficients[c * n..(c + 1) * n]) {
                    *o += b * q;
                }
            }
        }
    }

    /// Fourier coefficients, harmonic-major (`c·n + i`), of `n` signals sampled at every
    /// `τ_j` (`samples[j·n + i]`): the DFT (docs/theory.md (T8), (T10)) for a set of DOFs.
    pub fn dft_set(&self, samples: &[f64], n: usize) -> Vec<f64> {
        let ns = self.len() as f64;
        let mut out = vec![0.0; n * n_coefficients(self.harmonics)];
        for (j, b) in self.basis.iter().enumerate() {
            let row = &samples[j * n..(j + 1) * n];
            if row.iter().all(|&v| v == 0.0) {
                continue;
            }
            if n == 1 {
                let v = row[0];
                for (o, &bm) in out.iter_mut().zip(b) {
                    *o += bm * v;
                }
                continue;
            }
            for (m, &bm) in b.iter().enumerate() {
                for (o, &v) in out[m * n..(m + 1) * n].iter_mut().zip(row) {
                    *o += bm * v;
                }
            }
        }
        // the weights of (T10), applied once per coefficient
        for (m, chunk) in out.chunks_exact_mut(n.max(1)).enumerate() {
            let f = weight(m) / ns;
            chunk.iter_mut().for_each(|o| *o *= f);
        }
        out
    }
}

/// The maximum (`sign = 1`) or minimum (`sign = −1`) over one period of the trigonometric
/// polynomial with coefficients `coef`: the best of `samples` equidistant values, refined
/// by golden-section search on the bracket around it.
pub fn polynomial_extremum(coef: &[f64], samples: usize, sign: f64) -> f64 {
    let samples = samples.max(8);
    let step = 2.0 * PI / samples as f64;
    let (mut best_tau, mut best) = (0.0, f64::NEG_INFINITY);
    for j in 0..samples {
        let tau = j as f64 * step;
        let v = sign * evaluate(coef, tau);
        if v > best {
            (best_tau, best) = (tau, v);
        }
    }
    let refined = golden_section_max(
        |t| sign * evaluate(coef, t),
        best_tau - step,
        best_tau + step,
    );
    sign * best.max(refined)
}

/// How Fourier coefficients of a nonsmooth periodic signal (the contact displacement of the
/// redistributed MS-HBM, paper eqs. 33–35, or the penalty force of HBM-AFT) are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quadrature {
    /// Closed-form integrals between located switching times.
    Exact,
    /// DFT over equidistant samples.
    Sampled,
}

impl Quadrature {
    pub fn name(self) -> &'static str {
        match self {
            Quadrature::Exact => "exact",
            Quadrature::Sampled => "sampled",
        }
    }
}

impl std::fmt::Display for Quadrature {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Golden-section search for a maximum of `f` in the bracket `[a, d]` (60 reductions of the
/// bracket, to `0.618⁶⁰` of its width): the larger of the two final interior values.
pub(crate) fn golden_section_max(f: impl FnMut(f64) -> f64, a: f64, d: f64) -> f64 {
    golden_section_argmax(f, a, d).1
}

/// [`golden_section_max`] with where it is: `(t, f(t))`, `t` the final interior point with
/// the larger value.
pub(crate) fn golden_section_argmax(
    mut f: impl FnMut(f64) -> f64,
    mut a: f64,
    mut d: f64,
) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut b, mut c) = (d - g * (d - a), a + g * (d - a));
    let (mut fb, mut fc) = (f(b), f(c));
    for _ in 0..60 {
        if fb > fc {
            d = c;
            c = b;
            fc = fb;
            b = d - g * (d - a);
            fb = f(b);
        } else {
            a = b;
            b = c;
            fb = fc;
            c = a + g * (d - a);
            fc = f(c);
        }
    }
    if fb > fc {
        (b, fb)
    } else {
        (c, fc)
    }
}

/// Add the exact Gram block of the interval `[a, b]` (`Γ_mc += w_m/(2π) ∫_a^b b_m b_c dτ`,
/// row-major) to `gram` — the closed-form Fourier integrals of eqs. (33)–(35).
pub fn add_interval_gram(harmonics: usize, a: f64, b: f64, gram: &mut [f64]) {
    let h = harmonics;
    let nc = n_coefficients(h);
    // ∫ cos pτ and ∫ sin pτ over [a, b] for p = 0..2H, the multiples of a and b by the
    // angle-addition recurrence (two sin_cos instead of 4H)
    let mut ic = [0.0; 2 * MAX_RECURRENCE_HARMONICS + 1];
    let mut is = [0.0; 2 * MAX_RECURRENCE_HARMONICS + 1];
    let (mut ic_heap, mut is_heap);
    let (ic, is): (&mut [f64], &mut [f64]) = if h <= MAX_RECURRENCE_HARMONICS {
        (&mut ic[..2 * h + 1], &mut is[..2 * h + 1])
    } else {
        ic_heap = vec![0.0; 2 * h + 1];
        is_heap = vec![0.0; 2 * h + 1];
        (&mut ic_heap, &mut is_heap)
    };
    ic[0] = b - a;
    let (mut at_a, mut at_b) = (Rotation::new(a), Rotation::new(b));
    for p in 1..=2 * h {
        let pf = p as f64;
        let (ca, sa) = at_a.next();
        let (cb, sb) = at_b.next();
        ic[p] = (sb - sa) / pf;
        is[p] = (ca - cb) / pf;
    }
    // ∫ sin pτ for a signed p
    let int_sin = |p: isize| {
        if p >= 0 {
            is[p as usize]
        } else {
            -is[(-p) as usize]
        }
    };
    let mean = 1.0 / (2.0 * PI);
    let twice = 2.0 / (2.0 * PI);
    // the mean's row and column: ∫ 1, ∫ cos lτ, ∫ sin lτ
    gram[0] += mean * ic[0];
    for l in 1..=h {
        gram[2 * l - 1] += mean * ic[l];
        gram[2 * l] += mean * is[l];
        gram[(2 * l - 1) * nc] += twice * ic[l];
        gram[2 * l * nc] += twice * is[l];
    }
    // cos kτ cos lτ = ½[cos (k−l)τ + cos (k+l)τ], sin kτ sin lτ = ½[cos (k−l)τ − cos (k+l)τ],
    // cos kτ sin lτ = ½[sin (k+l)τ − sin (k−l)τ]
    for k in 1..=h {
        let (row_c, row_s) = ((2 * k - 1) * nc, 2 * k * nc);
        for l in 1..=h {
            let (ki, li) = (k as isize, l as isize);
            let difference = ic[k.abs_diff(l)];
            let sum = ic[k + l];
            let sin_sum = is[k + l];
            gram[row_c + 2 * l - 1] += twice * 0.5 * (difference + sum);
            gram[row_s + 2 * l] += twice * 0.5 * (difference - sum);
            gram[row_c + 2 * l] += twice * 0.5 * (sin_sum - int_sin(ki - li));
            gram[row_s + 2 * l - 1] += twice * 0.5 * (sin_sum - int_sin(li - ki));
        }
    }
}

/// Harmonics up to which [`add_interval_gram`] keeps its integrals on the stack.
const MAX_RECURRENCE_HARMONICS: usize = 64;

#[cfg(test)]
mod tests {
    use super::*;

    /// Padding keeps every signal's values at every instant (the added harmonics are zero);
    /// truncating keeps its lower harmonics; a length that is no whole number of blocks is
    /// refused.
    #[test]
    fn changing_the_number_of_harmonics_keeps_the_signals() {
        // two signals (n = 2), H = 2, harmonic-major: coefficient c of signal i at 2c + i
        let x: Vec<f64> = (0..10).map(|k| 0.3 * k as f64 - 1.0).collect();
        let signal = |x: &[f64], h: usize, i: usize| -> Vec<f64> {
            (0..n_coefficients(h)).map(|c| x[2 * c + i]).collect()
        };
        let padded = with_harmonics(&x, 2, 5).unwrap();
        assert_eq!(padded.len(), 2 * 11);
        for i in 0..2 {
            for tau in [0.0, 0.7, 2.9, 5.5] {
                let a = evaluate(&signal(&x, 2, i), tau);
                let b = evaluate(&signal(&padded, 5, i), tau);
                assert!((a - b).abs() < 1e-14, "{a} vs {b}");
            }
        }
        let truncated = with_harmonics(&x, 2, 1).unwrap();
        assert_eq!(truncated, x[..6].to_vec());
        assert_eq!(with_harmonics(&x[..9], 2, 3), None);
    }

    #[test]
    fn dft_inverts_synthesis() {
        let h = 4;
        let s = Sampling::new(h, 2 * h + 1);
        let coef: Vec<f64> = (0..2 * h + 1)
            .map(|i| (i as f64 * 0.37).sin() + 0.1)
            .collect();
        let samples: Vec<f64> = s.taus.iter().map(|&t| evaluate(&coef, t)).collect();
        let back = s.dft(&samples);
        for (a, b) in coef.iter().zip(&back) {
            assert!((a - b).abs() < 1e-13);
        }
    }

    #[test]
    fn set_transforms_invert_each_other_and_extrema_are_refined() {
        let (h, n) = (3, 2);
        let s = Sampling::new(h, 64);
        let coef: Vec<f64> = (0..n * n_coefficients(h))
            .map(|i| (i as f64 * 0.71).cos())
            .collect();
        let mut samples = vec![0.0; s.len() * n];
        for j in 0..s.len() {
            s.synthesize_into(j, &coef, n, &mut samples[j * n..(j + 1) * n]);
        }
        let back = s.dft_set(&samples, n);
        assert!(coef.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-13));
        let scalar: Vec<f64> = (0..n_coefficients(h)).map(|c| coef[c * n + 1]).collect();
        let fine = (0..200_000)
            .map(|j| evaluate(&scalar, 2.0 * PI * j as f64 / 200_000.0))
            .fold(f64::NEG_INFINITY, f64::max);
        let max = polynomial_extremum(&scalar, 16, 1.0);
        assert!(
            (max - fine).abs() < 1e-9 && max >= fine - 1e-15,
            "{max} vs {fine}"
        );
    }

    #[test]
    fn interval_grams_sum_to_identity_and_match_quadrature() {
        // 20: the recurrence re-anchors at 16; 70: the integrals beyond the stack's
        for h in [3, 10, 20, 70] {
            interval_grams_for(h, h <= 20);
        }
    }

    fn interval_grams_for(h: usize, against_quadrature: bool) {
        let nc = n_coefficients(h);
        // over the whole period the Gram matrix is the identity (orthogonality)
        let mut full = vec![0.0; nc * nc];
        add_interval_gram(h, 0.3, 0.3 + 2.0 * PI, &mut full);
        for m in 0..nc {
            for c in 0..nc {
                let e = if m == c { 1.0 } else { 0.0 };
                assert!(
                    (full[m * nc + c] - e).abs() < 1e-13,
                    "({m},{c}) {}",
                    full[m * nc + c]
                );
            }
        }
        if !against_quadrature {
            return;
        }
        // on a sub-interval, compare with a fine midpoint rule
        let (a, b) = (0.4, 1.9);
        let mut exact = vec![0.0; nc * nc];
        add_interval_gram(h, a, b, &mut exact);
        let n = 20_000 * (1 + h / 5);
        let mut approx = vec![0.0; nc * nc];
        for j in 0..n {
            let t = a + (j as f64 + 0.5) * (b - a) / n as f64;
            let bt = basis(h, t);
            for m in 0..nc {
                for c in 0..nc {
                    approx[m * nc + c] +=
                        weight(m) / (2.0 * PI) * bt[m] * bt[c] * (b - a) / n as f64;
                }
            }
        }
        for (x, y) in exact.iter().zip(&approx) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
    }
}
