//! The linear-elastic solid elements and structured meshes ([`mshbm::fe::solid`],
//! [`mshbm::fe::structured`], docs/theory.md §15) against independent references: matrices
//! assembled by a separate numpy script, eigenfrequencies from scikit-fem, exact linear
//! fields (patch tests), the rigid-body modes, Timoshenko beam theory, and the uncracked
//! mesh for a crack whose lips are tied.

use std::path::Path;

use faer::linalg::solvers::Solve;
use faer::Mat;
use mshbm::fe::mesh::Cells;
use mshbm::fe::solid::{assemble_plane, assemble_solid, ElasticMaterial, PlaneKind};
use mshbm::fe::structured::{cuboid, face_weights, rectangle, Crack2d, StructuredMesh};
use mshbm::modes::{eigenfrequencies_hz, symmetric_eigen};
use mshbm::sparse::SparseMatrix;

const STEEL: ElasticMaterial = ElasticMaterial {
    young: 2.1e5,
    poisson: 0.3,
    density: 7.85e-9,
};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn dofs_of(nodes: &[usize], d: usize) -> Vec<usize> {
    nodes
        .iter()
        .flat_map(|&p| (0..d).map(move |c| p * d + c))
        .collect()
}

/// Eigenfrequencies [Hz] with the nodes of `face` clamped.
fn clamped_frequencies(
    m: &SparseMatrix,
    k: &SparseMatrix,
    mesh: &StructuredMesh,
    d: usize,
    face: &str,
    count: usize,
) -> Vec<f64> {
    let fixed = dofs_of(&mesh.node_sets[face], d);
    let free: Vec<usize> = (0..k.nrows()).filter(|i| !fixed.contains(i)).collect();
    eigenfrequencies_hz(
        &m.submatrix(&free, &free),
        &k.submatrix(&free, &free),
        count,
    )
    .unwrap()
}

/// The same mesh as tests/data/cantilever_q4 (100 × 10 mm, 40 × 4 cells, plane stress),
/// assembled by its numpy script: every entry of K and M agrees to round-off.
#[test]
fn quadrilaterals_equal_an_independent_numpy_assembly() {
    let mesh = rectangle([100.0, 10.0], [40, 4], None).unwrap();
    let (m, k) = assemble_plane(
        &mesh.coordinates,
        &mesh.cells,
        &STEEL,
        1.0,
        PlaneKind::Stress,
    )
    .unwrap();
    let reference = mshbm::model::file::load_model(&data("cantilever_q4/model.toml"), &[]).unwrap();
    for (ours, theirs, name) in [(&k, &reference.stiffness, "K"), (&m, &reference.mass, "M")] {
        assert_eq!(ours.nrows(), theirs.nrows());
        let scale = theirs.max_abs();
        let mut worst = 0.0f64;
        for (i, j, v) in theirs.iter() {
            worst = worst.max((ours.get(i, j) - v).abs());
        }
        for (i, j, v) in ours.iter() {
            worst = worst.max((theirs.get(i, j) - v).abs());
        }
        assert!(
            worst <= 1e-12 * scale,
            "{name}: largest difference {worst:e} of {scale:e}"
        );
    }
}

/// The ten lowest eigenfrequencies of three small clamped meshes agree with scikit-fem
/// (tools/fe-reference/skfem_reference.py) to 1e-8, and so do the traces and total mass.
#[test]
fn eigenfrequencies_equal_scikit_fem() {
    let text = std::fs::read_to_string(data("skfem_reference.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let quad = rectangle([3.0, 1.5], [6, 3], None).unwrap();
    let hexa = cuboid([3.0, 1.0, 1.0], [3, 2, 2]).unwrap();
    let cases = [
        (
            "plane_stress",
            assemble_plane(
                &quad.coordinates,
                &quad.cells,
                &STEEL,
                1.0,
                PlaneKind::Stress,
            )
            .unwrap(),
            &quad,
            2,
        ),
        (
            "plane_strain",
            assemble_plane(
                &quad.coordinates,
                &quad.cells,
                &STEEL,
                1.0,
                PlaneKind::Strain,
            )
            .unwrap(),
            &quad,
            2,
        ),
        (
            "solid",
            assemble_solid(&hexa.coordinates, &hexa.cells, &STEEL).unwrap(),
            &hexa,
            3,
        ),
    ];
    for (name, (m, k), mesh, d) in cases {
        let r = &reference[name];
        assert_eq!(k.nrows() as u64, r["dofs"].as_u64().unwrap(), "{name}");
        let close = |ours: f64, key: &str| {
            let theirs = r[key].as_f64().unwrap();
            assert!(
                ((ours - theirs) / theirs).abs() < 1e-8,
                "{name} {key}: {ours} vs {theirs}"
            );
        };
        close((0..k.nrows()).map(|i| k.get(i, i)).sum(), "trace_k");
        close((0..m.nrows()).map(|i| m.get(i, i)).sum(), "trace_m");
        close(m.iter().map(|(_, _, v)| v).sum(), "sum_m");
        let theirs: Vec<f64> = r["frequencies_hz"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let ours = clamped_frequencies(&m, &k, mesh, d, "x0", theirs.len());
        for (a, b) in ours.iter().zip(&theirs) {
            assert!(((a - b) / b).abs() < 1e-8, "{name}: {ours:?} vs {theirs:?}");
        }
    }
}

/// Move the interior nodes of a structured mesh (a distorted mesh).
fn distort(mesh: &mut StructuredMesh, size: &[f64]) {
    let boundary: Vec<usize> = mesh.node_sets.values().flatten().copied().collect();
    for (p, x) in mesh.coordinates.iter_mut().enumerate() {
        if boundary.contains(&p) {
            continue;
        }
        for (a, v) in x.iter_mut().enumerate() {
            *v += 0.11 * size[a] * ((p * (a + 3)) as f64 * 0.7).sin() / 4.0;
        }
    }
}

/// Stiffness, mesh, DOFs per node and the exact linear field of one patch test.
type PatchCase<'a> = (
    SparseMatrix,
    &'a StructuredMesh,
    usize,
    &'a dyn Fn(&[f64]) -> Vec<f64>,
);

/// Patch test: on a distorted mesh, the boundary displacements of a linear field give the
/// linear field at every interior node (K u = 0 there), in plane stress, plane strain and 3D.
#[test]
fn patch_tests_reproduce_linear_fields_on_distorted_meshes() {
    let mut quad = rectangle([2.0, 1.0], [4, 4], None).unwrap();
    distort(&mut quad, &[0.5, 0.25]);
    let mut hexa = cuboid([1.0, 1.0, 1.0], [3, 3, 3]).unwrap();
    distort(&mut hexa, &[1.0 / 3.0; 3]);
    let field2 = |x: &[f64]| {
        vec![
            1e-3 * (1.0 + 2.0 * x[0] - 0.5 * x[1]),
            1e-3 * (0.3 * x[0] + 1.5 * x[1] - 2.0),
        ]
    };
    let field3 = |x: &[f64]| {
        vec![
            1e-3 * (1.0 + 2.0 * x[0] - 0.5 * x[1] + 0.2 * x[2]),
            1e-3 * (0.3 * x[0] + 1.5 * x[1] - 0.7 * x[2]),
            1e-3 * (-0.4 * x[0] + 0.1 * x[1] + 0.9 * x[2] + 0.5),
        ]
    };
    let cases: Vec<PatchCase> = vec![
        (
            assemble_plane(
                &quad.coordinates,
                &quad.cells,
                &STEEL,
                1.0,
                PlaneKind::Stress,
            )
            .unwrap()
            .1,
            &quad,
            2,
            &field2,
        ),
        (
            assemble_plane(
                &quad.coordinates,
                &quad.cells,
                &STEEL,
                1.0,
                PlaneKind::Strain,
            )
            .unwrap()
            .1,
            &quad,
            2,
            &field2,
        ),
        (
            assemble_solid(&hexa.coordinates, &hexa.cells, &STEEL)
                .unwrap()
                .1,
            &hexa,
            3,
            &field3,
        ),
    ];
    for (k, mesh, d, field) in cases {
        let n = k.nrows();
        let exact: Vec<f64> = mesh.coordinates.iter().flat_map(|x| field(x)).collect();
        let mut nodes: Vec<usize> = mesh.node_sets.values().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        let boundary = dofs_of(&nodes, d);
        let interior: Vec<usize> = (0..n).filter(|i| !boundary.contains(i)).collect();
        assert!(!interior.is_empty());
        let kd = k.to_dense();
        let kii = Mat::<f64>::from_fn(interior.len(), interior.len(), |a, b| {
            kd[(interior[a], interior[b])]
        });
        let rhs = Mat::<f64>::from_fn(interior.len(), 1, |a, _| {
            -boundary
                .iter()
                .map(|&j| kd[(interior[a], j)] * exact[j])
                .sum::<f64>()
        });
        let u = kii.partial_piv_lu().solve(&rhs);
        let err =
            (0..interior.len()).fold(0.0f64, |e, a| e.max((u[(a, 0)] - exact[interior[a]]).abs()));
        assert!(err < 1e-12, "{d}D patch test: error {err:e}");
    }
}

/// A free mesh has exactly the rigid-body modes as its zero-stiffness modes: 3 in 2D, 6 in
/// 3D; the next eigenvalue of K is clearly positive. M carries ρ·volume per component.
#[test]
fn free_meshes_have_exactly_the_rigid_body_modes() {
    let quad = rectangle([2.0, 1.0], [4, 2], None).unwrap();
    let hexa = cuboid([2.0, 1.0, 1.0], [2, 2, 2]).unwrap();
    let (m2, k2) = assemble_plane(
        &quad.coordinates,
        &quad.cells,
        &STEEL,
        0.5,
        PlaneKind::Stress,
    )
    .unwrap();
    let (m3, k3) = assemble_solid(&hexa.coordinates, &hexa.cells, &STEEL).unwrap();
    for (m, k, d, rigid, volume) in [(m2, k2, 2, 3, 2.0 * 1.0 * 0.5), (m3, k3, 3, 6, 2.0)] {
        let (values, _) = symmetric_eigen(&k.to_dense()).unwrap();
        let top = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let zeros = values.iter().filter(|v| v.abs() < 1e-10 * top).count();
        assert_eq!(zeros, rigid, "{d}D: eigenvalues {:?}", &values[..rigid + 1]);
        for c in 0..d {
            let comp: f64 = m
                .iter()
                .filter(|&(i, j, _)| i % d == c && j % d == c)
                .map(|(_, _, v)| v)
                .sum();
            assert!(
                (comp / (STEEL.density * volume) - 1.0).abs() < 1e-12,
                "{d}D component {c}: {comp}"
            );
        }
        assert!(
            m.iter().all(|(i, j, v)| i % d == j % d || v == 0.0),
            "M couples components"
        );
    }
}

/// Timoshenko's clamped–free beam (rectangular section, shear coefficient
/// κ = 10(1+ν)/(12+11ν)): the first two bending frequencies of a 100 × 10 plane-stress
/// cantilever of 80 × 8 quadrilaterals agree within 2 %.
#[test]
fn a_slender_cantilever_bends_as_timoshenko_beam_theory_says() {
    let (l, h) = (100.0, 10.0);
    let mesh = rectangle([l, h], [80, 8], None).unwrap();
    let (m, k) = assemble_plane(
        &mesh.coordinates,
        &mesh.cells,
        &STEEL,
        1.0,
        PlaneKind::Stress,
    )
    .unwrap();
    let fe = clamped_frequencies(&m, &k, &mesh, 2, "x0", 4);
    let timoshenko = timoshenko_clamped_free(l, h, 2);
    // the 2D model also has an axial mode (first one at c/4L ≈ 12.9 kHz): the bending modes
    // are the two lowest here
    println!("bending frequencies: FE {fe:?} Hz, Timoshenko {timoshenko:?} Hz");
    for (n, (a, b)) in fe.iter().zip(&timoshenko).enumerate() {
        assert!(
            ((a - b) / b).abs() < 0.02,
            "bending mode {}: FE {a} Hz, Timoshenko {b} Hz",
            n + 1
        );
    }
}

/// The `count` lowest bending frequencies [Hz] of a clamped–free Timoshenko beam of
/// rectangular section `h` (unit width), from the frequency equation of Huang (1961) in the
/// non-dimensional form: roots of the determinant of the 4×4 boundary-condition matrix,
/// bracketed by a scan in ω.
fn timoshenko_clamped_free(l: f64, h: f64, count: usize) -> Vec<f64> {
    let (e, nu, rho) = (STEEL.young, STEEL.poisson, STEEL.density);
    let g = e / (2.0 * (1.0 + nu));
    let kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
    let (a, i) = (h, h * h * h / 12.0);
    // w = Σ C e^{s x}, ψ = Σ C r(s) e^{s x}: s from E I s⁴ + ρ I ω² (1 + E/κG) s² − ρAω²(1 − ρ I ω²/κGA) = 0
    let det = |w: f64| -> f64 {
        let c4 = e * i;
        let c2 = rho * i * w * w * (1.0 + e / (kappa * g));
        let c0 = -rho * a * w * w * (1.0 - rho * i * w * w / (kappa * g * a));
        let disc = (c2 * c2 - 4.0 * c4 * c0).sqrt();
        let p = (-c2 + disc) / (2.0 * c4); // s² > 0
        let q = (-c2 - disc) / (2.0 * c4); // s² < 0 (below the cut-off frequency)
        let (al, be) = (p.sqrt(), (-q).sqrt());
        // modes: cosh, sinh (α), cos, sin (β); ψ' relations from κGA(w'' − ψ') + ρAω² w = 0
        // ψ = (κGA w' + ...) — use the equivalent ODE for ψ: ψ = [w'(κGA) + E I w''' + ρIω² w' (E/κG)...]
        // simpler: ψ from the first equation integrated: κGA(w' − ψ)' = −ρAω² w
        let kga = kappa * g * a;
        let ra = rho * a * w * w;
        // for w = e^{sx}: ψ = (s + ρAω²/(κGA s)) e^{sx}
        let psi_coef = |s2: f64| 1.0 + ra / (kga * s2); // ψ / (s w) as a function of s²
        let (pa, pb) = (psi_coef(al * al), psi_coef(-be * be));
        // basis functions and derivatives at x = 0 and x = l:
        // w1 = cosh αx, w2 = sinh αx, w3 = cos βx, w4 = sin βx
        // ψ1 = pa α sinh αx, ψ2 = pa α cosh αx, ψ3 = −pb β sin βx, ψ4 = pb β cos βx
        let x = l;
        let (ch, sh, co, si) = (
            (al * x).cosh(),
            (al * x).sinh(),
            (be * x).cos(),
            (be * x).sin(),
        );
        // clamped at 0: w = 0, ψ = 0; free at l: moment ψ' = 0, shear w' − ψ = 0
        let rows = [
            [1.0, 0.0, 1.0, 0.0],
            [0.0, pa * al, 0.0, pb * be],
            [
                pa * al * al * ch,
                pa * al * al * sh,
                -pb * be * be * co,
                -pb * be * be * si,
            ],
            [
                al * sh - pa * al * sh,
                al * ch - pa * al * ch,
                -be * si + pb * be * si,
                be * co - pb * be * co,
            ],
        ];
        let m = Mat::<f64>::from_fn(4, 4, |r, c| rows[r][c]);
        let scale: f64 = (0..4)
            .map(|r| (0..4).fold(0.0f64, |s, c| s.max(rows[r][c].abs())))
            .product();
        m.determinant() / scale
    };
    let mut roots = Vec::new();
    let (mut w, dw) = (1.0, 20.0);
    let mut prev = det(w);
    while roots.len() < count {
        let next = det(w + dw);
        if prev.signum() != next.signum() {
            let (mut lo, mut hi) = (w, w + dw);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if det(mid).signum() == det(lo).signum() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            roots.push(0.5 * (lo + hi) / (2.0 * std::f64::consts::PI));
        }
        prev = next;
        w += dw;
    }
    roots
}

/// A crack with its lips tied back together is the uncracked mesh: merging each copy into
/// its original node gives the uncracked K and M exactly; the lips coincide, and a crack off
/// the mesh lines is refused.
#[test]
fn a_tied_crack_is_the_uncracked_mesh() {
    let crack = Crack2d {
        x: 5.0,
        from: 0.0,
        to: 2.0,
    };
    let cracked = rectangle([10.0, 4.0], [10, 4], Some(&crack)).unwrap();
    let whole = rectangle([10.0, 4.0], [10, 4], None).unwrap();
    let (a, b) = (&cracked.node_sets["crack_a"], &cracked.node_sets["crack_b"]);
    // an edge crack to y = 2: nodes at y = 0 and 1 are doubled, the tip (y = 2) is not
    assert_eq!(a.len(), 2);
    assert_eq!(cracked.coordinates.len(), whole.coordinates.len() + 2);
    for (p, q) in a.iter().zip(b) {
        assert_eq!(cracked.coordinates[*p], cracked.coordinates[*q]);
    }
    let (mc, kc) = assemble_plane(
        &cracked.coordinates,
        &cracked.cells,
        &STEEL,
        1.0,
        PlaneKind::Stress,
    )
    .unwrap();
    let (mw, kw) = assemble_plane(
        &whole.coordinates,
        &whole.cells,
        &STEEL,
        1.0,
        PlaneKind::Stress,
    )
    .unwrap();
    let mut target: Vec<usize> = (0..cracked.coordinates.len()).collect();
    for (p, q) in a.iter().zip(b) {
        target[*q] = *p;
    }
    let merge = |x: &SparseMatrix| {
        let t: Vec<(usize, usize, f64)> = x
            .iter()
            .map(|(i, j, v)| (target[i / 2] * 2 + i % 2, target[j / 2] * 2 + j % 2, v))
            .collect();
        SparseMatrix::from_triplets(kw.nrows(), kw.nrows(), &t)
    };
    for (tied, uncracked) in [(merge(&kc), &kw), (merge(&mc), &mw)] {
        let scale = uncracked.max_abs();
        for (i, j, v) in uncracked.iter() {
            assert!((tied.get(i, j) - v).abs() <= 1e-12 * scale);
        }
        assert_eq!(tied.nnz(), uncracked.nnz());
    }
    let off = Crack2d {
        x: 5.5,
        from: 0.0,
        to: 2.0,
    };
    let e = rectangle([10.0, 4.0], [10, 4], Some(&off))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("crack.x") && e.contains("not on a mesh line"),
        "{e}"
    );
    let e = rectangle([10.0, 4.0], [0, 4], None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("at least 1"), "{e}");
    let bad = ElasticMaterial {
        poisson: 0.5,
        ..STEEL
    };
    let e = assemble_plane(
        &whole.coordinates,
        &whole.cells,
        &bad,
        1.0,
        PlaneKind::Strain,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("Poisson"), "{e}");
    let flat = Cells {
        kind: whole.cells.kind,
        connectivity: vec![0, 1, 1, 0],
    };
    let e = assemble_plane(&whole.coordinates, &flat, &STEEL, 1.0, PlaneKind::Stress)
        .unwrap_err()
        .to_string();
    assert!(e.contains("degenerate"), "{e}");
}

/// Face weights of a uniform traction: the end nodes of an edge of equal elements carry
/// half an interior node's share (2D); on a face of a box, corner : edge : interior nodes
/// carry 1 : 2 : 4; they sum to one.
#[test]
fn face_weights_are_those_of_a_uniform_traction() {
    let quad = rectangle([10.0, 4.0], [10, 4], None).unwrap();
    let w = face_weights(&quad, &quad.node_sets["x1"]).unwrap();
    assert_eq!(w.len(), 5);
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    assert!(
        (w[0] - 0.125).abs() < 1e-15 && (w[1] - 0.25).abs() < 1e-15 && (w[4] - 0.125).abs() < 1e-15
    );
    let hexa = cuboid([2.0, 2.0, 2.0], [2, 2, 2]).unwrap();
    let w = face_weights(&hexa, &hexa.node_sets["z1"]).unwrap();
    let mut sorted = w.clone();
    sorted.sort_by(f64::total_cmp);
    assert!(
        (sorted[0] - 1.0 / 16.0).abs() < 1e-15 && (sorted[8] - 0.25).abs() < 1e-15,
        "{w:?}"
    );
}
