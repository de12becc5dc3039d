"""Result objects: numpy arrays as attributes, ``to_dict()`` for tables and
``to_dataframe()`` (pandas, optional). Every result is a plain Python object holding the
extension's dict, so it pickles as it is."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

__all__ = ["Solution", "Floquet", "FrequencyResponse", "Branch", "Modes", "Simulation", "SteadyState"]


def _dataframe(columns: dict):
    try:
        import pandas as pd
    except ImportError as e:  # pandas is optional
        raise ImportError("to_dataframe() needs pandas: pip install pandas (or use to_dict())") from e
    return pd.DataFrame(columns)


def _plain(value: Any) -> Any:
    """Arrays and numpy scalars as plain Python (for JSON)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _axes(ax):
    """``ax``, or the axes of a new matplotlib figure (matplotlib is optional)."""
    if ax is not None:
        return ax
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # matplotlib is optional
        raise ImportError("plot() needs matplotlib: pip install matplotlib") from e
    return plt.figure().add_subplot()


def _stability_runs(stable: np.ndarray, fold: np.ndarray) -> list[tuple[bool, np.ndarray]]:
    """The points of a branch that are not folds, cut into runs of equal stability as
    ``mshbm frf --plot`` draws them: ``(unstable, indices)``, each run starting with the
    last point of the one before so that the curve stays connected (a point of unknown
    stability counts as stable)."""
    runs: list[tuple[bool, list[int]]] = []
    for i in np.flatnonzero(~np.asarray(fold, dtype=bool)):
        unstable = bool(stable[i] == 0.0)
        if runs and runs[-1][0] == unstable:
            runs[-1][1].append(int(i))
        else:
            start = [runs[-1][1][-1]] if runs else []
            runs.append((unstable, start + [int(i)]))
    return [(u, np.array(ix, dtype=np.int64)) for u, ix in runs]


class _Result:
    __slots__ = ("_data",)
    #: Where a result's fields live, readable as attributes and listed by ``dir()``: ``""``
    #: for the data itself, a key for a nested dict, None for no such fields.
    _FIELDS: str | None = None
    #: Fields that a property of the same name serves instead.
    _HIDDEN: tuple[str, ...] = ()

    def _fields(self) -> dict:
        data = object.__getattribute__(self, "_data")
        where = type(self)._FIELDS
        if where is None:
            return {}
        return data if where == "" else data[where]

    def __getattr__(self, name):
        fields = self._fields()
        if name in fields and name not in type(self)._HIDDEN:
            return fields[name]
        raise AttributeError(name)

    def __dir__(self):
        fields = {k for k in self._fields() if k.isidentifier() and k not in type(self)._HIDDEN}
        return sorted(set(super().__dir__()) | fields)

    def __init__(self, data: dict):
        self._data = data

    def __getstate__(self):
        return self._data

    def __setstate__(self, state):
        self._data = state

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return json.dumps(_plain(self._data), sort_keys=True) == json.dumps(_plain(other._data), sort_keys=True)


class Floquet(_Result):
    """Floquet multipliers of a periodic solution (docs: README "Stability")."""

    @property
    def multipliers(self) -> np.ndarray:
        """The multipliers, complex."""
        m = self._data["multipliers"]
        if isinstance(m, list):
            return np.zeros(0, dtype=complex)
        return m[:, 0] + 1j * m[:, 1]

    @property
    def max_multiplier(self) -> float:
        """Largest modulus."""
        return self._data["max_multiplier"]

    @property
    def stable(self) -> bool:
        """All multipliers inside the unit circle."""
        return self._data["stable"]

    def to_dict(self) -> dict:
        return dict(self._data)

    def __repr__(self):
        return f"<Floquet: {'stable' if self.stable else 'unstable'}, largest modulus {self.max_multiplier:.6f}>"


class Solution(_Result):
    """One periodic solution (``mshbm solve``): the fields of ``mshbm solve --json`` as
    attributes (``frequency_hz`` [Hz], ``time_s`` [s], displacements, gaps in the model's
    length unit, contact forces in its force unit), with ``label`` (the method),
    ``path`` (how Newton got there), ``others`` (other solutions met at the frequency by a
    sweep) and ``stability`` (:class:`Floquet` or None)."""

    _FIELDS = "solution"

    @property
    def label(self) -> str:
        return self._data.get("label", "")

    @property
    def field_dofs(self) -> np.ndarray | None:
        """The model DOFs of ``field_harmonics`` (``solve(dofs=…)``), or None."""
        d = self._data.get("field_dofs")
        return None if d is None else np.asarray(d, dtype=np.int64)

    @property
    def field_harmonics(self) -> np.ndarray | None:
        """Fourier coefficients ``[a0, a1, b1, …, aH, bH]`` of the displacement of each of
        ``field_dofs`` (rows), ``q(t) = a0 + Σ a_k cos kωt + b_k sin kωt``; None unless
        ``solve(dofs=…)``."""
        return self._data.get("field_harmonics")

    @property
    def field_complex(self) -> np.ndarray | None:
        """``field_harmonics`` as complex amplitudes ``c_0 = a0``, ``c_k = a_k − i b_k``
        (``q(t) = Re Σ_k c_k e^{ikωt}``), shape (DOFs, H + 1); None unless ``solve(dofs=…)``."""
        f = self.field_harmonics
        if f is None:
            return None
        c = np.empty((f.shape[0], (f.shape[1] + 1) // 2), dtype=complex)
        c[:, 0] = f[:, 0]
        c[:, 1:] = f[:, 1::2] - 1j * f[:, 2::2]
        return c

    @property
    def path(self) -> dict:
        return self._data.get("path", {"kind": "direct"})

    @property
    def stability_error(self) -> str | None:
        """Why the multipliers of a converged solution could not be computed."""
        return self._data.get("stability_error")

    @property
    def others(self) -> list["Solution"]:
        return [Solution({"solution": s}) for s in self._data.get("others", [])]

    @property
    def stability(self) -> Floquet | None:
        s = self._data["solution"].get("stability")
        return None if s is None else Floquet(s)

    @property
    def contact_displacement(self) -> np.ndarray:
        """Displacement of each contact's first DOF over one period, (contacts, samples)."""
        return np.array([c["displacement"] for c in self._data["solution"]["contacts"]])

    @property
    def contact_gap(self) -> np.ndarray:
        """Gap of each contact over one period, (contacts, samples)."""
        return np.array([c["gap"] for c in self._data["solution"]["contacts"]])

    @property
    def contact_force(self) -> np.ndarray:
        """Contact force of each contact over one period, (contacts, samples)."""
        return np.array([c["force"] for c in self._data["solution"]["contacts"]])

    @property
    def friction_force(self) -> np.ndarray:
        """Tangential (friction) force of each contact with friction over one period,
        (contacts, samples); empty without friction."""
        return np.array([f["force"] for f in self._contact_frictions()])

    @property
    def friction_force_2(self) -> np.ndarray:
        """On a 3D interface (the Coulomb cone): the friction force along each contact's
        second tangent, (contacts, samples); ``friction_force`` is then along the first.
        Empty on plane interfaces."""
        return np.array([f.get("force2", []) for f in self._contact_frictions() if f.get("force2")])

    @property
    def friction_limit(self) -> np.ndarray:
        """Its bound ``μ λ_N`` at each sample, (contacts, samples)."""
        return np.array([f["limit"] for f in self._contact_frictions()])

    @property
    def contact_state(self) -> np.ndarray:
        """State of each contact with friction at each sample (``"open"``, ``"stick"``,
        ``"slip"``), (contacts, samples); empty without friction."""
        return np.array([f["state"] for f in self._contact_frictions()], dtype=object)

    @property
    def state_fractions(self) -> np.ndarray:
        """Fractions of the period each contact with friction spends in stick, slip and
        open (exact, they sum to 1), (contacts, 3); empty without friction."""
        rows = self._data["solution"].get("state_fractions") or []
        return np.array([[r["stick"], r["slip"], r["open"]] for r in rows]).reshape(-1, 3)

    @property
    def dissipated_energy(self) -> float | None:
        """Energy the friction forces dissipate per period (force × length unit), or None
        without friction on the contacts."""
        return self._data["solution"].get("dissipated_energy")

    def _contact_frictions(self) -> list:
        s = self._data["solution"]
        return [f for f in s.get("frictions", []) if "state" in f]

    @property
    def harmonics_of_contacts(self) -> np.ndarray:
        """Fourier coefficients [a0, a1, b1, …, aH, bH] of each contact displacement."""
        return np.array([c["coefficients"] for c in self._data["solution"]["contacts"]])

    def plot(self, ax=None):
        """The first contact's displacement over one period against time [µs], as
        ``mshbm solve --plot`` draws it, on ``ax`` (a matplotlib Axes; a new figure when
        None). Returns the Axes."""
        ax = _axes(ax)
        s = self._data["solution"]
        contact = s["contacts"][0]
        ax.plot(np.asarray(s["time_s"]) * 1e6, contact["displacement"], label=f"H = {s['harmonics']}")
        ax.set_xlabel("time [µs]")
        ax.set_ylabel("contact displacement q_N")
        ax.set_title(f"Contact displacement over one period at {s['frequency_hz'] / 1e3:.4f} kHz")
        ax.legend()
        return ax

    def to_json(self) -> str:
        """The solution as ``mshbm solve --json`` writes it (a start for ``simulate``)."""
        return json.dumps(_plain(self._data["solution"]))

    def to_dict(self) -> dict:
        """The time series over one period as columns, as ``mshbm solve --output``:
        ``time_s``, then ``q_dof{d}``, ``gap_c{k}``, ``force_c{k}`` per contact (with
        friction also ``friction_c{k}`` and ``state_c{k}``, and on a 3D interface
        ``friction2_c{k}`` along the second tangent)."""
        s = self._data["solution"]
        columns = {"time_s": s["time_s"]}
        frictions = self._contact_frictions()
        for k, c in enumerate(s["contacts"]):
            columns[f"q_dof{c['dof']}"] = c["displacement"]
            columns[f"gap_c{k}"] = c["gap"]
            columns[f"force_c{k}"] = c["force"]
            if k < len(frictions):
                columns[f"friction_c{k}"] = frictions[k]["force"]
                if frictions[k].get("force2"):
                    columns[f"friction2_c{k}"] = frictions[k]["force2"]
                columns[f"state_c{k}"] = frictions[k]["state"]
        return columns

    def to_dataframe(self):
        """:meth:`to_dict` as a pandas DataFrame."""
        return _dataframe(self.to_dict())

    def __repr__(self):
        s = self._data["solution"]
        return (
            f"<Solution {s['method']} at {s['frequency_hz']} Hz, H = {s['harmonics']}: "
            f"converged {s['converged']} after {s['iterations']} iterations>"
        )


_BRANCH_COLUMNS = (
    "frequency_hz",
    "max_qn",
    "min_qn",
    "amplitude_h1",
    "residual_norm",
    "newton_iterations",
    "fold",
    "stable",
    "max_multiplier",
    "max_penetration",
    "dissipated_energy",
    "stick",
    "slip",
    "open",
)


class Branch(_Result):
    """One branch of a diagram: per point, numpy arrays ``frequency_hz`` [Hz], ``max_qn``,
    ``min_qn`` (extremes of the response DOF, length unit), ``amplitude_h1``,
    ``residual_norm``, ``newton_iterations``, ``fold`` (bool: a located fold),
    ``stable`` (1.0, 0.0, NaN when not computed), ``max_multiplier`` and
    ``max_penetration`` (NaN when not computed), ``dissipated_energy`` (per period) and
    ``stick``, ``slip``, ``open`` (fractions of the period, mean over the contacts; NaN
    without friction on the contacts), ``state_fractions`` ((points, contacts, 3): stick,
    slip, open per contact, or None); and ``harmonics``, ``method``, ``label``,
    ``penalty``, ``stop`` (why it ended), ``completed``."""

    _FIELDS = ""

    def __len__(self):
        return len(self._data["frequency_hz"])

    def __repr__(self):
        return f"<Branch {self.label}: {len(self)} points, {self.stop}>"


class FrequencyResponse(_Result):
    """A frequency response diagram (``mshbm frf``): ``branches`` (one :class:`Branch`
    per method and H), ``folds`` and ``bifurcations`` (lists of dicts, frequencies in
    Hz), ``completed``, ``stop_reason`` (None when every branch reached the end; else
    the first branch that stopped and why, e.g. stopped by the callback) and
    ``stopped_by_callback``."""

    @property
    def branches(self) -> list[Branch]:
        return [Branch(b) for b in self._data["branches"]]

    @property
    def folds(self) -> list[dict]:
        return self._data["folds"]

    @property
    def bifurcations(self) -> list[dict]:
        return self._data["bifurcations"]

    @property
    def completed(self) -> bool:
        return self._data["completed"]

    @property
    def stop_reason(self) -> str | None:
        return self._data["stop_reason"]

    @property
    def stopped_by_callback(self) -> bool:
        return self._data["stopped_by_callback"]

    def to_dict(self) -> dict:
        """Every point of every branch as columns (the CLI's CSV columns ``frequency_hz,
        harmonics, max_qn, min_qn, amplitude_h1, residual_norm, newton_iterations, fold,
        stable, max_multiplier``, then ``max_penetration, dissipated_energy, stick, slip,
        open, method, penalty, label``)."""
        branches = self._data["branches"]
        columns: dict[str, Any] = {}
        n = [len(b["frequency_hz"]) for b in branches]
        for key in _BRANCH_COLUMNS:
            parts = [np.asarray(b[key]) for b in branches]
            columns[key] = np.concatenate(parts) if parts else np.zeros(0)
            if key == "frequency_hz":
                columns["harmonics"] = np.repeat([b["harmonics"] for b in branches], n).astype(np.int64)
        columns["method"] = np.repeat([b["method"] for b in branches], n).astype(object)
        columns["penalty"] = np.repeat(
            [np.nan if b["penalty"] is None else b["penalty"] for b in branches], n
        ).astype(np.float64)
        columns["label"] = np.repeat([b["label"] for b in branches], n).astype(object)
        return columns

    def plot(self, ax=None):
        """The diagram as ``mshbm frf --plot`` draws it, on ``ax`` (a matplotlib Axes; a
        new figure when None): per branch the response DOF's maximum and minimum against
        the frequency (in kHz when it reaches 1 kHz), unstable parts dashed, the folds
        marked. Returns the Axes."""
        ax = _axes(ax)
        branches = self._data["branches"]
        highest = max((float(np.max(b["frequency_hz"])) for b in branches if len(b["frequency_hz"])), default=0.0)
        per_unit, unit = (1e3, "kHz") if highest >= 1e3 else (1.0, "Hz")
        for k, b in enumerate(branches):
            color = f"C{k}"
            f = np.asarray(b["frequency_hz"]) / per_unit
            labelled = False
            for unstable, ix in _stability_runs(np.asarray(b["stable"], dtype=float), np.asarray(b["fold"])):
                style = "--" if unstable else "-"
                for values in (b["max_qn"], b["min_qn"]):
                    label = None if labelled else f"{b['label']} (max, min)"
                    labelled = True
                    ax.plot(f[ix], np.asarray(values)[ix], style, color=color, label=label)
        if self.folds:
            ax.plot(
                [fo["frequency_hz"] / per_unit for fo in self.folds],
                [fo["min_qn"] for fo in self.folds],
                "o",
                color="C7",
                label="folds",
            )
        # the bifurcations that are not folds, where the stability changes
        for kind, name, color in (("period-doubling", "period doubling", "C3"), ("neimark-sacker", "Neimark-Sacker", "C4")):
            at = [bi for bi in self.bifurcations if bi["kind"] == kind]
            if at:
                ax.plot(
                    [bi["frequency_hz"] / per_unit for bi in at for _ in (0, 1)],
                    [v for bi in at for v in (bi["max_qn"], bi["min_qn"])],
                    "o",
                    mfc="none",
                    color=color,
                    label=name,
                )
        ax.set_xlabel(f"frequency [{unit}]")
        ax.set_ylabel("displacement of the response DOF (max, min)")
        ax.set_title("Frequency response")
        ax.legend()
        return ax

    def to_dataframe(self, table: str = "points"):
        """:meth:`to_dict` as a pandas DataFrame; ``table="folds"`` or
        ``"bifurcations"``: one row per fold or stability change (as ``frf --json``)."""
        if table == "points":
            return _dataframe(self.to_dict())
        if table in ("folds", "bifurcations"):
            rows = self._data[table]
            keys = ["harmonics", "label", "kind", "frequency_hz", "max_qn", "min_qn", "amplitude_h1", "at_kink"]
            keys = [k for k in keys if any(k in r for r in rows)] if rows else keys[:1] + keys[3:4]
            return _dataframe({k: [r.get(k) for r in rows] for k in keys})
        raise ValueError(f"table={table!r}: expected 'points', 'folds' or 'bifurcations'")

    def __repr__(self):
        n = sum(len(b["frequency_hz"]) for b in self._data["branches"])
        state = "complete" if self.completed else f"incomplete ({self.stop_reason})"
        return f"<FrequencyResponse: {len(self._data['branches'])} branches, {n} points, {len(self.folds)} folds, {state}>"


class Modes(_Result):
    """Eigenfrequencies [Hz] of the consistent (``original_hz``) and the redistributed
    (``redistributed_hz``) model, ``relative_error`` = f_redistributed / f_original − 1,
    and the ``norm`` of the redistribution (``mshbm modes``)."""

    _FIELDS = ""

    def to_dict(self) -> dict:
        n = len(self._data["original_hz"])
        return {
            "mode": np.arange(1, n + 1),
            "original_hz": self._data["original_hz"],
            "redistributed_hz": self._data["redistributed_hz"],
            "relative_error": self._data["relative_error"],
        }

    def to_dataframe(self):
        return _dataframe(self.to_dict())

    def __repr__(self):
        return f"<Modes: {len(self._data['original_hz'])} eigenfrequencies>"


class SteadyState(_Result):
    """The periodic steady state found by simulation: ``solution`` (:class:`Solution`,
    the last period), ``periodic``, ``periods_simulated``, ``period_scatter``,
    ``tolerance``, … (the fields of ``mshbm simulate --steady-state --json``)."""

    _FIELDS = ""

    @property
    def solution(self) -> Solution:
        """The last period as a :class:`Solution` (the steady state's fields are the
        solution's, flattened as in ``mshbm simulate --steady-state --json``)."""
        return Solution({"solution": self._data})


class Simulation(_Result):
    """A time integration (``mshbm simulate``): ``time_s`` [s], ``gaps`` and ``forces``
    (steps × contacts; length and force units), ``energy``, ``dt`` [s], ``scheme``, and
    ``steady_state`` (:class:`SteadyState` or None)."""

    _FIELDS = ""
    _HIDDEN = ("steady_state",)

    @property
    def steady_state(self) -> SteadyState | None:
        s = self._data["steady_state"]
        return None if s is None else SteadyState(s)

    def to_dict(self) -> dict:
        """Columns as ``mshbm simulate --output``: ``time_s``, ``gap_c{k}``,
        ``force_c{k}``, ``energy``."""
        columns = {"time_s": self._data["time_s"]}
        for k in range(self._data["gaps"].shape[1]):
            columns[f"gap_c{k}"] = self._data["gaps"][:, k]
            columns[f"force_c{k}"] = self._data["forces"][:, k]
        columns["energy"] = self._data["energy"]
        return columns

    def to_dataframe(self):
        return _dataframe(self.to_dict())

    def __repr__(self):
        return f"<Simulation: {len(self._data['time_s'])} steps of {self._data['dt']:.3e} s, {self._data['scheme']}>"
