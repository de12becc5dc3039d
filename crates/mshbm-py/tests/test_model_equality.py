"""Models compare equal when built the same way (issue 44: `Model.__eq__`), hash alike
when equal, and a pickled model equals its original."""

from __future__ import annotations

import pickle

import numpy as np

import mshbm
from conftest import BAR, DAMPED


def test_models_from_the_same_file_and_overrides_are_equal():
    a = mshbm.Model.from_toml(BAR, DAMPED)
    b = mshbm.Model.from_toml(BAR, DAMPED)
    assert a == b and hash(a) == hash(b)
    assert a != mshbm.Model.from_toml(BAR)
    assert a != mshbm.Model.from_toml(BAR, {"damping.first_mode_ratio": 0.02})
    assert a == mshbm.Model.from_toml(BAR).with_overrides(DAMPED)
    assert pickle.loads(pickle.dumps(a)) == a
    assert a != "a model" and not (a == 1)
    assert len({a, b}) == 1


def test_models_from_equal_arrays_are_equal():
    base = mshbm.Model.from_toml(BAR, DAMPED).arrays()
    a = mshbm.Model.from_arrays(**base)
    b = mshbm.Model.from_arrays(**mshbm.Model.from_toml(BAR, DAMPED).arrays())
    assert a == b and hash(a) == hash(b)
    assert pickle.loads(pickle.dumps(a)) == a
    # one entry of the stiffness changed (symmetrically), or another gap: not equal
    other = dict(base)
    k = base["stiffness"].tolil()
    k[5, 5] *= 1.0 + 1e-12
    other["stiffness"] = k.tocsc()
    assert mshbm.Model.from_arrays(**other) != a
    other = dict(base)
    other["contacts"] = [dict(c, gap=c["gap"] * 2) for c in base["contacts"]]
    assert mshbm.Model.from_arrays(**other) != a
    other = dict(base)
    other["harmonic_load"] = np.asarray(base["harmonic_load"]) * 2
    assert mshbm.Model.from_arrays(**other) != a
    # a file's model and the same arrays are built differently
    assert a != mshbm.Model.from_toml(BAR, DAMPED)
