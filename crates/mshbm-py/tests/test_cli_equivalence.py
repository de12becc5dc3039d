"""The Python package computes what the CLI computes: the same numbers as `mshbm solve
--json`, `mshbm frf --output` and `mshbm modes --json` (the CLI is the reference)."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import mshbm
from conftest import BAR, DAMPED, DAMPED_SET, EXAMPLES, assert_same_numbers


def bar_from_scipy(damping=None):
    """The paper's bar from scipy.sparse matrices read from examples/bar_matrices (the
    Matrix Market export of clamped_bar.toml) and numpy arrays."""
    d = EXAMPLES / "bar_matrices"
    mass = sp.csc_array(scipy.io.mmread(d / "mass.mtx"))
    stiffness = sp.csc_array(scipy.io.mmread(d / "stiffness.mtx"))
    n = stiffness.shape[0]
    load = np.zeros(n)
    load[50] = 4000.0  # N, at the middle node, as the model file
    return mshbm.Model.from_arrays(
        mass,
        stiffness,
        coordinates=np.loadtxt(d / "nodes.txt"),
        dirichlet=[0],
        contacts=[{"dofs": [100], "w": [-1.0], "gap": 0.2}],
        harmonic_load=load,
        damping=damping,
    )


@pytest.fixture(scope="module")
def reference_solution(cli_json):
    return cli_json("solve", BAR, "--frequency", 30000, "--harmonics", 3, *DAMPED_SET)


def test_solve_from_toml_equals_cli(reference_solution):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    s = mshbm.solve(bar, 30000, harmonics=3)
    assert s.converged and s.stability is not None
    assert_same_numbers(s._data["solution"], reference_solution, rel=1e-12)


def test_solve_from_scipy_sparse_equals_cli(reference_solution):
    bar = bar_from_scipy(damping={"first_mode_ratio": 0.01})
    assert bar.source == "<arrays>" and bar.n_dofs == 101
    s = mshbm.solve(bar, 30000, harmonics=3)
    assert_same_numbers(s._data["solution"], reference_solution, rel=1e-12)


def test_arrays_of_a_toml_model_rebuild_it():
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    again = mshbm.Model.from_arrays(**bar.arrays())
    a = mshbm.solve(bar, 45000, harmonics=2, stability=False)
    b = mshbm.solve(again, 45000, harmonics=2, stability=False)
    assert np.array_equal(a.contact_force, b.contact_force)
    assert np.array_equal(a.unknowns, b.unknowns)


def test_solve_hbm_aft_and_sweep_equal_cli(cli_json):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    ref = cli_json("solve", BAR, "--frequency", 30000, "--harmonics", 2, "--method", "hbm-aft", "--penalty", "1e7", *DAMPED_SET)
    s = mshbm.solve(bar, 30000, 2, method="hbm-aft", penalty=1e7)
    assert_same_numbers(s._data["solution"], ref)
    ref = cli_json("solve", BAR, "--frequency", 80000, "--harmonics", 1, "--sweep-from", 70000, "--sweep-to", 90000, *DAMPED_SET)
    s = mshbm.solve(bar, 80000, 1, sweep_from=70000, sweep_to=90000)
    assert_same_numbers(s._data["solution"], ref)


def test_solve_with_the_modal_receptance_equals_cli(cli_json):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    ref = cli_json("solve", BAR, "--frequency", 30000, "--harmonics", 3, "--receptance", "modal", "--receptance-modes", 12, *DAMPED_SET)
    s = mshbm.solve(bar, 30000, 3, receptance="modal", receptance_modes=12)
    assert_same_numbers(s._data["solution"], ref, rel=1e-12)
    exact = mshbm.solve(bar, 30000, 3)
    # 12 of 100 modes: close to the exact receptance's solution, but not equal to it
    gap = np.max(np.abs(s.unknowns - exact.unknowns)) / np.max(np.abs(exact.unknowns))
    assert 0 < gap < 1e-3


def test_solve_with_the_operator_jacobian_equals_cli(cli_json):
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    ref = cli_json("solve", BAR, "--frequency", 30000, "--harmonics", 3, "--jacobian", "operator", *DAMPED_SET)
    s = mshbm.solve(bar, 30000, 3, jacobian="operator")
    assert_same_numbers(s._data["solution"], ref, rel=1e-12)
    dense = mshbm.solve(bar, 30000, 3, jacobian="dense")
    # GMRES solves Newton's systems to 1e-9: the same solution to Newton's tolerance
    gap = np.max(np.abs(s.unknowns - dense.unknowns)) / np.max(np.abs(dense.unknowns))
    assert gap < 1e-9
    with pytest.raises(mshbm.ArgumentError, match="jacobian applies to method='redistributed' only"):
        mshbm.solve(bar, 30000, 3, method="hbm-aft", jacobian="operator")
    with pytest.raises(mshbm.ArgumentError, match="jacobian='sparse': expected one of"):
        mshbm.solve(bar, 30000, 3, jacobian="sparse")


def read_cli_csv(path):
    rows = [r for r in csv.reader(l for l in open(path) if not l.startswith("#"))]
    header, rows = rows[0], rows[1:]
    return {h: [r[k] for r in rows] for k, h in enumerate(header)}


@pytest.mark.parametrize("stability", [False, True])
def test_frf_equals_cli_csv(cli, tmp_path, stability):
    out = tmp_path / "frd.csv"
    harmonics, lo, hi = ([1, 3], 20000, 40000) if not stability else ([1], 28000, 34000)
    extra = ["--stability"] if stability else []
    cli("frf", BAR, "--from", lo, "--to", hi, "--harmonics", ",".join(map(str, harmonics)), *DAMPED_SET, "--output", out, *extra)
    ref = read_cli_csv(out)
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    d = mshbm.frf(bar, lo, hi, harmonics, stability=stability)
    assert d.completed and d.stop_reason is None
    got = d.to_dict()
    assert len(got["frequency_hz"]) == len(ref["frequency_hz"]) > 20
    # the CSV prints the frequency with 9 decimals and the rest with 13 digits
    assert np.allclose(got["frequency_hz"], np.array(ref["frequency_hz"], float), rtol=0, atol=1e-9)
    for col in ("max_qn", "min_qn", "amplitude_h1"):
        assert np.allclose(got[col], np.array(ref[col], float), rtol=1e-11, atol=0), col
    assert np.allclose(got["residual_norm"], np.array(ref["residual_norm"], float), rtol=1e-2, atol=1e-300)
    assert got["harmonics"].tolist() == [int(h) for h in ref["harmonics"]]
    assert got["newton_iterations"].tolist() == [int(n) for n in ref["newton_iterations"]]
    assert got["fold"].tolist() == [f == "true" for f in ref["fold"]]
    if stability:
        expect = [np.nan if s == "" else float(s == "true") for s in ref["stable"]]
        assert np.array_equal(got["stable"], np.array(expect), equal_nan=True)
        mult = np.array([np.nan if m == "" else float(m) for m in ref["max_multiplier"]])
        assert np.allclose(got["max_multiplier"], mult, rtol=0, atol=1e-9, equal_nan=True)
    else:
        assert np.isnan(got["stable"]).all() and all(s == "" for s in ref["stable"])
    # folds as `frf --json` reports them
    folds = [f for f in d.folds]
    assert sum(got["fold"]) == len(folds)


def test_frf_json_folds_equal_cli(cli_json):
    ref = cli_json("frf", BAR, "--from", 20000, "--to", 40000, "--harmonics", "3", *DAMPED_SET)
    d = mshbm.frf(mshbm.Model.from_toml(BAR, DAMPED), 20000, 40000, 3)
    assert_same_numbers({"folds": d.folds, "bifurcations": d.bifurcations}, {"folds": ref["folds"], "bifurcations": ref["bifurcations"]})
    folds = d.to_dataframe("folds")
    assert len(folds) == len(ref["folds"]) > 0
    assert folds["frequency_hz"].tolist() == [f["frequency_hz"] for f in ref["folds"]]
    for b, rb in zip(d.branches, ref["branches"]):
        assert b.label == rb["label"] and b.stop == rb["stop"] and b.completed == rb["completed"]
        assert_same_numbers(b.max_qn, [p["max_qn"] for p in rb["points"]])


def test_modes_equal_cli(cli_json):
    ref = cli_json("modes", BAR, "--count", 5)
    m = mshbm.modes(mshbm.Model.from_toml(BAR), 5)
    assert_same_numbers(m._data, ref)
    assert list(m.to_dict()) == ["mode", "original_hz", "redistributed_hz", "relative_error"]


def test_steady_state_simulation_equals_cli(cli_json):
    args = dict(frequency=30000, steady_state=True, scheme="redistributed", harmonics=3, periods=60)
    sets = {"damping.alpha": 7587.745, "damping.beta_linear": 5e-7}
    ref = cli_json("simulate", BAR, "--set", "damping.alpha=7587.745", "--set", "damping.beta_linear=5e-7",
                   "--frequency", 30000, "--steady-state", "--scheme", "redistributed", "--harmonics", 3, "--periods", 60)
    sim = mshbm.simulate(mshbm.Model.from_toml(BAR, sets), **args)
    assert_same_numbers(sim._data["steady_state"], ref)
    assert sim.steady_state.periodic
    assert sim.gaps.shape == (len(sim.time_s), 1)
    # its last period as a Solution (docs/python.md), with the CLI's numbers
    sol = sim.steady_state.solution
    assert sol.frequency_hz == ref["frequency_hz"] == 30000
    assert_same_numbers(sol.contacts[0]["coefficients"], ref["contacts"][0]["coefficients"])
    assert_same_numbers(sol.time_s, ref["time_s"])


def test_starting_from_a_solution_equals_cli_from_solution(cli_json, tmp_path):
    sets = {"damping.alpha": 7587.745, "damping.beta_linear": 5e-7}
    set_args = ["--set", "damping.alpha=7587.745", "--set", "damping.beta_linear=5e-7"]
    bar = mshbm.Model.from_toml(BAR, sets)
    first = mshbm.solve(bar, 29500, 3)
    start = tmp_path / "start.json"
    start.write_text(first.to_json())
    # the JSON written by the Python package is the CLI's: the CLI starts from it
    ref = cli_json("solve", BAR, *set_args, "--frequency", 30000, "--harmonics", 4, "--from-solution", start)
    s = mshbm.solve(bar, 30000, 4, start=first)
    assert_same_numbers(s._data["solution"], ref)
    ref = cli_json("simulate", BAR, *set_args, "--frequency", 29500, "--steady-state", "--harmonics", 3,
                   "--periods", 20, "--from-solution", start)
    sim = mshbm.simulate(bar, 29500, steady_state=True, harmonics=3, periods=20, start=first)
    assert_same_numbers(sim._data["steady_state"], ref)


@pytest.mark.parametrize("scheme", ["redistributed", "moreau"])
def test_transient_simulation_equals_cli_csv(cli, tmp_path, scheme):
    out = tmp_path / "sim.csv"
    cli("simulate", BAR, *DAMPED_SET, "--frequency", 30000, "--periods", 2, "--scheme", scheme, "--output", out)
    ref = read_cli_csv(out)
    sim = mshbm.simulate(mshbm.Model.from_toml(BAR, DAMPED), 30000, periods=2, scheme=scheme)
    got = sim.to_dict()
    assert list(got) == list(ref)
    assert len(got["time_s"]) == len(ref["time_s"]) > 1000
    for col in ref:
        assert np.allclose(got[col], np.array(ref[col], float), rtol=1e-11, atol=1e-300), col


FRICTION_DAMPER = EXAMPLES / "friction_damper" / "model.toml"


def test_friction_outputs_equal_cli(cli, cli_json, tmp_path):
    """Contacts with friction: the energy and the stick/slip/open fractions per point, and
    per sample the state and the friction force, as the CLI writes them."""
    out = tmp_path / "frd.csv"
    cli("frf", FRICTION_DAMPER, "--from", 300, "--to", 700, "--harmonics", 3, "--dof", 209, "--output", out)
    ref = read_cli_csv(out)
    damper = mshbm.Model.from_toml(FRICTION_DAMPER)
    d = mshbm.frf(damper, 300, 700, [3], dof=209)
    assert d.completed
    got = d.to_dict()
    assert len(got["frequency_hz"]) == len(ref["frequency_hz"]) > 10
    assert np.allclose(got["dissipated_energy"], np.array(ref["dissipated_energy"], float), rtol=1e-8, atol=0)
    for col in ("stick", "slip", "open"):
        assert np.allclose(got[col], np.array(ref[col], float), rtol=0, atol=1e-8), col
    fractions = d.branches[0].state_fractions
    assert fractions.shape == (len(got["frequency_hz"]), 5, 3)
    assert np.allclose(fractions.sum(axis=2), 1.0, atol=1e-12)
    assert np.allclose(fractions[:, :, 0].mean(axis=1), got["stick"], atol=1e-12)
    s = mshbm.solve(damper, 1100, 3)
    ref = cli_json("solve", FRICTION_DAMPER, "--frequency", 1100, "--harmonics", 3)
    assert s.dissipated_energy == pytest.approx(ref["dissipated_energy"], rel=1e-10)
    assert s.state_fractions.shape == (5, 3)
    assert np.allclose(s.state_fractions, [[f["stick"], f["slip"], f["open"]] for f in ref["state_fractions"]], atol=1e-12)
    assert s.contact_state.tolist() == [f["state"] for f in ref["frictions"]]
    assert np.allclose(s.friction_force, [f["force"] for f in ref["frictions"]], rtol=1e-10, atol=1e-12)
    # the state agrees with the forces: on the cone where slipping, no force where open
    slip = s.contact_state == "slip"
    assert np.allclose(np.abs(s.friction_force[slip]), s.friction_limit[slip], rtol=1e-9)
    assert np.all(s.contact_force[s.contact_state == "open"] == 0.0)
    columns = s.to_dict()
    assert list(columns["state_c0"]) == list(s.contact_state[0])
