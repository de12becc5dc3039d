//! The affine solution of one set of contact modes and its validity indicators
//! (docs/theory.md (T152), (T153)).

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use faer::Mat;

use super::{FrictionalContacts, Mode};
use crate::dense::solve_small_lu_columns;
use crate::error::{Error, Result};

/// What an indicator of a mode measures; its first root ends the mode (T153).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
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

#[derive(Clone, Debug)]
pub(super) struct Indicator {
    pub(super) contact: usize,
    pub(super) kind: Kind,
    /// `h = κᵀ γ(τ) + θᵀ a`, or `κᵀ γ̇(τ)` for a velocity.
    pub(super) kappa: Vec<f64>,
    pub(super) theta: Vec<f64>,
}

/// The affine solution of one set of modes (T152): `λ = F γ + G a`, `y = Y_F γ + Y_G a`.
#[derive(Clone, Debug)]
pub(super) struct ModeData {
    /// `m × m`, `m × n`, `m × m`, `m × n`, row-major.
    pub(super) f: Vec<f64>,
    pub(super) g: Vec<f64>,
    pub(super) yf: Vec<f64>,
    pub(super) yg: Vec<f64>,
    pub(super) indicators: Vec<Indicator>,
}

impl ModeData {
    /// The bytes it holds.
    pub(super) fn bytes(&self) -> usize {
        let indicators: usize = self
            .indicators
            .iter()
            .map(|i| i.kappa.len() + i.theta.len())
            .sum();
        8 * (self.f.len() + self.g.len() + self.yf.len() + self.yg.len() + indicators)
    }
}

/// The sets of modes met by earlier marches, kept between evaluations: a set's data depend on
/// the modes alone (and the Delassus matrix and `μ`), and along Newton and a continuation
/// the marches meet the same sets again.
#[derive(Clone, Debug, Default)]
pub(super) struct ModeCache {
    pub(super) data: Vec<ModeData>,
    pub(super) index: std::collections::HashMap<Vec<Mode>, usize>,
}

/// At most this many bytes of [`ModeCache`] are carried into a march (it is emptied first
/// when it holds more).
pub const MODE_CACHE_BYTES: usize = 64 << 20;

impl ModeCache {
    pub(super) fn bytes(&self) -> usize {
        self.data.iter().map(ModeData::bytes).sum()
    }
}

impl FrictionalContacts {
    /// The affine solution and the indicators of one set of modes (T152), (T153).
    pub(super) fn mode_data(&self, modes: &[Mode]) -> Result<ModeData> {
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
}
