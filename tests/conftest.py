"""Shared fixtures. Hardware tests carry ``@pytest.mark.hardware`` and run only with --hardware."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--hardware", action="store_true", help="run tests that need a real DAQ")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--hardware"):
        return
    skip = pytest.mark.skip(reason="needs a real DAQ: run with --hardware")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)
