"""eddi.threads.one_blas_thread: one BLAS thread inside, the pools restored after, and the
loaded libraries looked up once, not on every call (the look-up walks every shared object:
~2.4 ms, two calls per in-process identify)."""

import sys

import pytest

threadpoolctl = pytest.importorskip("threadpoolctl")

import eddi.threads as threads  # noqa: E402


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]


def test_one_thread_inside_and_the_pools_restored_after(monkeypatch):
    # the per-call limit (a process whose pools were not declared one-thread at their load; a test
    # session that imported station.cli before numpy has them so, and the limit is then skipped)
    monkeypatch.setattr(threads, "_ENVIRONMENT_ONE_THREAD", [False])
    before = _blas_threads()
    with threads.one_blas_thread():
        assert _blas_threads() == [1] * len(before)
    assert _blas_threads() == before


def test_the_libraries_are_looked_up_once_until_a_module_is_imported(monkeypatch):
    made = []
    real = threadpoolctl.ThreadpoolController

    class Counting(real):
        def __init__(self):
            made.append(1)
            super().__init__()

    monkeypatch.setattr(threadpoolctl, "ThreadpoolController", Counting)
    monkeypatch.setattr(threads, "_CONTROLLER", [None, -1])
    monkeypatch.setattr(threads, "_ENVIRONMENT_ONE_THREAD", [False])
    for _ in range(5):
        with threads.one_blas_thread():
            pass
    assert len(made) == 1  # each call looked them up again before (5)
    monkeypatch.setitem(sys.modules, "eddi_test_threads_new_module", object())
    with threads.one_blas_thread():
        pass
    assert len(made) == 2  # a new module may have loaded a new BLAS: looked up again


_CLI_PROBE = """
import sys, station.cli
from eddi.threads import one_blas_thread
with one_blas_thread():
    import numpy, scipy.linalg
    pass
with one_blas_thread():
    pass
looked = "threadpoolctl" in sys.modules
from threadpoolctl import threadpool_info
print(looked, sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}))
"""


def _probe(extra_env: dict[str, str]) -> str:
    import os
    import subprocess

    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env.update(extra_env)
    return subprocess.run([sys.executable, "-c", _CLI_PROBE], env=env, capture_output=True, text=True,
                          check=True).stdout.strip()


def test_the_cli_process_has_one_thread_without_threadpoolctl():
    # station's CLI sets the pools to one thread before numpy loads them: nothing left to limit
    # (session 14: the look-up was ~7 ms of CPU per `station identify`); before, threadpoolctl was
    # imported and looked the libraries up in every CLI process
    assert _probe({}) == "False [1]"


def test_a_user_count_keeps_the_per_call_limit():
    # OPENBLAS_NUM_THREADS=2 set by the user: the CLI keeps it, and the engine limits its calls
    assert _probe({"OPENBLAS_NUM_THREADS": "2"}).startswith("True")


def test_no_declaration_once_numpy_is_loaded(monkeypatch):
    import numpy  # noqa: F401 (loaded: the pools' size is no longer known from the environment)

    for v in threads.THREAD_VARIABLES:
        monkeypatch.setenv(v, "1")
    monkeypatch.setattr(threads, "_ENVIRONMENT_ONE_THREAD", [False])
    assert threads.declare_one_thread_environment() is False
