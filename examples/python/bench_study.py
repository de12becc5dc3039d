"""Benchmark: a study of 16 frequency response diagrams (the paper's bar, gap × damping ×
force amplitude, 20–100 kHz, H = 3), serially in one process and on a Dask LocalCluster
of 2 workers (one thread each). Prints the two times and their ratio; the tables must be
equal, and the exit status is 1 when the ratio exceeds --target (issue 20: 0.6).

    python examples/python/bench_study.py [--workers 2] [--repeat 1] [--target 0.6]

The cluster is started before the clock starts (its start-up, about a second, is printed
apart): the time is that of the study on a running cluster, as in a notebook that keeps
its client.
"""

from __future__ import annotations

import argparse
import time

import pandas as pd

import frd_study
import mshbm

GRID = {"gap": [0.1, 0.2], "damping": [0.01, 0.02], "force": [1000.0, 2000.0, 3000.0, 4000.0]}
SWEEP = {"from_hz": 20000.0, "to_hz": 100000.0, "harmonics": [3]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1, help="best of N for each")
    parser.add_argument("--target", type=float, default=0.6, help="largest acceptable ratio")
    args = parser.parse_args()
    from dask.distributed import Client, LocalCluster

    points = frd_study.grid(GRID)
    base = mshbm.Model.from_toml(frd_study.BAR)
    serial_times, dask_times = [], []
    for _ in range(args.repeat):
        start = time.perf_counter()
        serial = frd_study.run_serial(base, points, SWEEP)
        serial_times.append(time.perf_counter() - start)
    start = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    client.wait_for_workers(args.workers)
    print(f"cluster start-up: {time.perf_counter() - start:.2f} s")
    for _ in range(args.repeat):
        start = time.perf_counter()
        parallel = frd_study.run_dask(client, base, points, SWEEP)
        dask_times.append(time.perf_counter() - start)
    client.close()
    cluster.close()
    pd.testing.assert_frame_equal(parallel, serial, check_exact=True)
    s, d = min(serial_times), min(dask_times)
    print(f"{len(points)} diagrams, {len(serial)} points (tables equal)")
    print(f"serial: {s:.2f} s; {args.workers} workers: {d:.2f} s; ratio {d / s:.3f}")
    if d / s > args.target:
        raise SystemExit(f"ratio {d / s:.3f} above the target {args.target}")


if __name__ == "__main__":
    main()
