"""`FrequencyResponse.plot()` and `Solution.plot()` draw what `mshbm frf --plot` and
`mshbm solve --plot` draw: checked line by line against the diagram's own points."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

import mshbm
from conftest import BAR, DAMPED


@pytest.fixture(scope="module")
def diagram():
    # the bar through its first contact resonance, H = 3, with stability: stable and
    # unstable parts and four folds (3 s)
    return mshbm.frf(mshbm.Model.from_toml(BAR, DAMPED), 20000, 40000, 3, stability=True)


def test_the_diagram_is_drawn_point_by_point_unstable_parts_dashed(diagram):
    (branch,) = diagram.branches
    stable = np.asarray(branch.stable)
    fold = np.asarray(branch.fold, dtype=bool)
    assert (stable == 0.0).any() and (stable == 1.0).any(), "the test needs both verdicts"
    fig, ax = plt.subplots()
    assert diagram.plot(ax) is ax
    f = np.asarray(branch.frequency_hz) / 1e3  # kHz: the diagram reaches 1 kHz
    curves = [l for l in ax.get_lines() if l.get_linestyle() in ("-", "--")]
    drawn = set()
    for line in curves:
        x, y = line.get_xdata(), line.get_ydata()
        # each drawn point is a point of the branch, not a fold, with its max or min
        ix = [int(np.flatnonzero(np.isclose(f, xi, rtol=0, atol=1e-12) & ~fold)[0]) for xi in x]
        on_max = np.allclose(y, np.asarray(branch.max_qn)[ix], rtol=0, atol=0)
        on_min = np.allclose(y, np.asarray(branch.min_qn)[ix], rtol=0, atol=0)
        assert on_max or on_min
        # a run shares its first point with the run before: the others carry its verdict
        inner = stable[ix[1:]] if len(ix) > 1 else stable[ix]
        if line.get_linestyle() == "--":
            assert (inner == 0.0).all(), "a dashed run with a stable point"
        else:
            assert (inner != 0.0).all(), "a solid run with an unstable point"
        drawn.update(ix)
    assert drawn == set(np.flatnonzero(~fold).tolist()), "every point that is not a fold is drawn"
    # the runs join: each starts at the last point of the one before (max and min curves)
    assert sum(len(l.get_xdata()) for l in curves) == 2 * (len(drawn) + len(curves) // 2 - 1)
    assert any(l.get_linestyle() == "--" for l in curves) and any(l.get_linestyle() == "-" for l in curves)
    # the folds marked where the diagram reports them
    (marks,) = [l for l in ax.get_lines() if l.get_label() == "folds"]
    assert np.allclose(marks.get_xdata(), [fo["frequency_hz"] / 1e3 for fo in diagram.folds], rtol=0, atol=0)
    assert len(diagram.folds) > 0
    assert ax.get_xlabel() == "frequency [kHz]"
    plt.close(fig)


def test_a_new_figure_when_no_axes_are_given(diagram):
    ax = diagram.plot()
    assert ax.figure is not None and len(ax.get_lines()) > 0
    plt.close(ax.figure)


def test_the_solution_is_drawn_over_its_period():
    s = mshbm.solve(mshbm.Model.from_toml(BAR, DAMPED), 30000, harmonics=3, stability=False)
    fig, ax = plt.subplots()
    assert s.plot(ax) is ax
    (line,) = ax.get_lines()
    d = s.to_dict()
    assert np.array_equal(line.get_xdata(), np.asarray(d["time_s"]) * 1e6)
    assert np.array_equal(line.get_ydata(), np.asarray(s.contacts[0]["displacement"]))
    assert line.get_label() == "H = 3"
    plt.close(fig)
