"""eddi.threads.one_blas_thread: one BLAS thread inside, the pools restored after, and the
loaded libraries looked up once, not on every call (the look-up walks every shared object:
~2.4 ms, two calls per in-process identify)."""

import sys

import pytest

threadpoolctl = pytest.importorskip("threadpoolctl")

import eddi.threads as threads  # noqa: E402


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]


def test_one_thread_inside_and_the_pools_restored_after():
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
    for _ in range(5):
        with threads.one_blas_thread():
            pass
    assert len(made) == 1  # each call looked them up again before (5)
    monkeypatch.setitem(sys.modules, "eddi_test_threads_new_module", object())
    with threads.one_blas_thread():
        pass
    assert len(made) == 2  # a new module may have loaded a new BLAS: looked up again
