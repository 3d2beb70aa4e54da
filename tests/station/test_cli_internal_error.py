"""A failure of the station's own code: one line and exit 3, the traceback only on request."""

from __future__ import annotations

import numpy as np
import pytest

import station.cli as cli


def _broken(args):
    raise np.linalg.LinAlgError("SVD did not converge")


def _with_broken_identify(monkeypatch, argv):
    real = cli.build_parser

    def parser(argv_):
        p = real(argv_)
        real_parse = p.parse_args

        def parse(a=None, ns=None):
            args = real_parse(a, ns)
            args.func = _broken
            return args

        p.parse_args = parse
        return p

    monkeypatch.setattr(cli, "build_parser", parser)
    return cli.main(argv)


def test_an_internal_error_is_one_line_and_exit_3(monkeypatch, capsys):
    monkeypatch.delenv("STATION_DEBUG", raising=False)
    code = _with_broken_identify(monkeypatch, ["identify", "x.csv", "--mass", "1"])
    err = capsys.readouterr().err
    assert code == cli.EXIT_INTERNAL == 3
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("station identify: internal error (LinAlgError: SVD did not converge)")


def test_station_debug_shows_the_traceback(monkeypatch):
    monkeypatch.setenv("STATION_DEBUG", "1")
    with pytest.raises(np.linalg.LinAlgError):
        _with_broken_identify(monkeypatch, ["identify", "x.csv", "--mass", "1"])
