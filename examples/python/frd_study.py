"""A parameter study on Dask: one frequency response diagram per task over a grid of
gap × damping × force amplitude of the paper's bar (examples/clamped_bar.toml), gathered
into one table and drawn as an overlay.

    python examples/python/frd_study.py --workers 2 --csv study.csv --plot study.png
    python examples/python/frd_study.py --scheduler tcp://HOST:8786   # an existing cluster

Each task builds its model from the TOML file with the task's overrides and traces the
diagram with ``threads=1`` (one core per task: the workers' threads do the parallelism).
docs/python.md shows how to run the same script on SLURM or PBS with dask-jobqueue.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
from pathlib import Path

import pandas as pd

import mshbm

BAR = Path(__file__).resolve().parents[1] / "clamped_bar.toml"

#: The study's grid: initial gap [mm], modal damping ratio of the first mode [-],
#: force amplitude [N].
FULL_GRID = {
    "gap": [0.1, 0.2],
    "damping": [0.01, 0.02],
    "force": [2000.0, 4000.0],
}
#: The sweep of every diagram [Hz] and its numbers of harmonics.
SWEEP = {"from_hz": 20000.0, "to_hz": 100000.0, "harmonics": [3]}


def grid(spec: dict | None = None) -> list[dict]:
    """Every combination of the grid's values, as parameter dicts."""
    spec = spec or FULL_GRID
    keys = list(spec)
    return [dict(zip(keys, values)) for values in itertools.product(*(spec[k] for k in keys))]


def one_diagram(base: mshbm.Model, params: dict, sweep: dict | None = None) -> pd.DataFrame:
    """One task: the diagram of the ``base`` model with ``params`` as a table, one row per
    point, with the parameters as columns. The model travels to the worker with its
    text, so the worker needs no copy of the model file."""
    sweep = sweep or SWEEP
    model = base.with_overrides(
        {
            "contact.gap": params["gap"],
            "damping.first_mode_ratio": params["damping"],
            "load.amplitude": params["force"],
        },
    )
    diagram = mshbm.frf(
        model, sweep["from_hz"], sweep["to_hz"], sweep["harmonics"], threads=1
    )
    table = diagram.to_dataframe()
    for key, value in params.items():
        table.insert(0, key, value)
    table["completed"] = diagram.completed
    return table


def run_serial(base: mshbm.Model, points: list[dict], sweep: dict | None = None) -> pd.DataFrame:
    """The study in this process, one diagram after the other."""
    return pd.concat([one_diagram(base, p, sweep) for p in points], ignore_index=True)


def run_dask(
    client, base: mshbm.Model, points: list[dict], sweep: dict | None = None, timeout: float | None = None
) -> pd.DataFrame:
    """The study on a Dask cluster: one task per diagram, gathered in grid order.

    The workers need only ``mshbm`` installed: run as a script, the task function goes
    to them by value; imported, this file is uploaded to them (``Client.upload_file``)."""
    from dask.distributed import wait

    module = sys.modules[one_diagram.__module__]
    if module.__name__ != "__main__":
        client.upload_file(module.__file__)
    futures = client.map(one_diagram, [base] * len(points), points, sweep=sweep, pure=False)
    if timeout is not None:  # fail instead of waiting for ever (e.g. a worker that cannot run a task)
        wait(futures, timeout=timeout)
    return pd.concat(client.gather(futures), ignore_index=True)


def plot(table: pd.DataFrame, path: str | os.PathLike) -> None:
    """The overlay: max and min displacement of the contact DOF against frequency, one
    pair of curves per parameter set (colour: force, line style: damping, panel: gap;
    the grey line is the gap, which bounds the max)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gaps = sorted(table["gap"].unique())
    fig, axes = plt.subplots(1, len(gaps), figsize=(6 * len(gaps), 4.5), squeeze=False, sharey=True)
    forces = sorted(table["force"].unique())
    dampings = sorted(table["damping"].unique())
    styles = ["-", "--", ":", "-."]
    for ax, gap in zip(axes[0], gaps):
        for (force, damping, h), part in table[table["gap"] == gap].groupby(["force", "damping", "harmonics"]):
            part = part[~part["fold"]]
            for column in ("max_qn", "min_qn"):
                ax.plot(
                    part["frequency_hz"] / 1e3,
                    part[column],
                    styles[dampings.index(damping) % len(styles)],
                    color=f"C{forces.index(force)}",
                    lw=1,
                    label=f"F = {force:g} N, ζ = {damping:g}, H = {h}" if column == "max_qn" else None,
                )
        ax.axhline(gap, color="0.5", lw=0.5)
        ax.set_title(f"gap {gap:g} mm")
        ax.set_xlabel("frequency [kHz]")
    axes[0][0].set_ylabel("contact DOF displacement, max and min [mm]")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="workers of the LocalCluster (one thread each)")
    parser.add_argument("--scheduler", help="address of an existing Dask scheduler instead of a LocalCluster")
    parser.add_argument("--serial", action="store_true", help="run without Dask")
    parser.add_argument("--csv", help="write the table here")
    parser.add_argument("--plot", help="write the overlay here (.png, .svg, .pdf)")
    args = parser.parse_args()
    points = grid()
    base = mshbm.Model.from_toml(BAR)
    start = time.perf_counter()
    if args.serial:
        table = run_serial(base, points)
    else:
        from dask.distributed import Client, LocalCluster

        if args.scheduler:
            client = Client(args.scheduler)
            cluster = None
        else:
            cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True)
            client = Client(cluster)
        with client:
            table = run_dask(client, base, points)
        if cluster is not None:
            cluster.close()
    elapsed = time.perf_counter() - start
    print(f"{len(points)} diagrams, {len(table)} points in {elapsed:.1f} s")
    incomplete = table.loc[~table["completed"], ["gap", "damping", "force"]].drop_duplicates()
    if len(incomplete):
        print(f"incomplete diagrams:\n{incomplete}")
    if args.csv:
        table.to_csv(args.csv, index=False)
    if args.plot:
        plot(table, args.plot)
    print(table.groupby(["gap", "damping", "force"])["min_qn"].min().rename("lowest min_qn [mm]"))


if __name__ == "__main__":
    main()
