"""Ctrl-C stops every call (issue 44): SIGINT, sent from a thread while `solve`, `frf`,
`simulate` or `modes` runs on the main thread with `threads=1` or `threads=None`, raises
`KeyboardInterrupt` within 1 s — never a `PanicException` — and the package works after it.

The computations are the CLI's signal tests' (crates/mshbm-cli/tests/signals.rs): each runs
for many seconds uninterrupted, so the signal always arrives during the call."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

import mshbm
from conftest import BAR, EXAMPLES

BLOCK = EXAMPLES / "block_3d" / "model.toml"
#: the issue's bound, from the signal to the exception
LIMIT_S = 1.0


def seconds_to_interrupt(call, delay_s: float) -> float:
    """Run `call()` here (the main thread) and send SIGINT to the process from another
    thread `delay_s` after the start; the seconds from the signal to the KeyboardInterrupt."""
    sent: list[float] = []

    def send():
        time.sleep(delay_s)
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    try:
        call()
    except KeyboardInterrupt:
        stopped = time.monotonic()
    else:
        # the call ended first: take the signal here, not in pytest
        try:
            sender.join()
            time.sleep(0.5)
        except KeyboardInterrupt:
            pass
        pytest.fail(f"the call ended within {delay_s} s, before the signal: make it longer")
    sender.join()
    assert sent, "KeyboardInterrupt before the signal was sent"
    return stopped - sent[0]


def check_interrupt(call, delay_s: float = 1.0):
    latency = seconds_to_interrupt(call, delay_s)
    assert latency < LIMIT_S, f"stopped {latency:.2f} s after SIGINT"
    # the package is usable afterwards, and a later call is not cancelled
    assert mshbm.Model.from_toml(BAR).modes(3).original_hz[0] > 0


@pytest.mark.parametrize("threads", [1, None])
def test_ctrl_c_stops_solve(threads):
    model = mshbm.Model.from_toml(BLOCK)
    # at 3 s the solve iterates (checks every few ms); in its first second the set-up's
    # static contact problem checks no request, and a clean-clone run once stopped 1.07 s
    # after a signal sent there (issue 44's note)
    check_interrupt(
        lambda: model.solve(1500, harmonics=1, quadrature="sampled", stability=False, threads=threads),
        3.0,
    )


@pytest.mark.parametrize("threads", [1, None])
def test_ctrl_c_stops_frf(threads):
    model = mshbm.Model.from_toml(BLOCK, {"solid.divisions": [16, 16, 4], "interfaces.0.gap": 0.0003})
    check_interrupt(lambda: model.frf(400, 600, harmonics=3, quadrature="sampled", threads=threads), 2.0)


@pytest.mark.parametrize("threads", [1, None])
def test_ctrl_c_stops_simulate(threads):
    # the bar: its set-up is short, and the signal arrives while the integrator steps (the
    # 3D block's set-up, the redistributed scheme's contact matrices, ~14 s, checks no
    # request yet: a signal there waits for it; issue 44's note)
    model = mshbm.Model.from_toml(BAR)
    check_interrupt(lambda: model.simulate(30000, periods=100000, record=False, threads=threads))


@pytest.mark.parametrize("threads", [1, None])
def test_ctrl_c_stops_modes(threads):
    # 20 000 DOFs: about 10 s, most of it in sparse Cholesky factorizations that the
    # library stops waiting for
    model = mshbm.Model.from_toml(BLOCK, {"solid.divisions": [32, 32, 4]})
    check_interrupt(lambda: model.modes(10, threads=threads))


def test_a_call_from_another_thread_is_not_stopped_by_an_earlier_interrupt():
    """The stop request belongs to the main thread's call: a call on another thread runs to
    its end."""
    model = mshbm.Model.from_toml(BAR)
    out = {}
    worker = threading.Thread(target=lambda: out.setdefault("modes", model.modes(3, threads=1)))
    worker.start()
    worker.join()
    assert out["modes"].original_hz[0] > 0
