"""Ctrl-C held back while a capture is written (station.interrupts), then delivered."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from station.interrupts import held_interrupt


def test_a_sigint_during_the_block_is_delivered_after_it() -> None:
    done = []
    with pytest.raises(KeyboardInterrupt):
        with held_interrupt():
            os.kill(os.getpid(), signal.SIGINT)  # delivered to this (main) thread's handler at once
            done.append("the write finished")
    assert done == ["the write finished"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # the handler is restored


def test_no_sigint_no_interrupt_and_other_threads_pass_through() -> None:
    with held_interrupt():
        pass
    out = []
    t = threading.Thread(target=lambda: out.append(_in_thread()))
    t.start()
    t.join()
    assert out == ["ran"]


def _in_thread() -> str:
    with held_interrupt():
        return "ran"
