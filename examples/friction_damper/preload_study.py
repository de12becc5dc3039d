"""The friction damper (model.toml) at several preloads: one frequency response diagram per
normal preload of the tip face on the pad, overlaid, and the peak amplitude against the
preload — the classic behaviour of a friction damper:

* a light preload lets the tip slip (and lift off) freely: a high, lightly damped peak near
  the free beam's resonance;
* a heavy preload sticks the tip: the linear resonance of the stiffened (clamped–clamped)
  beam, stuck.toml, whose first eigenfrequency the stuck peak is checked against;
* in between, an optimal preload where stick–slip dissipates most and the peak is lowest.

    python examples/friction_damper/preload_study.py --csv study.csv \\
        --plot preload_study.png --peaks-plot peak_vs_preload.png

The script checks these three statements and exits 1 (saying which failed) when one does
not hold; the Python suite runs it (crates/mshbm-py/tests/test_friction_study.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

import mshbm

HERE = Path(__file__).resolve().parent
MODEL = HERE / "model.toml"
STUCK = HERE / "stuck.toml"

#: Normal preloads of the tip face [N] (the model's `loads[0].constant`, total over the
#: face's five nodes).
PRELOADS = [0.2, 1.0, 2.0, 5.0, 10.0, 20.0, 200.0]
#: The sweep [Hz], harmonics, and the response: the driven node's vertical displacement.
SWEEP = {"from_hz": 100.0, "to_hz": 6000.0, "harmonics": [3], "dof": 189}
#: The stuck peak lies below the clamped–clamped eigenfrequency by the slip that the
#: resonance still causes and the redistributed mass: within this fraction.
STUCK_TOLERANCE = 0.02


def diagram(preload: float) -> pd.DataFrame:
    """The diagram at one preload, one row per point, with the preload as a column."""
    model = mshbm.Model.from_toml(MODEL, {"loads.0.constant": [preload, 0.0]})
    d = mshbm.frf(
        model,
        SWEEP["from_hz"],
        SWEEP["to_hz"],
        SWEEP["harmonics"],
        dof=SWEEP["dof"],
        threads=1,
    )
    if not d.completed:
        raise RuntimeError(f"preload {preload} N: the diagram stopped: {d.stop_reason}")
    table = pd.DataFrame(d.to_dict())
    table.insert(0, "preload", preload)
    return table


def peaks(study: pd.DataFrame) -> pd.DataFrame:
    """Per preload: the largest half peak-to-peak displacement, where it is, and the stick
    fraction and the energy dissipated per period there."""
    rows = []
    for preload, t in study.groupby("preload"):
        k = (t["max_qn"] - t["min_qn"]).idxmax()
        rows.append(
            {
                "preload": preload,
                "peak": 0.5 * (t.loc[k, "max_qn"] - t.loc[k, "min_qn"]),
                "peak_hz": t.loc[k, "frequency_hz"],
                "stick_at_peak": t.loc[k, "stick"],
                "energy_at_peak": t.loc[k, "dissipated_energy"],
            }
        )
    return pd.DataFrame(rows)


def check(table: pd.DataFrame, stuck_hz: float) -> list[str]:
    """The module docs' statements that the sweep can decide, the failed ones: the lowest
    peak lies between the lightest and the heaviest preload, and the heaviest preload's
    peak is the stuck beam's resonance. (Where the lighter preloads peak is not checked:
    besides the free beam's first resonance, their diagrams rise toward its second one,
    ~5.3–5.6 kHz, at the sweep's end.)"""
    failed = []
    lowest = table["peak"].idxmin()
    if lowest in (table.index[0], table.index[-1]):
        failed.append(
            f"the lowest peak is at the preload {table.loc[lowest, 'preload']} N, not between "
            "the lightest and the heaviest"
        )
    stuck_peak = table["peak_hz"].iloc[-1]
    if abs(stuck_peak / stuck_hz - 1.0) > STUCK_TOLERANCE:
        failed.append(
            f"the heaviest preload's peak {stuck_peak:.1f} Hz is not within "
            f"{STUCK_TOLERANCE:.0%} of the stuck beam's eigenfrequency {stuck_hz:.1f} Hz"
        )
    return failed


def plot(study: pd.DataFrame, table: pd.DataFrame, stuck_hz: float, frd_path, peaks_path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if frd_path:
        fig, ax = plt.subplots(figsize=(9, 5.5))
        for preload, t in study.groupby("preload"):
            t = t[~t["fold"]]
            ax.semilogy(t["frequency_hz"], t["max_qn"] - t["min_qn"], label=f"{preload:g} N")
        ax.axvline(stuck_hz, color="grey", ls=":", lw=1, label="stuck beam, mode 1")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("peak-to-peak displacement at the drive [mm]")
        ax.set_title("friction damper: one diagram per normal preload (μ = 0.1, H = 3)")
        ax.legend(title="preload", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(frd_path, dpi=110)
        plt.close(fig)
    if peaks_path:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        ax.loglog(table["preload"], table["peak"], "o-", color="C0")
        ax.set_xlabel("normal preload [N]")
        ax.set_ylabel("peak amplitude at the drive [mm]", color="C0")
        right = ax.twinx()
        right.semilogx(table["preload"], table["peak_hz"], "s--", color="C1")
        right.set_ylabel("peak frequency [Hz]", color="C1")
        ax.set_title("friction damper: peak against preload")
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(peaks_path, dpi=110)
        plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", help="every point of every diagram (with the preload)")
    parser.add_argument("--plot", help="the diagrams overlaid (.png, .svg)")
    parser.add_argument("--peaks-plot", help="peak amplitude and frequency against the preload")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    parts = []
    for preload in PRELOADS:
        t0 = time.perf_counter()
        parts.append(diagram(preload))
        print(
            f"preload {preload:g} N: {len(parts[-1])} points in {time.perf_counter() - t0:.1f} s",
            file=sys.stderr,
        )
    study = pd.concat(parts, ignore_index=True)
    table = peaks(study)
    stuck_hz = mshbm.Model.from_toml(STUCK).modes(1).original_hz[0]
    if args.csv:
        study.to_csv(args.csv, index=False)
    plot(study, table, stuck_hz, args.plot, args.peaks_plot)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.5g}"))
    print(f"stuck beam's first eigenfrequency: {stuck_hz:.1f} Hz")
    print(f"{len(PRELOADS)} diagrams in {time.perf_counter() - start:.1f} s")
    failed = check(table, stuck_hz)
    for f in failed:
        print(f"check failed: {f}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
