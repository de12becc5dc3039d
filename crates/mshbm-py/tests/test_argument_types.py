"""Python values that do not translate into an option are refused at once, naming the
argument: a number of the wrong type (an ``ArgumentTypeError``, both an ``ArgumentError``
and a ``TypeError``) and a negative count (an ``ArgumentError``), never an ``OverflowError``
or a bare ``TypeError`` from the extension, and never silently truncated or parsed."""

from __future__ import annotations

import time

import numpy as np
import pytest

import mshbm
from conftest import BAR, DAMPED


@pytest.fixture(scope="module")
def bar():
    return mshbm.Model.from_toml(BAR, DAMPED)


CASES = [
    # (call, argument named, expected exception)
    (lambda m: mshbm.solve(m, 30000, harmonics=-3), "harmonics", mshbm.ArgumentError),
    (lambda m: mshbm.solve(m, 30000, harmonics=3.7), "harmonics", mshbm.ArgumentTypeError),
    (lambda m: mshbm.solve(m, 30000, harmonics=True), "harmonics", mshbm.ArgumentTypeError),
    (lambda m: mshbm.solve(m, "30000", harmonics=3), "frequency", mshbm.ArgumentTypeError),
    (lambda m: mshbm.solve(m, 30000, threads=-1), "threads", mshbm.ArgumentError),
    (lambda m: mshbm.solve(m, 30000, samples=256.0), "samples", mshbm.ArgumentTypeError),
    (lambda m: mshbm.solve(m, 30000, tolerance="1e-8"), "tolerance", mshbm.ArgumentTypeError),
    (lambda m: mshbm.solve(m, 30000, dof=-2), "dof", mshbm.ArgumentError),
    (lambda m: mshbm.frf(m, 20000, 40000, [1, 2.5]), "harmonics", mshbm.ArgumentTypeError),
    (lambda m: mshbm.frf(m, 20000, 40000, "3"), "harmonics", mshbm.ArgumentTypeError),
    (lambda m: mshbm.frf(m, "20000", 40000, 3), "from_hz", mshbm.ArgumentTypeError),
    (lambda m: mshbm.frf(m, 20000, 40000, 3, max_points=-5), "max_points", mshbm.ArgumentError),
    (lambda m: mshbm.frf(m, 20000, 40000, 3, step=1j), "step", mshbm.ArgumentTypeError),
    (lambda m: mshbm.modes(m, 3.7), "count", mshbm.ArgumentTypeError),
    (lambda m: mshbm.modes(m, -1), "count", mshbm.ArgumentError),
    (lambda m: mshbm.simulate(m, 30000, steps_per_period=100.5), "steps_per_period", mshbm.ArgumentTypeError),
    (lambda m: mshbm.simulate(m, 30000, periods="2"), "periods", mshbm.ArgumentTypeError),
]


@pytest.mark.parametrize("call,name,kind", CASES)
def test_a_value_that_does_not_translate_is_refused_naming_its_argument(bar, call, name, kind):
    start = time.perf_counter()
    with pytest.raises(kind) as info:
        call(bar)
    assert time.perf_counter() - start < 1.0, "refused only after computing"
    assert str(info.value).startswith(f"{name} must be "), str(info.value)
    assert info.value.argument == name
    assert isinstance(info.value, mshbm.ArgumentError) and isinstance(info.value, ValueError)
    if kind is mshbm.ArgumentTypeError:
        assert isinstance(info.value, TypeError)


def test_numpy_scalars_are_numbers(bar):
    # numpy integers and floats translate as Python's do
    s = mshbm.solve(bar, np.float64(30000.0), harmonics=np.int64(1), stability=False)
    t = mshbm.solve(bar, 30000.0, harmonics=1, stability=False)
    assert s.converged and t.converged
    assert np.array_equal(s.contact_force, t.contact_force)
