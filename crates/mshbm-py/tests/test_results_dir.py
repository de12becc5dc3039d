"""`dir()` of a result lists its fields (issue 44: attributes visible to `dir()`), and
every name it lists can be read."""

from __future__ import annotations

import pickle

import mshbm
from conftest import BAR, DAMPED


def check(result, expected: set[str]):
    names = dir(result)
    assert expected <= set(names), expected - set(names)
    for name in names:
        getattr(result, name)  # every listed name reads
    # and a pickled result lists the same
    assert dir(pickle.loads(pickle.dumps(result))) == names


def test_every_result_lists_its_fields():
    bar = mshbm.Model.from_toml(BAR, DAMPED)
    s = mshbm.solve(bar, 30000, harmonics=2, stability=False)
    check(s, {"frequency_hz", "contacts", "converged", "time_s", "harmonics", "plot", "label"})
    d = mshbm.frf(bar, 28000, 30000, 1)
    check(d, {"branches", "folds", "plot"})
    check(d.branches[0], {"frequency_hz", "max_qn", "min_qn", "stable", "label", "stop"})
    m = mshbm.modes(bar, 3)
    check(m, {"original_hz", "redistributed_hz", "relative_error"})
    try:  # two periods are too few to be periodic: the result comes with the error
        mshbm.simulate(bar, 30000, periods=2, steady_state=True, harmonics=2)
        raise AssertionError("expected NotConvergedError")
    except mshbm.NotConvergedError as e:
        sim = e.result
    check(sim, {"time_s", "gaps", "forces", "energy", "steady_state"})
    assert dir(sim).count("steady_state") == 1
    check(sim.steady_state, {"solution", "periodic", "period_scatter"})
