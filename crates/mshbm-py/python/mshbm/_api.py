"""The computations: thin wrappers over the extension. Every default and check is the
library's request layer (``mshbm::request``, shared with the CLI): an option left at
``None`` takes the library's default, named in each docstring. What is checked here is only
the translation of Python values: a number of the wrong type or a negative count is refused
naming the argument (:class:`ArgumentTypeError`, :class:`ArgumentError`)."""

from __future__ import annotations

import numbers
from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from . import _native
from ._native import ArgumentError, NotConvergedError
from ._results import Floquet, FrequencyResponse, Modes, Simulation, Solution

if TYPE_CHECKING:  # for annotations only: _model imports this module (Model.solve, …)
    from ._model import Model

__all__ = ["solve", "frf", "modes", "simulate", "stability"]


def _stopping_on_numpy_false(
    callback: Callable[[dict[str, Any]], Any] | None,
) -> Callable[[dict[str, Any]], Any] | None:
    """``callback`` with a numpy ``False`` (a comparison of arrays' values) returned as
    ``False``, which stops the diagram like Python's."""
    if callback is None:
        return None

    def call(point: dict[str, Any]) -> Any:
        answer = callback(point)
        return False if isinstance(answer, np.bool_) and not answer else answer

    return call


def _field_dofs(dofs: str | Iterable[int], n_dofs: int) -> list[int]:
    """The model DOFs of ``dofs=``: ``"all"`` or DOF numbers (integers, in range)."""
    if isinstance(dofs, str):
        if dofs != "all":
            raise ArgumentError(f"dofs={dofs!r}: expected 'all' or a list of DOF numbers")
        return list(range(n_dofs))
    try:
        chosen = list(dofs)
    except TypeError:
        raise ArgumentError(f"dofs={dofs!r}: expected 'all' or a list of DOF numbers") from None
    for d in chosen:
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)):
            raise ArgumentError(f"dofs: {d!r} is not a DOF number (an integer)")
        if not 0 <= d < n_dofs:
            raise ArgumentError(f"dofs: DOF {d} is out of range (the model has {n_dofs} DOFs)")
    return [int(d) for d in chosen]


def _model(model: Any) -> Model:
    """``model`` if it is an :class:`mshbm.Model` (one that holds a native model)."""
    if not isinstance(getattr(model, "_native", None), _native.NativeModel):
        raise ArgumentError(f"expected an mshbm.Model, got {type(model).__name__}")
    return model


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of the wrong type: an :class:`ArgumentError` (a ``ValueError``) and a
    ``TypeError``, naming the argument. Numbers are never coerced: ``harmonics=3.7`` or
    ``frequency="30000"`` are refused, not truncated or parsed."""


def _integer(name: str, value: Any) -> int | None:
    """``value`` as a non-negative integer (``None`` passes), or an error naming ``name``:
    bools, floats and strings are refused, negative counts are refused before they reach
    the library's unsigned integers."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _naming(
            ArgumentTypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}"),
            name,
        )
    if value < 0:
        raise _naming(ArgumentError(f"{name} must be an integer ≥ 0, got {int(value)}"), name)
    return int(value)


def _real(name: str, value: Any) -> float | None:
    """``value`` as a float (``None`` passes), or an error naming ``name`` (bools, strings
    and complex numbers are refused; the library checks the range)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _naming(
            ArgumentTypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}"),
            name,
        )
    return float(value)


def _naming(err: ArgumentError, name: str) -> ArgumentError:
    """``err`` with its ``argument`` attribute, the keyword at fault (as the library's
    argument errors carry it)."""
    err.argument = name  # type: ignore[attr-defined]
    return err


def _penalties(penalty: Any) -> list[str]:
    """``1e8``, ``"100x"`` or a list of them, as the CLI's ``--penalty`` strings."""
    if penalty is None:
        return []
    if isinstance(penalty, (str, int, float)):
        penalty = [penalty]
    return [p if isinstance(p, str) else repr(float(p)) for p in penalty]


def _tangential(penalty: Any) -> str | None:
    """``tangential_penalty`` as the CLI's ``--tangential-penalty`` string."""
    if penalty is None or isinstance(penalty, str):
        return penalty
    return repr(float(penalty))


def _harmonics(harmonics: Any) -> list[int] | None:
    if harmonics is None:
        return None
    if isinstance(harmonics, (numbers.Integral, bool, float, str)):
        return [_integer("harmonics", harmonics)]  # type: ignore[list-item]
    return [_integer("harmonics", h) for h in harmonics]  # type: ignore[misc]


def solve(
    model: Model,
    frequency: float,
    harmonics: int | None = None,
    *,
    method: str | None = None,
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: float | str | None = None,
    tangential_penalty: float | str | None = None,
    tolerance: float | None = None,
    max_iterations: int | None = None,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str | None = None,
    receptance_modes: int | None = None,
    jacobian: str | None = None,
    stability: bool | None = None,
    start: str | Solution | None = None,
    sweep_from: float | None = None,
    sweep_to: float | None = None,
    dofs: str | Iterable[int] | None = None,
    threads: int | None = None,
) -> Solution:
    """One periodic solution at ``frequency`` [Hz] (``mshbm solve``), with its Floquet
    multipliers (``stability=False`` skips them).

    ``harmonics``: H (default 5). ``method``: ``"redistributed"`` (default, the paper's MS-HBM),
    ``"hbm-aft"`` (penalty contact; ``penalty`` a stiffness [force/length] or
    ``"100x"`` the contact stiffness, the default; ``mass`` ``"consistent"`` or
    ``"redistributed"``) or ``"mshbm"`` (the general MS-HBM). ``samples``: samples per
    period (default max(256, 16(2H+1))); ``quadrature``: ``"exact"`` or ``"sampled"``;
    ``tolerance``: Newton's max-norm residual relative to the model's length scale
    (default 1e-10; ``max_iterations`` default 50); ``tangential_penalty``: hbm-aft's
    tangential stiffness on contacts with friction (default the normal one);
    ``dof``: the response DOF (default: the first contact's). ``receptance``:
    ``"auto"`` (modal above 20 000 DOFs with a stiffness factor of more than 40 values per
    DOF, exact otherwise), ``"exact"`` or ``"modal"`` (the
    lowest ``receptance_modes`` modes, default 200, plus the exact static compliance;
    docs/theory.md §17). ``jacobian``: Newton's linear systems, ``"auto"`` (dense below
    1000 unknowns, the operator above), ``"dense"`` (LU) or ``"operator"`` (GMRES on the
    Jacobian's action; docs/theory.md §18). ``start``: ``"auto"``
    (linear response, then continuation from a lower frequency if Newton fails),
    ``"linear"``, or a :class:`Solution` to start from (``--from-solution``);
    ``sweep_from``/``sweep_to`` [Hz]: trace the branch and list every solution at the
    frequency (``others``). ``dofs``: ``"all"`` or a list of model DOFs whose harmonics
    the solution keeps (``field_dofs``, ``field_harmonics``, ``field_complex``: the
    displacement field of the whole structure, as ``mshbm solve --vtk`` writes it).
    ``threads``: threads this call may use (default all cores).

    Raises :class:`NotConvergedError` (its ``result`` holds the unconverged solution)
    with the CLI's message when Newton does not converge.
    """
    # a start solution goes to the library as the CLI's --from-solution JSON: the library
    # refuses one of another method or model (PeriodicSolution::unusable_start)
    if isinstance(start, Solution):
        start_kind, start_solution = None, start.to_json()
    else:
        start_kind, start_solution = start, None
    data = _native.solve(
        _model(model)._native,
        _real("frequency", frequency),
        _integer("harmonics", harmonics),
        method=method,
        samples=_integer("samples", samples),
        quadrature=quadrature,
        mass=mass,
        penalty=_penalties(penalty),
        tangential_penalty=_tangential(tangential_penalty),
        tolerance=_real("tolerance", tolerance),
        max_iterations=_integer("max_iterations", max_iterations),
        dof=_integer("dof", dof),
        stability_modes=_integer("stability_modes", stability_modes),
        receptance=receptance,
        receptance_modes=_integer("receptance_modes", receptance_modes),
        jacobian=jacobian,
        stability=stability,
        start=start_kind,
        start_solution=start_solution,
        sweep_from=_real("sweep_from", sweep_from),
        sweep_to=_real("sweep_to", sweep_to),
        field=dofs is not None,
        threads=_integer("threads", threads),
    )
    if dofs is not None:
        field = data.pop("field_harmonics")
        data["field_dofs"] = _field_dofs(dofs, field.shape[0])
        data["field_harmonics"] = field[data["field_dofs"]]
    why = data.pop("not_converged")
    solution = Solution(data)
    if why is not None:
        err = NotConvergedError(why)
        err.result = solution
        raise err
    return solution


def stability(model: Model, frequency: float, harmonics: int = 5, **options) -> Floquet:
    """The Floquet multipliers of the periodic solution at ``frequency`` [Hz] (the
    redistributed MS-HBM; ``stability_modes`` sets the reduced basis). Takes the options
    of :func:`solve`; raises :class:`NotConvergedError` when Newton does not converge or
    the multipliers cannot be computed."""
    options["stability"] = True
    s = solve(model, frequency, harmonics, **options)
    if s.stability is None:
        raise NotConvergedError(
            f"stability not computed: {s.stability_error or 'the method provides no Floquet multipliers'}"
        )
    return s.stability


def frf(
    model: Model,
    from_hz: float,
    to_hz: float,
    harmonics: int | Iterable[int] | None = None,
    *,
    method: str | None = None,
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: float | str | Iterable[float | str] | None = None,
    tangential_penalty: float | str | None = None,
    tolerance: float | None = None,
    max_iterations: int | None = None,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str | None = None,
    receptance_modes: int | None = None,
    jacobian: str | None = None,
    step: float | None = None,
    max_step: float | None = None,
    min_step: float | None = None,
    max_turn: float | None = None,
    stability: bool | None = None,
    overlay_mshbm: bool | None = None,
    max_points: int | None = None,
    callback: Callable[[dict], Any] | None = None,
    threads: int | None = None,
) -> FrequencyResponse:
    """The frequency response diagram from ``from_hz`` to ``to_hz`` [Hz] by
    pseudo-arclength continuation (``mshbm frf``), one branch per H of ``harmonics``
    (and per ``penalty`` with ``method="hbm-aft"``), folds located.

    Options as :func:`solve`, and: ``step``, ``max_step``, ``min_step`` (arclength
    steps, dimensionless; default 0.01, 0.1, 1e-12), ``max_turn`` [degrees, default 20], ``stability`` (multipliers of every
    point), ``overlay_mshbm`` (with hbm-aft: also the MS-HBM), ``max_points`` per branch
    (default 20000).

    ``callback(point)`` is called at every point with a dict (``label``, ``harmonics``,
    ``frequency_hz``, ``max_qn``, ``min_qn``, ``amplitude_h1``, ``fold``, ``stable``,
    ``points``, ``step``, …): returning ``False`` (or ``numpy.False_``) stops the diagram, and what was found
    is returned with ``completed=False``, ``stopped_by_callback=True`` and the
    ``stop_reason``; an exception in the callback stops it and propagates.

    A branch that stops early (e.g. a step too small at a sharp turn) does not raise: the
    result says so (``completed``, ``stop_reason``, each branch's ``stop``).
    """
    data = _native.frf(
        _model(model)._native,
        _real("from_hz", from_hz),
        _real("to_hz", to_hz),
        _harmonics(harmonics),
        method=method,
        samples=_integer("samples", samples),
        quadrature=quadrature,
        mass=mass,
        penalty=_penalties(penalty),
        tangential_penalty=_tangential(tangential_penalty),
        tolerance=_real("tolerance", tolerance),
        max_iterations=_integer("max_iterations", max_iterations),
        dof=_integer("dof", dof),
        stability_modes=_integer("stability_modes", stability_modes),
        receptance=receptance,
        receptance_modes=_integer("receptance_modes", receptance_modes),
        jacobian=jacobian,
        step=_real("step", step),
        max_step=_real("max_step", max_step),
        min_step=_real("min_step", min_step),
        max_turn=_real("max_turn", max_turn),
        stability=stability,
        overlay_mshbm=overlay_mshbm,
        max_points=_integer("max_points", max_points),
        callback=_stopping_on_numpy_false(callback),
        threads=_integer("threads", threads),
    )
    return FrequencyResponse(data)


def modes(model: Model, count: int = 30, *, threads: int | None = None) -> Modes:
    """The first ``count`` eigenfrequencies [Hz] of the consistent and the redistributed
    model and their relative difference (``mshbm modes``)."""
    return Modes(
        _native.modes(
            _model(model)._native, _integer("count", count), threads=_integer("threads", threads)
        )
    )


def simulate(
    model: Model,
    frequency: float | None = None,
    *,
    periods: float | None = None,
    duration: float | None = None,
    steps_per_period: int | None = None,
    dt: float | None = None,
    scheme: str | None = None,
    restitution: float | None = None,
    theta: float | None = None,
    steady_state: bool = False,
    periodicity: str | None = None,
    tolerance: float | None = None,
    harmonics: int | None = None,
    dof: int | None = None,
    start: Solution | None = None,
    record: bool = True,
    threads: int | None = None,
) -> Simulation:
    """Reference time integration (``mshbm simulate``): ``scheme`` ``"moreau"``
    (Moreau–Jean with impacts; ``restitution``, ``theta``) or ``"redistributed"``
    (position-level Newmark on the redistributed mass; the default with contacts).
    ``frequency`` [Hz] of the harmonic load; ``periods`` or ``duration`` [s];
    ``steps_per_period`` (default 2000 forced, 8000 free) or ``dt`` [s].
    ``steady_state``: integrate period by period until the response repeats
    (``periodicity`` ``"response"`` (default) or ``"state"``, ``tolerance``, ``harmonics`` of
    the reported solution (default 10), ``periods`` the limit, default 1000); raises
    :class:`NotConvergedError` (with ``result``) when it does not become periodic.
    ``start``: a :class:`Solution` to start from. ``record=False`` keeps no time series.
    """
    data = _native.simulate(
        _model(model)._native,
        _real("frequency", frequency),
        periods=_real("periods", periods),
        duration=_real("duration", duration),
        steps_per_period=_integer("steps_per_period", steps_per_period),
        dt=_real("dt", dt),
        scheme=scheme,
        restitution=_real("restitution", restitution),
        theta=_real("theta", theta),
        steady_state=bool(steady_state),
        periodicity=periodicity,
        tolerance=_real("tolerance", tolerance),
        harmonics=_integer("harmonics", harmonics),
        dof=_integer("dof", dof),
        start_solution=None if start is None else start.to_json(),
        record=bool(record),
        threads=_integer("threads", threads),
    )
    why = data.pop("not_periodic")
    result = Simulation(data)
    if why is not None:
        err = NotConvergedError(why)
        err.result = result
        raise err
    return result
