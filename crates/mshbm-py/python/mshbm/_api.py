"""The computations: thin wrappers over the extension, with the CLI's defaults."""

from __future__ import annotations

from typing import Any, Callable, Iterable

from . import _native
from ._model import Model
from ._native import ArgumentError, NotConvergedError
from ._results import Floquet, FrequencyResponse, Modes, Simulation, Solution

__all__ = ["solve", "frf", "modes", "simulate", "stability"]


def _model(model: Any) -> Model:
    if not isinstance(model, Model):
        raise ArgumentError(f"expected an mshbm.Model, got {type(model).__name__}")
    return model


def _penalties(penalty: Any) -> list[str]:
    """``1e8``, ``"100x"`` or a list of them, as the CLI's ``--penalty`` strings."""
    if penalty is None:
        return []
    if isinstance(penalty, (str, int, float)):
        penalty = [penalty]
    return [p if isinstance(p, str) else repr(float(p)) for p in penalty]


def _harmonics(harmonics: Any) -> list[int]:
    if isinstance(harmonics, int):
        return [harmonics]
    return [int(h) for h in harmonics]


def solve(
    model: Model,
    frequency: float,
    harmonics: int = 5,
    *,
    method: str = "redistributed",
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: float | str | None = None,
    tolerance: float = 1e-10,
    max_iterations: int = 50,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str = "auto",
    receptance_modes: int | None = None,
    jacobian: str = "auto",
    stability: bool = True,
    start: str | Solution = "auto",
    sweep_from: float | None = None,
    sweep_to: float | None = None,
    threads: int | None = None,
) -> Solution:
    """One periodic solution at ``frequency`` [Hz] (``mshbm solve``), with its Floquet
    multipliers (``stability=False`` skips them).

    ``harmonics``: H. ``method``: ``"redistributed"`` (default, the paper's MS-HBM),
    ``"hbm-aft"`` (penalty contact; ``penalty`` a stiffness [force/length] or
    ``"100x"`` the contact stiffness, the default; ``mass`` ``"consistent"`` or
    ``"redistributed"``) or ``"mshbm"`` (the general MS-HBM). ``samples``: samples per
    period (default max(256, 16(2H+1))); ``quadrature``: ``"exact"`` or ``"sampled"``;
    ``tolerance``: Newton's max-norm residual relative to the model's length scale;
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
    frequency (``others``). ``threads``: threads this call may use (default all cores).

    Raises :class:`NotConvergedError` (its ``result`` holds the unconverged solution)
    with the CLI's message when Newton does not converge.
    """
    # a start solution goes to the library as the CLI's --from-solution JSON: the library
    # refuses one of another method or model (PeriodicSolution::unusable_start)
    if isinstance(start, Solution):
        start_kind, start_solution = "auto", start.to_json()
    else:
        start_kind, start_solution = start, None
    data = _native.solve(
        _model(model)._native,
        float(frequency),
        int(harmonics),
        method=method,
        samples=samples,
        quadrature=quadrature,
        mass=mass,
        penalty=_penalties(penalty),
        tolerance=float(tolerance),
        max_iterations=int(max_iterations),
        dof=dof,
        stability_modes=stability_modes,
        receptance=receptance,
        receptance_modes=receptance_modes,
        jacobian=jacobian,
        stability=bool(stability),
        start=start_kind,
        start_solution=start_solution,
        sweep_from=sweep_from,
        sweep_to=sweep_to,
        threads=threads,
    )
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
    harmonics: int | Iterable[int] = 5,
    *,
    method: str = "redistributed",
    samples: int | None = None,
    quadrature: str | None = None,
    mass: str | None = None,
    penalty: float | str | Iterable[float | str] | None = None,
    tolerance: float = 1e-10,
    max_iterations: int = 50,
    dof: int | None = None,
    stability_modes: int | None = None,
    receptance: str = "auto",
    receptance_modes: int | None = None,
    jacobian: str = "auto",
    step: float = 0.01,
    max_step: float = 0.1,
    min_step: float = 1e-12,
    max_turn: float = 20.0,
    stability: bool = False,
    overlay_mshbm: bool = False,
    max_points: int | None = None,
    callback: Callable[[dict], Any] | None = None,
    threads: int | None = None,
) -> FrequencyResponse:
    """The frequency response diagram from ``from_hz`` to ``to_hz`` [Hz] by
    pseudo-arclength continuation (``mshbm frf``), one branch per H of ``harmonics``
    (and per ``penalty`` with ``method="hbm-aft"``), folds located.

    Options as :func:`solve`, and: ``step``, ``max_step``, ``min_step`` (arclength
    steps, dimensionless), ``max_turn`` [degrees], ``stability`` (multipliers of every
    point), ``overlay_mshbm`` (with hbm-aft: also the MS-HBM), ``max_points`` per branch
    (default 20000).

    ``callback(point)`` is called at every point with a dict (``label``, ``harmonics``,
    ``frequency_hz``, ``max_qn``, ``min_qn``, ``amplitude_h1``, ``fold``, ``stable``,
    ``points``, ``step``, …): returning ``False`` stops the diagram, and what was found
    is returned with ``completed=False``, ``stopped_by_callback=True`` and the
    ``stop_reason``; an exception in the callback stops it and propagates.

    A branch that stops early (e.g. a step too small at a sharp turn) does not raise: the
    result says so (``completed``, ``stop_reason``, each branch's ``stop``).
    """
    data = _native.frf(
        _model(model)._native,
        float(from_hz),
        float(to_hz),
        _harmonics(harmonics),
        method=method,
        samples=samples,
        quadrature=quadrature,
        mass=mass,
        penalty=_penalties(penalty),
        tolerance=float(tolerance),
        max_iterations=int(max_iterations),
        dof=dof,
        stability_modes=stability_modes,
        receptance=receptance,
        receptance_modes=receptance_modes,
        jacobian=jacobian,
        step=float(step),
        max_step=float(max_step),
        min_step=float(min_step),
        max_turn=float(max_turn),
        stability=bool(stability),
        overlay_mshbm=bool(overlay_mshbm),
        max_points=max_points,
        callback=callback,
        threads=threads,
    )
    return FrequencyResponse(data)


def modes(model: Model, count: int = 30, *, threads: int | None = None) -> Modes:
    """The first ``count`` eigenfrequencies [Hz] of the consistent and the redistributed
    model and their relative difference (``mshbm modes``)."""
    return Modes(_native.modes(_model(model)._native, int(count), threads=threads))


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
    periodicity: str = "response",
    tolerance: float | None = None,
    harmonics: int = 10,
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
    (``periodicity`` ``"response"`` or ``"state"``, ``tolerance``, ``harmonics`` of the
    reported solution, ``periods`` the limit, default 1000); raises
    :class:`NotConvergedError` (with ``result``) when it does not become periodic.
    ``start``: a :class:`Solution` to start from. ``record=False`` keeps no time series.
    """
    data = _native.simulate(
        _model(model)._native,
        None if frequency is None else float(frequency),
        periods=periods,
        duration=duration,
        steps_per_period=steps_per_period,
        dt=dt,
        scheme=scheme,
        restitution=restitution,
        theta=theta,
        steady_state=bool(steady_state),
        periodicity=periodicity,
        tolerance=tolerance,
        harmonics=int(harmonics),
        dof=dof,
        start_solution=None if start is None else start.to_json(),
        record=bool(record),
        threads=threads,
    )
    why = data.pop("not_periodic")
    result = Simulation(data)
    if why is not None:
        err = NotConvergedError(why)
        err.result = result
        raise err
    return result
