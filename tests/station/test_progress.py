"""The progress line: drawn for a person at a terminal, silent when piped or with --json."""

from __future__ import annotations

import io
import threading

import pytest

from station import progress
from station.progress import Working


class Terminal(io.StringIO):
    """A stream that says it is a terminal and signals its first write."""

    def __init__(self, tty: bool = True) -> None:
        super().__init__()
        self.tty = tty
        self.wrote = threading.Event()

    def isatty(self) -> bool:
        return self.tty

    def write(self, s: str) -> int:
        self.wrote.set()
        return super().write(s)


def test_a_terminal_sees_the_command_and_the_line_is_cleared(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    term = Terminal()
    with Working("station identify", stream=term):
        assert term.wrote.wait(30)  # drawn by the progress thread, no sleep here
    text = term.getvalue()
    assert "station identify: running" in text


@pytest.mark.parametrize("tty,enabled", [(False, True), (True, False)])
def test_piped_or_json_output_stays_quiet(monkeypatch: pytest.MonkeyPatch, tty: bool, enabled: bool) -> None:
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    term = Terminal(tty)
    w = Working("station report", enabled=enabled, stream=term)
    with w:
        pass
    assert w._thread is None and term.getvalue() == ""
