"""The compiled kernels of the simulator: built ahead of time, or compiled by numba when used.

The RK4 kernels of :mod:`eddi.simulate` and :mod:`eddi.sensitivity` (and the IIR filter of
:mod:`eddi.iir`, the Bouc-Wen operator of :mod:`eddi.hysteresis`, the conditioning's integral
and zero crossings in :mod:`eddi.calculus` and :mod:`eddi.conditioning.levels`) are plain Python source
compiled by numba. Compiled at first use (JIT) they cost every process numba's import and
set-up (~0.5 s of CPU even when its on-disk cache holds them) and the first run after an
installation ~2.5 s of compilation. Built ahead of time (``python -m eddi.kernels``: the same
source through ``numba.pycc`` into one extension module, ``eddi/_aot_kernels*.so``) they load
like any extension, with no numba at run time, and give the same numbers bit for bit (same
source, same LLVM, no fast-math; tested in ``tests/eddi/test_kernels.py``). They are built for
this machine's processor, as the JIT compiles (``--cpu generic``: for any processor of the
architecture, the sensitivity kernel then ~2x slower); a module built for another processor
is not used.

:class:`Kernels` picks, at the first call of a kernel:

* the ahead-of-time module when it exists, was built for this Python, and its fingerprint
  (a hash of the kernels' bytecode and of the module constants they read) equals that of the
  code in use: an edited kernel never runs stale compiled code;
* else numba's JIT, exactly as before (``cache=True``), also for a call whose argument types
  the built signatures do not cover.

``EDDI_JIT=1`` in the environment forces the JIT; ``EDDI_AOT_DIR`` looks for the built
module in another directory (tests, read-only installations).

``numba.pycc`` is deprecated by numba (no removal date yet, 0.68 has it); when it goes, the
JIT path is what remains, with no change of results.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import sys
import types
from pathlib import Path
from typing import Any, Callable

AOT_NAME = "_aot_kernels"
#: The modules whose kernels go into the built module.
KERNEL_MODULES = ("eddi.simulate", "eddi.local_frequency", "eddi.sensitivity", "eddi.iir", "eddi.hysteresis",
                  "eddi.median", "eddi.refine_grid",
                  "eddi.calculus", "eddi.peaks", "eddi.conditioning.levels", "eddi.conditioning.checks",
                  "eddi.conditioning.kinematics", "eddi.bspline", "eddi.decimal_text")


def _aot_dir() -> Path:
    return Path(os.environ.get("EDDI_AOT_DIR") or Path(__file__).resolve().parent)


def _load_aot_module() -> types.ModuleType | None:
    """The built extension module (None when absent or not built for this Python)."""
    name = f"eddi.{AOT_NAME}"
    if name in sys.modules:
        return sys.modules[name]
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = _aot_dir() / (AOT_NAME + suffix)
        if path.is_file():
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:  # pragma: no cover - defensive
                return None
            try:
                mod = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(mod)
            except ImportError:
                return None
            built_for = getattr(mod, "aot__cpu", None)
            if built_for is not None and built_for() not in (0, cpu_stamp()):
                return None  # built for another processor's instructions: the JIT runs instead
            sys.modules[name] = mod
            return mod
    return None


def cpu_stamp() -> int:
    """A 60-bit hash of this machine's processor (model name and instruction-set flags in
    ``/proc/cpuinfo``); -1 where that is not readable (a module built for the host is then
    never used)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            text = f.read(1 << 16)
    except OSError:
        return -1
    keys = {}
    for line in text.splitlines():
        if not line.strip():
            break  # the first processor's block
        k, _, v = line.partition(":")
        if k.strip() in ("vendor_id", "model name", "flags"):
            keys[k.strip()] = v.strip()
    if "flags" not in keys:
        return -1
    return int(hashlib.sha256(repr(sorted(keys.items())).encode()).hexdigest()[:15], 16)


class Kernels:
    """The compiled kernels of one module, resolved at first use (see the module notes).

    Parameters
    ----------
    namespace : dict
        The module's globals (the kernels' source functions and the constants they read).
    signatures : dict of str to list of str
        Entry kernels (called from Python) and the numba signatures built ahead of time.
    callees : tuple of str
        Kernels called only by other kernels (compiled into them).
    """

    def __init__(self, namespace: dict[str, Any], signatures: dict[str, list[str]],
                 callees: tuple[str, ...] = ()) -> None:
        self._ns = namespace
        self._signatures = signatures
        self._callees = callees
        self._prefix = namespace["__name__"].rsplit(".", 1)[-1]
        self._loaded: dict[str, Callable[..., Any]] | None = None
        self._jit: dict[str, Any] | None = None
        self.source = "not loaded"

    # -- identity of the source -------------------------------------------------------------
    def fingerprint(self) -> int:
        """A 60-bit hash of the kernels' code and of the module constants they read.

        The code is the functions' bytecode with its names and constants (:func:`_hash_code`:
        what numba compiles, so any edit that can change a kernel's machine code changes it; line
        numbers, comments and blank lines do not count). Not ``inspect.getsource``: tokenizing
        the modules for it took ~7-15 ms of every process (session 18)."""
        h = hashlib.sha256()
        for name in sorted((*self._signatures, *self._callees)):
            fn = self._ns[name]
            _hash_code(h, fn.__code__)
            h.update(f"defaults={fn.__defaults__!r};".encode())
            for g in sorted(fn.__code__.co_names):
                val = self._ns.get(g)
                if isinstance(val, (int, float)) and not isinstance(val, bool):
                    h.update(f"{g}={val!r};".encode())
        for name, sigs in sorted(self._signatures.items()):
            h.update(f"{name}:{'|'.join(sigs)};".encode())
        return int(h.hexdigest()[:15], 16)

    def exported_name(self, name: str, i: int) -> str:
        return f"{self._prefix}__{name.lstrip('_')}__{i}"

    # -- the two ways ----------------------------------------------------------------------
    def jit_functions(self) -> dict[str, Any]:
        """numba dispatchers of every kernel (compiled lazily, cached on disk), sharing one
        namespace in which each kernel sees the others' dispatchers."""
        if self._jit is None:
            import numba

            ns = dict(self._ns)
            out = {}
            for name in (*self._callees, *self._signatures):
                fn = self._ns[name]
                clone = types.FunctionType(fn.__code__, ns, fn.__name__, fn.__defaults__, fn.__closure__)
                clone.__qualname__, clone.__module__, clone.__doc__ = fn.__qualname__, fn.__module__, fn.__doc__
                out[name] = ns[name] = numba.njit(cache=True)(clone)
            self._jit = out
        return self._jit

    def _aot_functions(self) -> dict[str, Callable[..., Any]] | None:
        if os.environ.get("EDDI_JIT", "") not in ("", "0"):
            return None
        mod = _load_aot_module()
        if mod is None:
            return None
        stamp = getattr(mod, f"{self._prefix}__fingerprint", None)
        try:
            mine = self.fingerprint()
        except (OSError, TypeError):  # pragma: no cover - defensive (a function without code)
            return None
        if stamp is None or stamp() != mine:
            return None  # built from other source: never run it
        out = {}
        for name, sigs in self._signatures.items():
            built = [getattr(mod, self.exported_name(name, i)) for i in range(len(sigs))]
            out[name] = self._with_fallback(name, built)
        return out

    def _with_fallback(self, name: str, built: list[Callable[..., Any]]) -> Callable[..., Any]:
        checks = [_signature_check(sig) for sig in self._signatures[name]]

        def call(*args: Any) -> Any:
            for fn, check in zip(built, checks):
                # the built wrappers do not check an array's layout (a strided array would be
                # read as if contiguous): every argument is checked here first
                if check(args):
                    return fn(*args)
            return self.jit_functions()[name](*args)

        call.__name__ = name
        return call

    def _load(self) -> dict[str, Callable[..., Any]]:
        if self._loaded is None:
            aot = self._aot_functions()
            if aot is not None:
                self._loaded, self.source = aot, "ahead of time"
            else:
                self._loaded, self.source = dict(self.jit_functions()), "numba JIT"
        return self._loaded

    def built(self, name: str) -> Callable[..., Any] | None:
        """The kernel ``name`` built ahead of time, or None when the module would run numba's JIT
        (no built module, another source, ``EDDI_JIT=1``): for a caller with a way of its own that
        costs less than numba's import and compile (``eddi.decimal_text``)."""
        if self._loaded is None:
            aot = self._aot_functions()
            if aot is None:
                return None
            self._loaded, self.source = aot, "ahead of time"
        return self._loaded[name] if self.source == "ahead of time" else None

    def __getattr__(self, name: str) -> Callable[..., Any]:
        if name.startswith("__") or name not in self.__dict__.get("_signatures", {}):
            raise AttributeError(name)
        return self._load()[name]


def _hash_code(h: Any, code: types.CodeType) -> None:
    """Feed ``code`` to the hash ``h``: bytecode, argument counts and flags, names, variable names and
    constants (nested code objects the same way; floats by their exact ``repr``)."""
    h.update(code.co_code)
    h.update(f"{code.co_argcount},{code.co_posonlyargcount},{code.co_kwonlyargcount},{code.co_flags};".encode())
    h.update(repr((code.co_names, code.co_varnames, code.co_freevars, code.co_cellvars)).encode())
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            _hash_code(h, c)
        else:
            h.update(f"{type(c).__name__}:{c!r};".encode())


_DTYPES = {"f8": "float64", "i8": "int64", "u1": "uint8"}


def _signature_check(sig: str) -> Callable[[tuple], bool]:
    """``check(args)``: whether every argument has exactly the type of ``sig`` (the tests of
    :func:`_arg_checks`, in one function with the common cases first: the per-argument
    closures cost ~8 us a call, ~0.25 s of CPU in a diagnosis of the double beam's ~31k
    kernel calls)."""
    import numpy as np

    per_arg = _arg_checks(sig)
    specs = _arg_specs(sig)
    n = len(specs)
    arrays = tuple((i, np.dtype(_DTYPES[base]), dims, c_order)
                   for i, (base, dims, c_order) in enumerate(specs) if dims)
    scalars = tuple((i, base == "f8") for i, (base, dims, _c) in enumerate(specs) if not dims)
    ndarray = np.ndarray

    def check(args: tuple) -> bool:
        if len(args) != n:
            return False
        for i, dtype, dims, c_order in arrays:
            a = args[i]
            if not isinstance(a, ndarray) or a.ndim != dims or not (a.dtype is dtype or a.dtype == dtype):
                return False
            fl = a.flags
            if not fl.aligned or (c_order and not fl.c_contiguous):
                return False
        for i, real in scalars:
            t = type(args[i])
            if t is float and real or t is int:
                continue
            if not per_arg[i](args[i]):
                return False
        return True

    return check


def _arg_specs(sig: str) -> list[tuple[str, int, bool]]:
    """Per argument of a signature: base type (``f8``, ``i8``), array dimensions (0: a
    scalar) and whether C order is required."""
    inner = sig[sig.index("(") + 1: sig.rindex(")")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        depth += ch == "["
        depth -= ch == "]"
        if ch == "," and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    if cur.strip():
        parts.append(cur.strip())
    out = []
    for p in parts:
        base = p.split("[")[0].strip()
        if "[" in p:
            out.append((base, p[p.index("[") + 1: p.rindex("]")].count(",") + 1, "::1" in p))
        else:
            out.append((base, 0, False))
    return out


def _arg_checks(sig: str) -> list[Callable[[Any], bool]]:
    """Per argument of a signature such as ``"i8(f8[::1], f8, i8[:, ::1])"``, a test that a
    value has exactly that type (arrays: dtype, dimensions, C order when ``::1``)."""
    import numpy as np

    inner = sig[sig.index("(") + 1: sig.rindex(")")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        depth += ch == "["
        depth -= ch == "]"
        if ch == "," and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    if cur.strip():
        parts.append(cur.strip())
    checks: list[Callable[[Any], bool]] = []
    for p in parts:
        base = p.split("[")[0].strip()
        if "[" in p:
            dims = p[p.index("[") + 1: p.rindex("]")].count(",") + 1
            dtype, c_order = np.dtype(_DTYPES[base]), "::1" in p

            def ok(a: Any, dtype: Any = dtype, dims: int = dims, c_order: bool = c_order) -> bool:
                return (isinstance(a, np.ndarray) and a.dtype == dtype and a.ndim == dims
                        and (a.flags.c_contiguous or not c_order) and a.flags.aligned)
        elif base == "f8":
            def ok(a: Any) -> bool:
                return isinstance(a, (float, int, np.floating, np.integer)) and not isinstance(a, bool)
        else:
            def ok(a: Any) -> bool:
                return isinstance(a, (int, np.integer)) and not isinstance(a, bool)
        checks.append(ok)
    return checks


def build(output_dir: str | Path | None = None, cpu: str = "host") -> Path:
    """Compile every kernel of :data:`KERNEL_MODULES` ahead of time into one extension module.

    ``cpu="host"`` (default) compiles for this machine's processor, as the JIT does: numba's
    generic x86-64 target made the sensitivity kernel (`_rk4_sens`, most of an output-error
    refinement) 1.8-2.3x slower than the JIT (session 12), with the same numbers. The module
    records the processor (:func:`cpu_stamp`) and is not used on another one (the JIT runs).
    ``cpu="generic"``: a module for any processor of the architecture.

    Returns
    -------
    Path
        The built module (``eddi/_aot_kernels.<python tag>.so`` unless ``output_dir``).
    """
    import warnings

    import numba

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numba.pycc's deprecation notice
        from numba.pycc import CC

    cc = CC(AOT_NAME)
    cc.output_dir = str(output_dir or Path(__file__).resolve().parent)
    cc.verbose = False
    stamp_cpu = 0
    if cpu == "host":
        stamp_cpu = cpu_stamp()
        if stamp_cpu < 0:
            raise RuntimeError("no /proc/cpuinfo to stamp a module built for this processor: use cpu='generic'")
        cc.target_cpu = "host"
    elif cpu != "generic":
        raise ValueError("cpu must be 'host' or 'generic'")
    for modname in KERNEL_MODULES:
        mod = importlib.import_module(modname)
        k: Kernels = mod._KERNELS
        stamp = k.fingerprint()
        ns = dict(k._ns)
        for name in k._callees:
            fn = k._ns[name]
            ns[name] = numba.njit(types.FunctionType(fn.__code__, ns, fn.__name__, fn.__defaults__, fn.__closure__))
        for name, sigs in k._signatures.items():
            fn = k._ns[name]
            for i, sig in enumerate(sigs):
                clone = types.FunctionType(fn.__code__, ns, fn.__name__, fn.__defaults__, fn.__closure__)
                cc.export(k.exported_name(name, i), sig)(clone)
        cc.export(f"{k._prefix}__fingerprint", "i8()")(eval(f"lambda: {stamp}"))  # noqa: S307 - an int literal
    cc.export("aot__cpu", "i8()")(eval(f"lambda: {stamp_cpu}"))  # noqa: S307 - an int literal
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cc.compile()
    built = [p for p in Path(cc.output_dir).glob(AOT_NAME + "*") if p.suffix in (".so", ".pyd")]
    return max(built, key=lambda p: p.stat().st_mtime)


def current_module(output_dir: str | Path | None = None) -> Path | None:
    """The built module in ``output_dir`` (default: the eddi package) when every kernel module
    would use it (built for this Python and processor, fingerprints equal to the source in
    use), else None: ``python -m eddi.kernels --if-stale`` then builds."""
    saved = os.environ.get("EDDI_AOT_DIR")
    os.environ["EDDI_AOT_DIR"] = str(output_dir or Path(__file__).resolve().parent)
    try:
        if _load_aot_module() is None:
            return None
        for modname in KERNEL_MODULES:
            if importlib.import_module(modname)._KERNELS._aot_functions() is None:
                return None
        return Path(sys.modules[f"eddi.{AOT_NAME}"].__file__)
    finally:
        if saved is None:
            os.environ.pop("EDDI_AOT_DIR", None)
        else:
            os.environ["EDDI_AOT_DIR"] = saved


if __name__ == "__main__":  # pragma: no cover - the build command
    import argparse

    ap = argparse.ArgumentParser(description="Build the simulator's kernels ahead of time (numba.pycc).")
    ap.add_argument("--output-dir", default=None, help="where to write the module (default: the eddi package)")
    ap.add_argument("--cpu", choices=("host", "generic"), default="host",
                    help="host (default): this machine's processor, as fast as the JIT, not used on another "
                         "processor; generic: any processor of the architecture (the sensitivity kernel "
                         "~2x slower)")
    ap.add_argument("--if-stale", action="store_true",
                    help="build only when the module in the output directory is not current (another source, "
                         "Python or processor); the installation's step for editable installs")
    a = ap.parse_args()
    have = current_module(a.output_dir) if a.if_stale else None
    print(f"{have} (current: not rebuilt)" if have is not None else build(a.output_dir, a.cpu))
