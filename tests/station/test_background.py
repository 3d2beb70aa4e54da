"""station.background: a call in a forked worker gives what it gives here, errors included."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from eddi.errors import SignalError
from station.background import Background, background_allowed

needs_fork = pytest.mark.skipif(not background_allowed(), reason="needs 2 cores and fork")


def _work(n: int, seed: int) -> tuple[int, np.ndarray]:
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    return os.getpid(), np.linalg.solve(a @ a.T + n * np.eye(n), rng.standard_normal(n))


def _fails(msg: str) -> None:
    raise SignalError(msg)


def _dies() -> int:
    if os.environ.get("STATION_TEST_PARENT") != str(os.getpid()):
        os.kill(os.getpid(), signal.SIGKILL)  # the worker dies without a word
    return 7


@needs_fork
def test_the_worker_returns_what_the_call_returns_here() -> None:
    job = Background(_work, 40, 3)
    assert job.in_background
    pid, x = job()
    assert pid != os.getpid()  # computed in another process
    assert np.array_equal(x, _work(40, 3)[1])  # bit for bit
    assert job() is job()  # collected once


@needs_fork
def test_the_workers_error_is_raised_with_its_type_and_message() -> None:
    job = Background(_fails, "too few zero crossings")
    assert isinstance(job.failed(), SignalError)
    with pytest.raises(SignalError, match="too few zero crossings"):
        job()
    with pytest.raises(ValueError):  # the layer root and the built-in it resembles
        job()


@needs_fork
def test_a_worker_that_dies_is_replaced_by_the_call_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STATION_TEST_PARENT", str(os.getpid()))
    assert Background(_dies)() == 7


def test_station_serial_runs_the_call_here_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STATION_SERIAL", "1")
    job = Background(_work, 10, 1)
    assert not job.in_background
    assert job()[0] == os.getpid()
    with pytest.raises(SignalError, match="at once"):  # raised by the constructor, as a plain call
        Background(_fails, "at once")


@needs_fork
def test_what_was_printed_before_the_fork_is_printed_once() -> None:
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = ("import sys; from station.background import Background\n"
            "print('printed before the worker starts')\n"  # block-buffered (a pipe): still in the buffer
            "print(Background(int, '7')())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(root), "PATH": ""}).stdout
    assert out.splitlines() == ["printed before the worker starts", "7"]


def test_with_another_thread_running_the_call_runs_here() -> None:
    import threading

    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        job = Background(_work, 10, 2)
        assert not job.in_background  # no fork while another thread may hold a lock
        assert job()[0] == os.getpid()
    finally:
        release.set()
        other.join()
