"""setup.py: `pip install .` / `pip install -e .` build the simulator's kernels ahead of time,
and a failed build never fails the installation (numba's JIT remains)."""

from __future__ import annotations

import importlib.util
import sys
import types
from pathlib import Path
from unittest import mock

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]


def _requirement(reqs: list[str], name: str) -> str:
    return next(r for r in reqs if r.split(">")[0].split("=")[0].split("<")[0].strip() == name)


def test_the_build_environment_has_numba_numpy_and_pydantic_with_the_runtimes_constraints() -> None:
    # pip builds in an isolated environment: the kernels' build needs numba (numba.pycc), numpy
    # and pydantic (eddi.model) there, constrained as at run time (same numba, same numpy ABI)
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())
    build_reqs, runtime = conf["build-system"]["requires"], conf["project"]["dependencies"]
    for name in ("numba", "numpy", "pydantic"):
        assert _requirement(build_reqs, name) == _requirement(runtime, name)
    # editable_mode (PEP 660): >= 64; the SPDX string form of project.license: >= 77
    least = _requirement(build_reqs, "setuptools").split(">=")[1]
    assert tuple(int(p) for p in least.split(".")) >= (77,)
    assert isinstance(conf["project"]["license"], str)


@pytest.fixture()
def setup_py(monkeypatch: pytest.MonkeyPatch) -> types.ModuleType:
    """setup.py, loaded without running setup()."""
    from setuptools.command.build import build

    before = list(build.sub_commands)
    spec = importlib.util.spec_from_file_location("eddi_setup_under_test", REPO / "setup.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    with mock.patch("setuptools.setup") as setup:
        spec.loader.exec_module(mod)
    assert setup.call_count == 1
    assert ("build_eddi_kernels", None) in build.sub_commands
    monkeypatch.setattr(build, "sub_commands", before)
    return mod


def _run(setup_py: types.ModuleType, build_lib: Path) -> None:
    from setuptools.dist import Distribution

    cmd = setup_py.build_eddi_kernels(Distribution())
    cmd.initialize_options()
    cmd.build_lib = str(build_lib)
    cmd.run()


def test_a_build_without_numba_pycc_leaves_the_jit_and_does_not_fail(setup_py: types.ModuleType, tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    # numba.pycc is deprecated: a numba without it (here: blocked by a sitecustomize of the
    # build's process) must give one line and no module, never a failed installation
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text("import sys\nsys.modules['numba.pycc'] = None\n")
    monkeypatch.setenv("PYTHONPATH", str(site))
    monkeypatch.delenv("EDDI_NO_AOT_BUILD", raising=False)
    _run(setup_py, tmp_path / "lib")
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("eddi-station: kernels NOT built ahead of time (ModuleNotFoundError: import of "
                             "numba.pycc halted")
    assert "numba's JIT compiles them at first use" in err[0]
    assert not list((tmp_path / "lib" / "eddi").glob("_aot_kernels*"))


def test_the_build_step_can_be_skipped(setup_py: types.ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("EDDI_NO_AOT_BUILD", "1")
    _run(setup_py, tmp_path / "lib")
    assert capsys.readouterr().err.startswith("eddi-station: EDDI_NO_AOT_BUILD set")
    assert not (tmp_path / "lib").exists()


def test_the_wheel_is_tagged_for_the_platform(setup_py: types.ModuleType) -> None:
    # the wheel holds a compiled module: never a py3-none-any wheel
    from setuptools.dist import Distribution

    assert not Distribution().has_ext_modules()
    assert setup_py.BinaryDistribution().has_ext_modules()
