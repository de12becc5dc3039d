//! Floquet multipliers of frictional solutions of the redistributed MS-HBM (docs/theory.md
//! (T182)–(T184)) against independent references: the frictionless analysis (μ = 0), the
//! period map of an exact event-driven integration of a mass on a Jenkins element, and
//! time integration started from the orbit on the friction damper.

mod common;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use faer::{c64, Mat};
use mshbm::model::{Contact, ContactFriction, Damping, Model};
use mshbm::newton::{solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::sparse::SparseMatrix;
use mshbm::stability::StabilityOptions;

use common::{hz, ms_hbm};

/// The largest distance from a multiplier of `a` to the nearest of `b`, both ways.
fn spectral_distance(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let one_way = |a: &[[f64; 2]], b: &[[f64; 2]]| {
        a.iter().fold(0.0f64, |worst, x| {
            let d = b
                .iter()
                .map(|y| (x[0] - y[0]).hypot(x[1] - y[1]))
                .fold(f64::INFINITY, f64::min);
            worst.max(d)
        })
    };
    one_way(a, b).max(one_way(b, a))
}

/// With `μ = 0` every closed contact slips freely and no anchor is held: the frictional
/// analysis (P and Q from the law's force maps, (T182)) must give the frictionless
/// multipliers (T80)–(T82), in the full space and in a reduced basis.
#[test]
fn without_friction_coefficient_the_multipliers_are_the_frictionless_ones() {
    let (with, without) = (
        common::friction_damper(Some(0.0), &[]),
        common::friction_damper(None, &[]),
    );
    let tight = NewtonOptions {
        tolerance: 1e-12,
        ..NewtonOptions::default()
    };
    for (f, modes) in [(300.0, None), (800.0, None), (800.0, Some(20))] {
        let mut a = ms_hbm(&with, 5);
        let mut b = ms_hbm(&without, 5);
        for p in [&mut a, &mut b] {
            p.set_stability_options(StabilityOptions { modes }).unwrap();
        }
        let (_, oa) = solve_at_frequency(&mut a, hz(f), 209, &tight).unwrap();
        let (_, ob) = solve_at_frequency(&mut b, hz(f), 209, &tight).unwrap();
        assert!(oa.converged && ob.converged);
        let fa = a.floquet(&oa.x, hz(f)).unwrap().unwrap();
        let fb = b.floquet(&ob.x, hz(f)).unwrap().unwrap();
        let d = spectral_distance(&fa.multipliers, &fb.multipliers);
        println!(
            "{f} Hz, modes {modes:?}: {} multipliers, largest {:.6} against {:.6}, distance {d:.2e}",
            fa.multipliers.len(),
            fa.max_multiplier,
            fb.max_multiplier
        );
        assert_eq!(fa.multipliers.len(), fb.multipliers.len());
        assert!(d <= 1e-8, "{f} Hz: the spectra differ by {d:e}");
        assert_eq!(fa.stable, fb.stable);
    }
}

/// A mass `m` on a spring `k` to ground, joined by a spring `k_c` to a massless node pressed
/// by `p` on a rigid plane with friction `μ` (a Jenkins element of limit `μ p` in series with
/// `k_c`), forced by `F cos ωt`, mass-proportional damping `α`. DOFs: the mass, the node's
/// normal, the node's tangent.
fn jenkins_oscillator(m: f64, k: f64, k_c: f64, p: f64, mu: f64, force: f64, alpha: f64) -> Model {
    Model {
        stiffness_file: None,
        source: PathBuf::from("jenkins oscillator"),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: "jenkins oscillator".into(),
        mass: SparseMatrix::from_triplets(3, 3, &[(0, 0, m)]),
        stiffness: SparseMatrix::from_triplets(
            3,
            3,
            &[
                (0, 0, k + k_c),
                (0, 2, -k_c),
                (2, 0, -k_c),
                (2, 2, k_c),
                (1, 1, 10.0 * k_c),
            ],
        ),
        damping_matrix: None,
        coordinates: vec![vec![0.0], vec![1.0], vec![2.0]],
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts: vec![Contact {
            dofs: vec![1],
            w: vec![-1.0],
            gap: 0.0,
            friction: Some(ContactFriction {
                dofs: vec![2],
                w: vec![1.0],
                mu,
                second: None,
            }),
        }],
        harmonic_load: vec![force, 0.0, 0.0],
        constant_load: vec![0.0, p, 0.0],
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha,
            ..Damping::default()
        },
    }
}

/// The mass on a Jenkins element integrated exactly up to round-off: RK4 on 4000 steps per
/// period within each stick or slip phase, and every switch located by bisection of the
/// step (stick ends where the spring force reaches `±L`, slip where the velocity vanishes).
/// State `(x, v, s)`, `s` the slider (the node's tangential position).
struct ExactJenkins {
    m: f64,
    k: f64,
    k_c: f64,
    limit: f64,
    force: f64,
    alpha: f64,
    omega: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Slider {
    Stick,
    /// Slipping with the spring force at `+L` (sign 1) or `−L` (sign −1).
    Slip(f64),
}

impl ExactJenkins {
    fn acceleration(&self, t: f64, x: f64, v: f64, s: f64, mode: Slider) -> f64 {
        let spring = match mode {
            Slider::Stick => self.k_c * (x - s),
            Slider::Slip(sign) => sign * self.limit,
        };
        (self.force * (self.omega * t).cos() - self.alpha * self.m * v - self.k * x - spring)
            / self.m
    }

    fn rk4(&self, t: f64, y: [f64; 2], s: f64, mode: Slider, h: f64) -> [f64; 2] {
        let f = |t: f64, y: [f64; 2]| [y[1], self.acceleration(t, y[0], y[1], s, mode)];
        let k1 = f(t, y);
        let k2 = f(
            t + h / 2.0,
            [y[0] + h / 2.0 * k1[0], y[1] + h / 2.0 * k1[1]],
        );
        let k3 = f(
            t + h / 2.0,
            [y[0] + h / 2.0 * k2[0], y[1] + h / 2.0 * k2[1]],
        );
        let k4 = f(t + h, [y[0] + h * k3[0], y[1] + h * k3[1]]);
        [
            y[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            y[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
        ]
    }

    /// The switching function of `mode` (positive while it holds) and the next mode.
    fn switch(&self, y: [f64; 2], s: f64, mode: Slider) -> (f64, Slider) {
        match mode {
            Slider::Stick => {
                let f = self.k_c * (y[0] - s);
                if f >= 0.0 {
                    (self.limit - f, Slider::Slip(1.0))
                } else {
                    (self.limit + f, Slider::Slip(-1.0))
                }
            }
            Slider::Slip(sign) => (sign * y[1], Slider::Stick),
        }
    }

    /// From `(x, v, s)` in `mode` at `t0`, over one period: the state and mode at the end.
    fn period(&self, t0: f64, state: [f64; 3], mode: Slider) -> ([f64; 3], Slider) {
        self.run_for(t0, state, mode, 2.0 * PI / self.omega)
    }

    /// From `(x, v, s)` in `mode` at `t0`, over `duration`.
    fn run_for(&self, t0: f64, state: [f64; 3], mode: Slider, duration: f64) -> ([f64; 3], Slider) {
        let period = 2.0 * PI / self.omega;
        let h = period / 4000.0;
        let (mut t, mut y, mut s, mut mode) = (t0, [state[0], state[1]], state[2], mode);
        let end = t0 + duration;
        while t < end - 1e-15 * period {
            let step = h.min(end - t);
            let next = self.rk4(t, y, s, mode, step);
            let (g1, to) = self.switch(next, s, mode);
            if g1 >= 0.0 {
                t += step;
                y = next;
                continue;
            }
            // bisection of the step for the switch
            let (mut lo, mut hi) = (0.0, step);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                let (g, _) = self.switch(self.rk4(t, y, s, mode, mid), s, mode);
                if g >= 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            y = self.rk4(t, y, s, mode, hi);
            t += hi;
            s = match to {
                // the slider stops where it is
                Slider::Stick => {
                    y[0] - match mode {
                        Slider::Slip(sign) => sign * self.limit / self.k_c,
                        Slider::Stick => unreachable!(),
                    }
                }
                Slider::Slip(_) => s,
            };
            mode = to;
        }
        if let Slider::Slip(sign) = mode {
            s = y[0] - sign * self.limit / self.k_c;
        }
        ([y[0], y[1], s], mode)
    }
}

/// The mass on a Jenkins element: the frictional multipliers (T182)–(T184) against the
/// period map of the exact integration, differentiated by central differences at the
/// periodic orbit, at a section where the slider sticks (the nonzero multipliers do not
/// depend on the section). The MS-HBM's are those of the truncated orbit; they converge to
/// the exact ones as H grows.
#[test]
fn a_mass_on_a_jenkins_element_has_the_multipliers_of_its_exact_period_map() {
    let (m, k, k_c, p, mu, force, alpha) = (1.0, 1.0, 3.0, 1.0, 0.3, 0.5, 0.1);
    let omega = 1.5;
    let exact = ExactJenkins {
        m,
        k,
        k_c,
        limit: mu * p,
        force,
        alpha,
        omega,
    };
    // the periodic orbit: simulated from rest until it repeats to round-off
    let (mut state, mut mode) = ([0.0; 3], Slider::Stick);
    let mut change = f64::INFINITY;
    for _ in 0..400 {
        let (next, next_mode) = exact.period(0.0, state, mode);
        change = (0..3)
            .map(|i| (next[i] - state[i]).abs())
            .fold(0.0, f64::max);
        state = next;
        mode = next_mode;
        if change < 1e-13 {
            break;
        }
    }
    assert!(change < 1e-12, "not periodic: {change:e}");
    // a section inside a stick phase: march in 1/64 of the period until stuck
    let period = 2.0 * PI / omega;
    let mut t0 = 0.0;
    for _ in 0..64 {
        if mode == Slider::Stick {
            break;
        }
        (state, mode) = exact.run_for(t0, state, mode, period / 64.0);
        t0 += period / 64.0;
    }
    assert_eq!(mode, Slider::Stick);
    // central differences of the period map from the section
    let scale = [1e-6, 1e-6 * omega, 1e-6];
    let mut jac = Mat::<f64>::zeros(3, 3);
    for j in 0..3 {
        let mut plus = state;
        let mut minus = state;
        plus[j] += scale[j];
        minus[j] -= scale[j];
        let (a, ma) = exact.period(t0, plus, Slider::Stick);
        let (b, mb) = exact.period(t0, minus, Slider::Stick);
        assert_eq!((ma, mb), (Slider::Stick, Slider::Stick));
        for i in 0..3 {
            jac[(i, j)] = (a[i] - b[i]) / (2.0 * scale[j]);
        }
    }
    let reference: Vec<[f64; 2]> = jac
        .eigenvalues()
        .unwrap()
        .iter()
        .map(|z: &c64| [z.re, z.im])
        .filter(|z| z[0].hypot(z[1]) > 1e-6)
        .collect();
    println!("exact period map's nonzero multipliers: {reference:?}");
    assert_eq!(reference.len(), 2);

    let model = jenkins_oscillator(m, k, k_c, p, mu, force, alpha);
    let mut errors = Vec::new();
    for harmonics in [10, 40] {
        let mut method = ms_hbm(&model, harmonics);
        let (_, out) =
            solve_at_frequency(&mut method, omega, 0, &NewtonOptions::default()).unwrap();
        assert!(out.converged, "H = {harmonics}: {:?}", out.reason);
        let floquet = method.floquet(&out.x, omega).unwrap().unwrap();
        let nonzero: Vec<[f64; 2]> = floquet
            .multipliers
            .iter()
            .copied()
            .filter(|z| z[0].hypot(z[1]) > 1e-6)
            .collect();
        let d = spectral_distance(&nonzero, &reference);
        println!(
            "H = {harmonics}: multipliers {:?}, distance to the exact ones {d:.2e}",
            floquet.multipliers
        );
        assert_eq!(
            nonzero.len(),
            2,
            "H = {harmonics}: {:?}",
            floquet.multipliers
        );
        errors.push(d);
    }
    assert!(errors[1] < errors[0], "no convergence in H: {errors:?}");
    assert!(errors[1] <= 1e-3, "H = 40: {:e}", errors[1]);
}

/// Time integration started from the orbit (T174), the position-level scheme with friction
/// (T170)–(T175), `periods` periods at 2048 steps: the relative period-to-period change of
/// the state, period by period.
fn simulated_changes(
    model: &Model,
    omega: f64,
    harmonics: usize,
    periods: usize,
) -> (bool, f64, Vec<f64>) {
    use mshbm::integrate::steady_state::{
        simulate_to_steady_state, Periodicity, SteadyStateOptions,
    };
    use mshbm::integrate::{Integrator, Scheme, Settings};
    use mshbm::simulation::state_from_solution;
    use mshbm::MassKind;
    let system = model.system(MassKind::Redistributed).unwrap();
    let mut method = ms_hbm(model, harmonics);
    let (sol, out) =
        solve_at_frequency(&mut method, omega, 209, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let floquet = method.floquet(&out.x, omega).unwrap().unwrap();
    let (q0, v0) = state_from_solution(&system, model, &sol, omega, Path::new("ms-hbm")).unwrap();
    let steps = 2048;
    let mut it = Integrator::new(
        &system,
        &Settings {
            dt: 2.0 * PI / omega / steps as f64,
            scheme: Scheme::PositionNewmark,
            omega: Some(omega),
            energy_offset: 0.0,
        },
    )
    .unwrap();
    it.set_state(0.0, &q0, &v0).unwrap();
    let steady = simulate_to_steady_state(
        &mut it,
        omega,
        &SteadyStateOptions {
            steps_per_period: steps,
            max_periods: periods,
            tolerance: 1e-300,
            harmonics: 10,
            response_dof: 209,
            periodicity: Periodicity::State,
        },
        |_| {},
        |_, _| {},
    )
    .unwrap();
    (
        floquet.stable,
        floquet.max_multiplier,
        steady.period_change_history,
    )
}

/// Issue 40's acceptance for stability: the verdicts of the frictional multipliers agree
/// with time integration started from the orbit on the friction damper at 640 Hz, near its
/// friction-damped resonance (H = 20). With stiffness-proportional damping on the linear
/// block the orbit is stable and the simulation stays on it (its period-to-period change
/// falls); with the example's mass-proportional damping alone the largest multiplier is a
/// complex pair of modulus ~1.9 (a Neimark–Sacker instability: lightly damped high modes
/// driven by the tip face's switching) and the simulation leaves the orbit (the change
/// grows by orders of magnitude and never settles), as docs/theory.md (T175) found.
#[test]
fn the_verdicts_agree_with_time_integration_on_the_friction_damper() {
    let omega = hz(640.0);
    let (stable, largest, changes) = simulated_changes(
        &common::friction_damper(Some(0.1), &["damping.beta_linear=1e-7"]),
        omega,
        20,
        30,
    );
    println!(
        "damped: stable {stable}, largest {largest:.4}, changes {:?}",
        changes
            .iter()
            .map(|c| format!("{c:.1e}"))
            .collect::<Vec<_>>()
    );
    let (unstable_verdict, largest_u, changes_u) =
        simulated_changes(&common::friction_damper(Some(0.1), &[]), omega, 20, 30);
    println!(
        "undamped: stable {unstable_verdict}, largest {largest_u:.4}, changes {:?}",
        changes_u
            .iter()
            .map(|c| format!("{c:.1e}"))
            .collect::<Vec<_>>()
    );
    assert!(stable && largest < 0.5);
    // the simulation settles on the orbit (to the round-off of its state) within 30 periods
    let last = changes[changes.len() - 5..]
        .iter()
        .fold(0.0f64, |m, c| m.max(*c));
    assert!(last <= 1e-9, "stable orbit left: {last:e}");
    assert!(!unstable_verdict && largest_u > 1.2);
    // the simulation started on the unstable orbit never settles
    let least = changes_u[5..].iter().fold(f64::INFINITY, |m, c| m.min(*c));
    assert!(least >= 1e-2, "unstable orbit kept: {least:e}");
}

/// A mass with two DOFs `(x, y)` on springs `k_x`, `k_y` to ground (coupled by `K_xy = k_x/4`,
/// so that the normal motion feels the tangential one), joined by springs `k_c`
/// along both to a massless node that hits a rigid stop after a gap `g` (in `y`) with friction
/// `μ` (along `x`), forced by `(F_x, F_y) cos ωt`, mass-proportional damping `α`. DOFs: the
/// mass's `x`, `y`, the node's `x`, `y`. Each period the node closes (and sticks at once:
/// the anchor of a closing contact, with its instant's sensitivity), slips as the cone
/// shrinks, and opens.
#[allow(clippy::too_many_arguments)]
fn stop_oscillator(
    k_x: f64,
    k_y: f64,
    k_c: f64,
    gap: f64,
    mu: f64,
    force: [f64; 2],
    alpha: f64,
) -> Model {
    Model {
        stiffness_file: None,
        source: PathBuf::from("stop oscillator"),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: "stop oscillator".into(),
        mass: SparseMatrix::from_triplets(4, 4, &[(0, 0, 1.0), (1, 1, 1.0)]),
        stiffness: SparseMatrix::from_triplets(
            4,
            4,
            &[
                (0, 0, k_x + k_c),
                (0, 2, -k_c),
                (2, 0, -k_c),
                (2, 2, k_c),
                (1, 1, k_y + k_c),
                (0, 1, 0.25 * k_x),
                (1, 0, 0.25 * k_x),
                (1, 3, -k_c),
                (3, 1, -k_c),
                (3, 3, k_c),
            ],
        ),
        damping_matrix: None,
        coordinates: vec![vec![0.0], vec![1.0], vec![2.0], vec![3.0]],
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts: vec![Contact {
            dofs: vec![3],
            w: vec![-1.0],
            gap,
            friction: Some(ContactFriction {
                dofs: vec![2],
                w: vec![1.0],
                mu,
                second: None,
            }),
        }],
        harmonic_load: vec![force[0], force[1], 0.0, 0.0],
        constant_load: vec![0.0; 4],
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha,
            ..Damping::default()
        },
    }
}

/// The stop oscillator integrated exactly up to round-off (RK4 within each phase, switches
/// by bisection). State `(x, ẋ, y, ẏ)` and the slider `s` (the node's `x` while stuck).
struct ExactStop {
    k: [f64; 2],
    k_c: f64,
    gap: f64,
    mu: f64,
    force: [f64; 2],
    alpha: f64,
    omega: f64,
}

impl ExactStop {
    fn derivative(&self, t: f64, y: [f64; 4], s: f64, mode: Mode2) -> [f64; 4] {
        let c = (self.omega * t).cos();
        let k_xy = 0.25 * self.k[0];
        let mut ax = self.force[0] * c - self.alpha * y[1] - self.k[0] * y[0] - k_xy * y[2];
        let mut ay = self.force[1] * c - self.alpha * y[3] - self.k[1] * y[2] - k_xy * y[0];
        let normal = self.k_c * (y[2] - self.gap);
        match mode {
            Mode2::Open => {}
            Mode2::Stick => {
                ax -= self.k_c * (y[0] - s);
                ay -= normal;
            }
            Mode2::Slip(sign) => {
                ax -= sign * self.mu * normal;
                ay -= normal;
            }
        }
        [y[1], ax, y[3], ay]
    }

    fn rk4(&self, t: f64, y: [f64; 4], s: f64, mode: Mode2, h: f64) -> [f64; 4] {
        let add = |a: [f64; 4], b: [f64; 4], f: f64| {
            [
                a[0] + f * b[0],
                a[1] + f * b[1],
                a[2] + f * b[2],
                a[3] + f * b[3],
            ]
        };
        let k1 = self.derivative(t, y, s, mode);
        let k2 = self.derivative(t + h / 2.0, add(y, k1, h / 2.0), s, mode);
        let k3 = self.derivative(t + h / 2.0, add(y, k2, h / 2.0), s, mode);
        let k4 = self.derivative(t + h, add(y, k3, h), s, mode);
        let mut out = y;
        for i in 0..4 {
            out[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        out
    }

    /// The switching function of `mode` (positive while it holds) and the mode after its root.
    fn switch(&self, y: [f64; 4], s: f64, mode: Mode2) -> (f64, Mode2) {
        let pen = y[2] - self.gap;
        match mode {
            Mode2::Open => (-pen, Mode2::Stick),
            Mode2::Stick => {
                let upper = self.mu * pen - (y[0] - s);
                let lower = self.mu * pen + (y[0] - s);
                [
                    (pen, Mode2::Open),
                    (upper, Mode2::Slip(1.0)),
                    (lower, Mode2::Slip(-1.0)),
                ]
                .into_iter()
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap()
            }
            Mode2::Slip(sign) => {
                let node_velocity = y[1] - sign * self.mu * y[3];
                if pen < sign * node_velocity {
                    (pen, Mode2::Open)
                } else {
                    (sign * node_velocity, Mode2::Stick)
                }
            }
        }
    }

    /// From `(x, ẋ, y, ẏ)`, slider `s`, in `mode` at `t0`, over `duration`.
    fn run_for(
        &self,
        t0: f64,
        y0: [f64; 4],
        s0: f64,
        mode: Mode2,
        duration: f64,
    ) -> ([f64; 4], f64, Mode2) {
        let h = 2.0 * PI / self.omega / 4000.0;
        let (mut t, mut y, mut s, mut mode) = (t0, y0, s0, mode);
        let end = t0 + duration;
        while t < end - 1e-12 * h {
            let step = h.min(end - t);
            let next = self.rk4(t, y, s, mode, step);
            let (g, _) = self.switch(next, s, mode);
            if g >= 0.0 {
                t += step;
                y = next;
                continue;
            }
            let (mut lo, mut hi) = (0.0, step);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if self.switch(self.rk4(t, y, s, mode, mid), s, mode).0 >= 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            y = self.rk4(t, y, s, mode, hi);
            t += hi;
            let (_, to) = self.switch(y, s, mode);
            (s, mode) = match (mode, to) {
                // closing: stuck where the node is (it followed the mass), unless the cone
                // cannot hold the tangential velocity
                (Mode2::Open, _) => {
                    if y[1].abs() <= self.mu * y[3] {
                        (y[0], Mode2::Stick)
                    } else {
                        (s, Mode2::Slip(y[1].signum()))
                    }
                }
                (Mode2::Slip(sign), Mode2::Stick) => {
                    (y[0] - sign * self.mu * (y[2] - self.gap), Mode2::Stick)
                }
                (_, to) => (s, to),
            };
        }
        (y, s, mode)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode2 {
    Open,
    Stick,
    Slip(f64),
}

/// The stop oscillator: lift-off, closing into stick (the anchor's instant sensitivity of
/// (T183)), slip and opening every period; the frictional multipliers against the exact
/// period map differentiated by central differences at a section where the node is open.
#[test]
fn a_frictional_stop_has_the_multipliers_of_its_exact_period_map() {
    let (k, k_c, gap, mu, force, alpha, omega) = ([2.0, 1.0], 3.0, 0.2, 0.5, [0.15, 0.3], 0.1, 1.1);
    let exact = ExactStop {
        k,
        k_c,
        gap,
        mu,
        force,
        alpha,
        omega,
    };
    let period = 2.0 * PI / omega;
    let (mut y, mut s, mut mode) = ([0.0; 4], 0.0, Mode2::Open);
    let mut change = f64::INFINITY;
    for _ in 0..600 {
        let (next, ns, nm) = exact.run_for(0.0, y, s, mode, period);
        change = (0..4).map(|i| (next[i] - y[i]).abs()).fold(0.0, f64::max);
        (y, s, mode) = (next, ns, nm);
        if change < 1e-13 {
            break;
        }
    }
    assert!(change < 1e-12, "not periodic: {change:e}");
    // the modes met in one period, and a section where the node is open
    let mut t0 = 0.0;
    let mut seen = Vec::new();
    for _ in 0..256 {
        if !seen.contains(&mode) {
            seen.push(mode);
        }
        (y, s, mode) = exact.run_for(t0, y, s, mode, period / 256.0);
        t0 += period / 256.0;
    }
    println!("modes met: {seen:?}");
    assert!(
        seen.contains(&Mode2::Open)
            && seen.contains(&Mode2::Stick)
            && seen.iter().any(|m| matches!(m, Mode2::Slip(_))),
        "the orbit should open, stick and slip: {seen:?}"
    );
    for _ in 0..256 {
        if mode == Mode2::Open {
            break;
        }
        (y, s, mode) = exact.run_for(t0, y, s, mode, period / 256.0);
        t0 += period / 256.0;
    }
    assert_eq!(mode, Mode2::Open);
    let mut jac = Mat::<f64>::zeros(4, 4);
    for j in 0..4 {
        let (mut plus, mut minus) = (y, y);
        plus[j] += 1e-7;
        minus[j] -= 1e-7;
        let (a, _, ma) = exact.run_for(t0, plus, s, Mode2::Open, period);
        let (b, _, mb) = exact.run_for(t0, minus, s, Mode2::Open, period);
        assert_eq!((ma, mb), (Mode2::Open, Mode2::Open));
        for i in 0..4 {
            jac[(i, j)] = (a[i] - b[i]) / 2e-7;
        }
    }
    let reference: Vec<[f64; 2]> = jac
        .eigenvalues()
        .unwrap()
        .iter()
        .map(|z: &c64| [z.re, z.im])
        .filter(|z| z[0].hypot(z[1]) > 1e-6)
        .collect();
    println!("exact period map's nonzero multipliers: {reference:?}");

    let model = stop_oscillator(k[0], k[1], k_c, gap, mu, force, alpha);
    let mut errors = Vec::new();
    for harmonics in [10, 40] {
        let mut method = ms_hbm(&model, harmonics);
        let (sol, out) =
            solve_at_frequency(&mut method, omega, 1, &NewtonOptions::default()).unwrap();
        assert!(out.converged, "H = {harmonics}: {:?}", out.reason);
        let floquet = method.floquet(&out.x, omega).unwrap().unwrap();
        let nonzero: Vec<[f64; 2]> = floquet
            .multipliers
            .iter()
            .copied()
            .filter(|z| z[0].hypot(z[1]) > 1e-6)
            .collect();
        let d = spectral_distance(&nonzero, &reference);
        println!(
            "H = {harmonics}: max y {:.6}, multipliers {:?}, distance to the exact ones {d:.2e}",
            sol.response.max, floquet.multipliers
        );
        errors.push(d);
    }
    assert!(errors[1] < errors[0], "no convergence in H: {errors:?}");
    assert!(errors[1] <= 1e-3, "H = 40: {:e}", errors[1]);
}
