"""Models: from a TOML model file (with ``--set``-style overrides) or from arrays."""

from __future__ import annotations

import json
import math
import os
from typing import Any, Iterable, Mapping

import numpy as np

from . import _native
from ._native import ArgumentError

__all__ = ["Model"]


def _toml_value(value: Any) -> str:
    """A Python value as the TOML text of an override (``--set key=VALUE``)."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ArgumentError(
        f"override value {value!r}: expected a number, a boolean, a string or a list"
    )


def _overrides(overrides: Mapping[str, Any] | Iterable[str] | None) -> list[str]:
    """``{"contact.gap": 0.1}`` or ``["contact.gap=0.1"]`` as the CLI's ``--set`` strings."""
    if overrides is None:
        return []
    if isinstance(overrides, Mapping):
        return [f"{key}={_toml_value(value)}" for key, value in overrides.items()]
    if isinstance(overrides, str):
        return [overrides]
    return [str(o) for o in overrides]


def _csc(name: str, matrix: Any):
    """A square matrix (scipy.sparse or a dense numpy array) as the CSC arrays the
    extension reads without copying: ``(shape, data, indices, indptr)``."""
    import scipy.sparse as sp

    if sp.issparse(matrix):
        a = sp.csc_array(matrix)
    else:
        dense = np.asarray(matrix, dtype=np.float64)
        if dense.ndim != 2:
            raise ArgumentError(f"{name}: expected a 2-D matrix, got {dense.ndim} dimensions")
        a = sp.csc_array(dense)
    a.sort_indices()
    return (
        (int(a.shape[0]), int(a.shape[1])),
        np.ascontiguousarray(a.data, dtype=np.float64),
        np.ascontiguousarray(a.indices, dtype=np.int64),
        np.ascontiguousarray(a.indptr, dtype=np.int64),
    )


def _contact(k: int, c: Any) -> tuple[list[int], list[float], float]:
    if isinstance(c, Mapping):
        unknown = set(c) - {"dofs", "w", "gap"}
        if unknown:
            raise ArgumentError(f"contacts[{k}]: unknown keys {sorted(unknown)} (expected dofs, w, gap)")
        try:
            c = (c["dofs"], c["w"], c["gap"])
        except KeyError as e:
            raise ArgumentError(f"contacts[{k}]: missing {e.args[0]!r} (expected dofs, w, gap)") from None
    try:
        dofs, w, gap = c
    except (TypeError, ValueError):
        raise ArgumentError(f"contacts[{k}]: expected {{'dofs': [...], 'w': [...], 'gap': g}} or (dofs, w, gap)") from None
    dofs = [dofs] if np.isscalar(dofs) else list(dofs)
    w = [w] if np.isscalar(w) else list(w)
    return [int(d) for d in dofs], [float(x) for x in w], float(gap)


_DAMPING_KEYS = ("alpha", "beta", "beta_linear", "beta_condensed", "first_mode_ratio")


def _same(a: Any, b: Any) -> bool:
    """Equality of the recipes' values: numpy arrays and scipy sparse matrices by shape and
    entries, containers element by element."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if hasattr(a, "tocoo") and hasattr(b, "tocoo"):  # scipy sparse
        return a.shape == b.shape and (a != b).nnz == 0
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.array_equal(a, b))
    return bool(a == b)


class Model:
    """A validated model (the library's ``Model``).

    Build one with :meth:`from_toml` or :meth:`from_arrays`. Units are those of the model
    (the paper's bar: mm, t, s, N, MPa); frequencies are always in Hz. DOFs are numbered
    from 0 as in the model file, Dirichlet DOFs included.

    Models pickle (for Dask workers): a model from a file by its text, path and overrides
    (files it refers to, e.g. Matrix Market matrices, are read again from that path), a
    model from arrays by its arrays. Two models are equal when built the same way.
    """

    __slots__ = ("_native", "_recipe")

    def __init__(self, native: _native.NativeModel, recipe: tuple):
        self._native = native
        self._recipe = recipe

    # --- construction -------------------------------------------------------------------
    @classmethod
    def from_toml(
        cls,
        path: str | os.PathLike,
        overrides: Mapping[str, Any] | Iterable[str] | None = None,
        *,
        max_memory_gib: float | None = None,
        allow_outside_paths: bool = False,
    ) -> "Model":
        """Read a model file (``kind = "bar"``, ``"matrices"``, ``"solid"`` or
        ``"dropped_bar"``, see examples/) as ``mshbm … MODEL --set …`` does.

        ``overrides``: a dict ``{"contact.gap": 0.1, "damping.first_mode_ratio": 0.01}``
        (dotted paths; values in the model's units) or a list of ``"key=value"`` strings.
        ``max_memory_gib``: memory budget of the model and of every computation on it
        (``--max-memory``); ``allow_outside_paths``: as ``--allow-outside-paths``.
        Raises :class:`ModelError` (naming the file and the field) or
        :class:`ArgumentError` (a malformed override).
        """
        sets = _overrides(overrides)
        native = _native.NativeModel.from_toml(
            os.fspath(path), sets, max_memory_gib, allow_outside_paths
        )
        kind, text, source, sets = native.recipe()
        # absolute, so that a worker with another working directory finds the files a
        # `kind = "matrices"` model refers to
        source = os.path.abspath(source)
        return cls(native, ("toml", text, source, sets, max_memory_gib, allow_outside_paths))

    @classmethod
    def from_arrays(
        cls,
        mass: Any,
        stiffness: Any,
        *,
        coordinates: Any,
        contacts: Iterable[Any],
        harmonic_load: Any,
        constant_load: Any = None,
        damping_matrix: Any = None,
        dirichlet: Iterable[int] = (),
        dofs_per_node: int = 1,
        damping: Mapping[str, float] | None = None,
        name: str | None = None,
        acceleration: Iterable[float] | None = None,
        max_memory_gib: float | None = None,
    ) -> "Model":
        """A model from arrays: the fields of a ``kind = "matrices"`` model file.

        ``mass``, ``stiffness`` (and ``damping_matrix``): the consistent mass, stiffness
        (and damping) matrices of the unconstrained mesh, ``scipy.sparse`` or dense numpy,
        symmetric, n × n. ``coordinates``: node coordinates in the model's length unit,
        shape (nodes, dim) with dim 1, 2 or 3 (or 1-D for dim 1), nodes × dofs_per_node =
        n. ``dirichlet``: DOFs fixed to zero. ``contacts``: one per unilateral contact,
        ``{"dofs": [d, …], "w": [w, …], "gap": g0}`` (gap g = g0 + Σ w·q ≥ 0, length
        unit) or ``(dofs, w, gap)``. ``harmonic_load``: amplitude F of the load F·cos(ωt)
        per DOF (force unit, length n); ``constant_load``: constant load per DOF (default
        zero). ``damping``: ``{"alpha": 1/s, "beta": s, "beta_linear": s,
        "beta_condensed": s, "first_mode_ratio": ζ}`` as the model file's ``[damping]``.
        Validated by the library: a bad field raises :class:`ModelError` naming
        ``<arrays>`` and the field (e.g. ``matrices.mass``, ``contacts[0].dofs``).
        """
        damping = dict(damping or {})
        unknown = set(damping) - set(_DAMPING_KEYS)
        if unknown:
            raise ArgumentError(f"damping: unknown keys {sorted(unknown)} (expected {', '.join(_DAMPING_KEYS)})")
        coordinates = np.asarray(coordinates, dtype=np.float64)
        if coordinates.ndim == 1:
            coordinates = coordinates.reshape(-1, 1)
        harmonic_load = np.ascontiguousarray(harmonic_load, dtype=np.float64).ravel()
        if constant_load is None:
            constant_load = np.zeros_like(harmonic_load)
        constant_load = np.ascontiguousarray(constant_load, dtype=np.float64).ravel()
        kwargs = dict(
            mass=mass,
            stiffness=stiffness,
            coordinates=np.ascontiguousarray(coordinates),
            contacts=[_contact(k, c) for k, c in enumerate(contacts)],
            harmonic_load=harmonic_load,
            constant_load=constant_load,
            damping_matrix=damping_matrix,
            dirichlet=[int(d) for d in dirichlet],
            dofs_per_node=int(dofs_per_node),
            damping=damping,
            name=name,
            acceleration=None if acceleration is None else [float(a) for a in acceleration],
            max_memory_gib=max_memory_gib,
        )
        native = _native.NativeModel.from_arrays(
            mass=_csc("mass", mass),
            stiffness=_csc("stiffness", stiffness),
            damping_matrix=None if damping_matrix is None else _csc("damping_matrix", damping_matrix),
            coordinates=kwargs["coordinates"],
            dofs_per_node=kwargs["dofs_per_node"],
            dirichlet=kwargs["dirichlet"],
            contacts=kwargs["contacts"],
            harmonic_load=harmonic_load,
            constant_load=constant_load,
            name=name,
            acceleration=kwargs["acceleration"],
            max_memory_gib=max_memory_gib,
            **{k: float(v) if v is not None else None for k, v in damping.items()},
        )
        return cls(native, ("arrays", kwargs))

    def with_overrides(self, overrides: Mapping[str, Any] | Iterable[str]) -> "Model":
        """This model file's model with more overrides (after the ones it was read with),
        e.g. ``base.with_overrides({"contact.gap": 0.1})``: the file is not read again
        (its text travels with the model, so this works on a Dask worker that lacks the
        file; files the model refers to are read again from their path)."""
        if self._recipe[0] != "toml":
            raise ArgumentError("with_overrides applies to models read from a model file (from_toml)")
        _, text, path, sets, max_memory_gib, allow_outside_paths = self._recipe
        return Model._rebuild(("toml", text, path, [*sets, *_overrides(overrides)], max_memory_gib, allow_outside_paths))

    @staticmethod
    def _rebuild(recipe: tuple) -> "Model":
        if recipe[0] == "toml":
            _, text, path, sets, max_memory_gib, allow_outside_paths = recipe
            native = _native.NativeModel.from_toml_text(
                text, path, sets, max_memory_gib, allow_outside_paths
            )
            return Model(native, recipe)
        return Model.from_arrays(**recipe[1])

    def __reduce__(self):
        return (Model._rebuild, (self._recipe,))

    def __eq__(self, other: object) -> bool:
        """Models are equal when built the same way: the same model file text, path,
        overrides (in order) and settings, or equal arrays (sparse matrices by their
        entries). A pickled model equals its original."""
        if not isinstance(other, Model):
            return NotImplemented
        return _same(self._recipe, other._recipe)

    def __hash__(self) -> int:
        if self._recipe[0] == "toml":
            _, text, path, sets, max_memory_gib, allow_outside_paths = self._recipe
            return hash(("toml", text, path, tuple(sets), max_memory_gib, allow_outside_paths))
        return hash(("arrays", self.name, self.n_dofs))

    # --- what it is ---------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The model's name."""
        return self._native.name

    @property
    def n_dofs(self) -> int:
        """Number of DOFs, Dirichlet DOFs included."""
        return self._native.n_dofs

    @property
    def source(self) -> str:
        """The model file's path, or ``<arrays>``."""
        return self._native.source

    @property
    def contact_dofs(self) -> list[list[int]]:
        """The DOFs of each contact."""
        return self._native.contact_dofs

    def arrays(self) -> dict:
        """The model's arrays, in the form :meth:`from_arrays` takes
        (``Model.from_arrays(**model.arrays())`` rebuilds the model): consistent ``mass``,
        ``stiffness`` (and ``damping_matrix``) as ``scipy.sparse.csc_array``,
        ``coordinates``, ``dirichlet``, ``contacts``, loads, ``damping``, ``name``.
        Friction elements and named interfaces are not included."""
        import scipy.sparse as sp

        d = self._native.arrays()
        for key in ("mass", "stiffness", "damping_matrix"):
            if d[key] is not None:
                shape, rows, cols, vals = d[key]
                d[key] = sp.csc_array((vals, (rows, cols)), shape=shape)
        d["contacts"] = [{"dofs": dofs, "w": w, "gap": gap} for dofs, w, gap in d["contacts"]]
        d["damping"] = {k: d.pop(k) for k in _DAMPING_KEYS}
        d.pop("note", None)
        return d

    def __repr__(self) -> str:
        return f"<mshbm.Model {self.name!r}: {self.n_dofs} DOFs, {len(self.contact_dofs)} contacts, from {self.source}>"

    # --- computations (the module-level functions) ---------------------------------------
    def solve(self, frequency: float, harmonics: int | None = None, **options):
        """:func:`mshbm.solve` on this model."""
        from ._api import solve

        return solve(self, frequency, harmonics, **options)

    def frf(self, from_hz: float, to_hz: float, harmonics=None, **options):
        """:func:`mshbm.frf` on this model."""
        from ._api import frf

        return frf(self, from_hz, to_hz, harmonics, **options)

    def modes(self, count: int = 30, **options):
        """:func:`mshbm.modes` on this model."""
        from ._api import modes

        return modes(self, count, **options)

    def simulate(self, frequency: float | None = None, **options):
        """:func:`mshbm.simulate` on this model."""
        from ._api import simulate

        return simulate(self, frequency, **options)
