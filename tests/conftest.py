"""Shared fixtures. Hardware tests carry ``@pytest.mark.hardware`` and run only with --hardware."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C as a terminal gives it, whatever started the run. A shell's background job (``cmd &``
    without job control, ``nohup``, some CI runners) starts with SIGINT ignored; Python then keeps
    it ignored and so does every process a test starts, and the tests that press Ctrl-C on a
    ``station`` process (test_acquire, test_device_sim_url, test_qemu_rig, test_interrupts) hung
    until their timeouts: 3 failures of a fresh-clone run started in the background."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--hardware", action="store_true", help="run tests that need a real DAQ")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--hardware"):
        return
    skip = pytest.mark.skip(reason="needs a real DAQ: run with --hardware")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)
