"""Installation step that builds the simulator's kernels ahead of time (issue 13).

Everything about the package is in ``pyproject.toml``; this file only adds one ``build``
sub-command, ``build_eddi_kernels``, which runs ``python -m eddi.kernels`` (numba.pycc, see
``eddi/kernels.py``) while ``pip install .`` or ``pip install -e .`` builds the package:

* ``pip install .``: the module is written into the wheel's ``eddi/`` (the wheel is then tagged
  for this Python and platform, as it holds a compiled module);
* ``pip install -e .`` (PEP 660: setuptools sets ``editable_mode``): the module is written in
  place, into the source tree's ``eddi/``, where the editable installation imports from;
  skipped when the module there is already current (same source, this processor).

A failure (no C compiler, ``numba.pycc`` gone in a later numba, numba not importable where the
build runs) never fails the installation: one line on stderr (shown by ``pip install -v``) and
the kernels are compiled by numba's JIT at first use, as before. ``EDDI_NO_AOT_BUILD=1`` skips
the step. With ``--no-build-isolation`` the build uses the target environment's numba.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from setuptools import Command, setup
from setuptools.command.build import build
from setuptools.dist import Distribution

ROOT = Path(__file__).resolve().parent
#: Wall-clock limit of the kernel build (it takes ~9 s of CPU; a loaded machine is slower).
TIMEOUT_S = 1200


def _say(msg: str) -> None:
    print(f"eddi-station: {msg}", file=sys.stderr, flush=True)


def _reason(output: str, code: int) -> str:
    """The line of a failed build's output that says why: its exception, else its last line."""
    lines = [ln.strip() for ln in output.splitlines() if ln.strip()]
    errors = [ln for ln in lines if re.match(r"[\w.]*(Error|Exception)\b", ln)]
    return (errors or lines or [f"exit code {code}"])[-1]


class build_eddi_kernels(Command):  # noqa: N801 - setuptools command names are lower case
    """Build the simulator's kernels ahead of time (numba.pycc); never fails the build."""

    description = "build eddi's simulator kernels ahead of time (optional: numba's JIT otherwise)"
    user_options: list = []
    editable_mode: bool = False

    def initialize_options(self) -> None:
        self.build_lib = None
        self.editable_mode = False

    def finalize_options(self) -> None:
        self.set_undefined_options("build_py", ("build_lib", "build_lib"))

    def _output_dir(self) -> Path:
        return ROOT / "eddi" if self.editable_mode else Path(self.build_lib) / "eddi"

    def run(self) -> None:
        if os.environ.get("EDDI_NO_AOT_BUILD", "") not in ("", "0"):
            _say("EDDI_NO_AOT_BUILD set: kernels not built ahead of time (numba's JIT compiles them at first use)")
            return
        try:
            self._build()
        except Exception as exc:  # noqa: BLE001 - whatever goes wrong, the installation goes on
            self._failed(f"{type(exc).__name__}: {exc}")

    def _build(self) -> None:
        out = self._output_dir()
        out.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        # the source tree first: the build imports eddi from here, with the build environment's numba
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
        env.pop("EDDI_AOT_DIR", None)
        env.pop("EDDI_JIT", None)
        cmd = [sys.executable, "-m", "eddi.kernels", "--output-dir", str(out)]
        if self.editable_mode:
            cmd.append("--if-stale")
        res = subprocess.run(cmd, env=env, cwd=str(ROOT), capture_output=True, text=True, timeout=TIMEOUT_S)
        if res.returncode != 0:
            self._failed(_reason(res.stderr or res.stdout or "", res.returncode))
            return
        _say(f"kernels built ahead of time: {res.stdout.strip().splitlines()[-1]}")

    @staticmethod
    def _failed(reason: str) -> None:
        _say(f"kernels NOT built ahead of time ({reason[:200]}); numba's JIT compiles them at first use "
             "(~2.5 s once); to build later: python -m eddi.kernels")

    def get_outputs(self) -> list[str]:
        return [str(p) for p in self._output_dir().glob("_aot_kernels*") if p.suffix in (".so", ".pyd")]

    def get_output_mapping(self) -> dict[str, str]:
        return {}

    def get_source_files(self) -> list[str]:
        return []


class BinaryDistribution(Distribution):
    """The wheel may hold a module compiled for this Python and platform: tag it so."""

    def has_ext_modules(self) -> bool:  # noqa: D102
        return True


build.sub_commands.append(("build_eddi_kernels", None))
setup(cmdclass={"build_eddi_kernels": build_eddi_kernels}, distclass=BinaryDistribution)
