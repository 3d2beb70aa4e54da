"""Serving the emulated DAQ on a pseudo-terminal, so the host's real serial code path runs.

:class:`PtyServer` opens a pty pair, keeps the master side and gives the slave's path
(:attr:`PtyServer.port`) to the host, which opens it like any serial port
(``serial:///dev/pts/N``). The server loop moves command bytes to the firmware and DATA frames
back, advancing sample time either

* unpaced (``paced=False``): as fast as the host takes the bytes. The pty's own buffer is the
  flow control, so nothing is ever dropped and runs are fast and deterministic (tests);
* paced (``paced=True``): to a clock (``time.monotonic`` unless one is injected), like real
  hardware. If the host does not keep up, the device FIFO (``fifo_bytes``) overflows and the
  frames that do not fit are discarded, which the host sees as a gap in the sample counter.

A rig can also run in a process of its own, like a real device (:class:`RigProcess`, or
``python -m simulated_rig.serve --system NAME``): it builds its physics, compiles its
simulator and only then "powers on" and prints its port, so a busy host, or a first run
with an empty JIT cache, delays the device as it would delay a real DAQ (the bytes wait in
the pty), never into a command timeout.

A control socket (``control=PATH``, a UNIX stream socket) lets another process strike the
served rig without a terminal: one line of JSON ``{"peak_force_n": 300, "double_hit": false}``
in, one line of JSON ``{"at_sample": N}`` (or ``{"error": "..."}``) out
(``station rig strike``, :func:`strike`).
"""

from __future__ import annotations

import argparse
import copy
import errno
import json
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import tty
from typing import IO, Callable, Sequence

from simulated_rig.device import EmulatedDaq
from simulated_rig.errors import RigError, ScenarioError
from simulated_rig.loop import StepLoop, close_fds


class PtyServer(StepLoop):
    """The emulated DAQ behind a pty.

    Parameters
    ----------
    device : EmulatedDaq
    paced : bool
        Advance sample time with ``clock`` (True) or as fast as the host reads (False).
    clock : callable returning float, [s]
    link : str or None
        If given, a symlink to the pty at this path (a stable name across restarts).
    fifo_bytes : int
        Device output FIFO in paced mode, [bytes].
    tick_s : float
        Longest wait of the loop, [s].
    control : str or None
        If given, a UNIX socket at this path that strikes the rig (see the module docstring).
    """

    def __init__(
        self,
        device: EmulatedDaq,
        *,
        paced: bool = False,
        clock: Callable[[], float] = time.monotonic,
        link: str | None = None,
        fifo_bytes: int = 4 << 20,
        tick_s: float = 0.002,
        control: str | None = None,
    ) -> None:
        self.device = device
        self.paced = paced
        self.clock = clock
        self.fifo_bytes = fifo_bytes
        self.tick_s = tick_s
        self.overrun_frames = 0
        self.master_fd, self.slave_fd = os.openpty()
        tty.setraw(self.slave_fd)  # no echo, no line discipline, before anyone opens it
        os.set_blocking(self.master_fd, False)
        self.port = os.ttyname(self.slave_fd)
        self.link = link
        if link is not None:
            try:
                _replace_own_link(link, self.port)
            except RigError:
                os.close(self.master_fd)
                os.close(self.slave_fd)
                raise
        self.control = control
        self._control_sock: socket.socket | None = None
        self._out = bytearray()
        super().__init__()
        self.thread_name = f"rig {self.port}"
        self._t0: float | None = None
        self._produced = 0
        if control is not None:
            try:
                self._control_sock = _listen(control)
            except BaseException:
                self.control = None  # not ours: close() must not remove it
                self.close()
                raise

    # ------------------------------------------------------------------ lifetime
    def release(self) -> None:
        """Close the pty (the host then sees the device disappear), the link and the control socket."""
        close_fds(self.master_fd, self.slave_fd)
        self.master_fd = self.slave_fd = -1
        if self.link is not None and os.path.islink(self.link) and os.readlink(self.link) == self.port:
            os.unlink(self.link)  # only our own link: a later server may have taken the name
        if self._control_sock is not None:
            self._control_sock.close()
            self._control_sock = None
            if self.control is not None and _is_socket(self.control):
                os.unlink(self.control)

    # ------------------------------------------------------------------ loop
    def serve_forever(self) -> None:
        """Serve until :meth:`close` (or until the pty fails): :meth:`StepLoop.run` in this thread."""
        self.run()

    def step(self) -> None:
        """One round: wait for the pty, take commands, acquire samples, write what fits."""
        fd = self.master_fd
        dev = self.device
        want_write = bool(self._out) or (dev.streaming and not self.paced)
        timeout = self.tick_s if (dev.streaming or self._out) else 0.05
        ctl = self._control_sock
        r, w, _ = select.select([fd] if ctl is None else [fd, ctl], [fd] if want_write else [], [], timeout)
        if ctl is not None and ctl in r:
            self._serve_control(ctl)
            r = [x for x in r if x is not ctl]
        if r:
            try:
                data = os.read(fd, 65536)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                    data = b""
                elif exc.errno == errno.EIO:  # no host has the slave open: nothing to read
                    data = b""
                else:
                    raise
            if data:
                self._out += dev.receive(data)
        if dev.streaming:
            if self._t0 is None:
                self._t0 = self.clock()
                self._produced = 0
            if self.paced:
                due = int((self.clock() - self._t0) * dev.source.rate_hz) - self._produced
                while due > 0:  # block by block, as the firmware's acquisition interrupt would
                    n = min(due, dev.block_size)
                    frames = dev.acquire(n)
                    self._produced += n
                    due -= n
                    if len(self._out) + len(frames) > self.fifo_bytes:
                        self.overrun_frames += frames.count(b"\x00") // 2
                    else:
                        self._out += frames
            elif len(self._out) < 65536:
                n = max(dev.block_size, 4096 // max(1, len(dev.active_channels)))
                self._out += dev.acquire(n)
                self._produced += n
        else:
            self._t0 = None
        if self._out:
            try:
                written = os.write(fd, self._out)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                    written = 0
                elif exc.errno == errno.EIO:
                    written = 0
                else:
                    raise
            del self._out[:written]
            if not written and not r:
                time.sleep(0)  # let the host thread run


    def _serve_control(self, ctl: socket.socket) -> None:
        """Answer one strike request on the control socket (one JSON line in, one out)."""
        try:
            conn, _ = ctl.accept()
        except OSError:
            return
        with conn:
            conn.settimeout(1.0)
            try:
                line = conn.makefile("rb").readline(4096)
                answer = self._strike(line)
                conn.sendall((json.dumps(answer) + "\n").encode())
            except OSError:
                pass

    def _strike(self, line: bytes) -> dict[str, object]:
        try:
            req = json.loads(line.decode() or "{}")
            peak = float(req["peak_force_n"])
            double = bool(req.get("double_hit", False))
        except (ValueError, TypeError, KeyError, AttributeError, UnicodeDecodeError):
            return {"error": "expected one JSON line {\"peak_force_n\": N, \"double_hit\": false}"}
        deliver = getattr(self.device.source, "deliver_impact", None)
        if not callable(deliver):
            return {"error": "this rig has no hammer"}
        try:
            deliver(peak, double_hit=double)
        except (RigError, ValueError) as exc:
            return {"error": str(exc)}
        return {"at_sample": self.device.next_sample + self.device.pending_samples, "peak_force_n": peak}


def _listen(control: str) -> socket.socket:
    """A listening UNIX socket at ``control``, replacing only a dead socket left there.

    Raises
    ------
    RigError
        When a live rig serves there, or the path holds another kind of file.
    """
    if _is_socket(control):
        if _answers(control):
            raise RigError(f"--control {control}: another rig serves there; stop it or choose another path")
        os.unlink(control)  # a socket left by an earlier server
    elif os.path.lexists(control):
        raise RigError(f"--control {control}: exists and is not a socket; refusing to replace it")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.bind(control)
        sock.listen(4)
        sock.setblocking(False)
    except OSError as exc:
        sock.close()
        raise RigError(f"--control {control}: cannot listen there ({exc.strerror or exc})") from None
    return sock


def _answers(path: str) -> bool:
    """True when a server accepts connections on the UNIX socket ``path``."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        try:
            sock.connect(path)
            return True
        except OSError:
            return False


def _is_socket(path: str) -> bool:
    import stat

    try:
        return stat.S_ISSOCK(os.lstat(path).st_mode)
    except OSError:
        return False


def strike(control: str, peak_force_n: float, double_hit: bool = False, timeout_s: float = 10.0) -> int:
    """Strike a served rig through its control socket; returns the device sample counter then.

    Raises
    ------
    RigError
        When nothing serves at ``control`` or the rig refuses the blow (one line).
    """
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(timeout_s)
            sock.connect(control)
            sock.sendall((json.dumps({"peak_force_n": peak_force_n, "double_hit": double_hit}) + "\n").encode())
            answer = json.loads(sock.makefile("rb").readline(4096).decode() or "{}")
    except (OSError, ValueError) as exc:
        raise RigError(f"{control}: no rig answers there ({exc.strerror if isinstance(exc, OSError) and exc.strerror else exc}); "
                       "start one with `station rig serve --control PATH`") from None
    if "error" in answer or not isinstance(answer.get("at_sample"), int):
        raise RigError(f"{control}: the rig refused the blow: {answer.get('error', answer)}")
    return int(answer["at_sample"])


def serve_source(source: object, *, paced: bool, link: str | None = None, **device_options: object) -> PtyServer:
    """Start an :class:`EmulatedDaq` around ``source`` on a pty, in a thread.

    Raises
    ------
    RigError
        When the source does not fit the firmware.
    """
    if not hasattr(source, "read") or not hasattr(source, "channels"):
        raise RigError(f"a rig source needs read() and channels, got {type(source).__name__}")
    device = EmulatedDaq(source, **device_options)  # type: ignore[arg-type]
    return PtyServer(device, paced=paced, link=link).start()


def _replace_own_link(link: str, port: str) -> None:
    """Point the symlink ``link`` at ``port``, replacing only a link to a pty (a previous server's).

    Raises
    ------
    RigError
        ``link`` exists and is a regular file, a folder, or a link to something else.
    """
    if os.path.lexists(link):
        if not os.path.islink(link):
            raise RigError(f"--link {link}: exists and is not a symbolic link; refusing to replace it")
        target = os.readlink(link)
        if not target.startswith("/dev/pts/"):
            raise RigError(f"--link {link}: is a link to {target}, not to a pty a rig made; refusing to replace it")
        os.unlink(link)
    try:
        os.symlink(port, link)
    except FileNotFoundError:
        raise RigError(f"--link {link}: the folder {os.path.dirname(link) or '.'} does not exist") from None


# ------------------------------------------------------------------------------------------
# the rig as a process of its own

#: Longest wait for a rig process to power on (imports, physics, a JIT compile on a cold
#: cache, on a busy machine), [s]. Power-on, not a command: no command timeout includes it.
RIG_START_TIMEOUT_S = 300.0


def build_firmware(system: str, seed: int | None = None, block_size: int = 256) -> EmulatedDaq:
    """The emulated DAQ of a named system (physics resolved, simulator compiled).

    A multi-DOF system (:func:`simulated_rig.mdof_systems.mdof_systems`) streams the force and
    one accelerometer per mass (:class:`simulated_rig.mdof_source.MdofRigSource`).

    Raises
    ------
    ScenarioError
        For an unknown system (the message lists the known ones).
    """
    from simulated_rig.mdof_systems import mdof_systems
    from simulated_rig.source import RigSource
    from simulated_rig.systems import SYSTEMS, system_info

    if system in mdof_systems():  # force + one accelerometer per mass
        from simulated_rig.mdof_source import MdofRigSource

        source: object = MdofRigSource.from_system(system, seed=seed)
    else:
        if system not in SYSTEMS:
            raise ScenarioError(f"unknown system {system!r}; known: {', '.join(tuple(SYSTEMS) + mdof_systems())}")
        system_info(system)
        source = RigSource.from_system(system, seed=seed)
    warm_up(source)
    return EmulatedDaq(source, model=f"EDDI-SIM ({system})", serial=f"SIM-{system}", block_size=block_size)


def warm_up(source: object) -> None:
    """Run every compiled path of a rig source once, on a throw-away copy (JIT before power-on).

    A blow, its first window and one continuation chunk: the kernels a later blow runs are
    then compiled (or loaded from the cache), so no command waits for a compiler.
    """
    deliver = getattr(source, "deliver_impact", None)
    if not callable(deliver):
        return
    spare = copy.deepcopy(source)
    reference = 1.0
    try:
        reference = float(json.loads(getattr(spare, "scenario_json", "") or "{}")["source"]["reference_force_n"])
    except (ValueError, KeyError, TypeError):
        pass
    spare.deliver_impact(reference)
    rate = float(getattr(spare, "rate_hz", 1000.0))
    spare.read(int(1.2 * rate))


def _watch_stdin(stop: Callable[[], None]) -> None:
    """Stop the server when the parent closes our stdin (or dies)."""
    try:
        while sys.stdin.buffer.read(4096):
            pass
    except (OSError, ValueError):
        pass
    stop()


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m simulated_rig.serve --system NAME``: serve a rig on a pty until stdin closes.

    Prints one JSON line when powered on: ``{"port": "/dev/pts/N", "pid": P, ...}``. A bad
    system ends in one line on stderr and exit code 2.
    """
    ap = argparse.ArgumentParser(prog="python -m simulated_rig.serve", description=main.__doc__)
    ap.add_argument("--system", required=True)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--paced", action="store_true", help="sample time follows the clock (default: as fast as read)")
    ap.add_argument("--block-size", type=int, default=256)
    ap.add_argument("--link", default=None)
    ap.add_argument("--control", default=None)
    args = ap.parse_args(argv)
    try:
        firmware = build_firmware(args.system, args.seed, args.block_size)
        server = PtyServer(firmware, paced=args.paced, link=args.link, control=args.control)
    except (RigError, OSError) as exc:
        print(f"rig: error: {exc}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: server.stop())
    threading.Thread(target=_watch_stdin, args=(server.stop,), daemon=True).start()
    print(json.dumps({"port": server.port, "pid": os.getpid(), "system": args.system, "paced": args.paced}),
          flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
    if server.error is not None:
        print(f"rig: error: {server.error}", file=sys.stderr)
        return 2
    return 0


class RigProcess:
    """A simulated rig running in its own process (``python -m simulated_rig.serve``).

    Start it, do other work, then :meth:`wait_ready` for its port. Closing it (or the parent
    exiting) stops the rig.

    Parameters
    ----------
    system : str
    seed : int or None
    paced : bool
    block_size : int
    """

    def __init__(self, system: str, *, seed: int | None = None, paced: bool = False, block_size: int = 256) -> None:
        cmd = [sys.executable, "-m", "simulated_rig.serve", "--system", system, "--block-size", str(block_size)]
        if seed is not None:
            cmd += ["--seed", str(seed)]
        if paced:
            cmd.append("--paced")
        env = dict(os.environ)
        here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # this checkout first
        env["PYTHONPATH"] = os.pathsep.join([here] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        self.system = system
        self.port: str | None = None
        self._stderr = tempfile.TemporaryFile()  # a file, not a pipe: a chatty rig can never block on it
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._stderr,
                                      env=env, start_new_session=True)

    @property
    def pid(self) -> int:
        return self._proc.pid

    def wait_ready(self, timeout_s: float = RIG_START_TIMEOUT_S) -> str:
        """Wait for the rig to power on; returns its pty path.

        Raises
        ------
        RigError
            When it exits or stays silent (the rig's own one-line error when it gave one).
        """
        if self.port is not None:
            return self.port
        out: IO[bytes] = self._proc.stdout  # type: ignore[assignment]
        ready, _, _ = select.select([out], [], [], timeout_s)
        line = out.readline() if ready else b""
        try:
            self.port = str(json.loads(line.decode())["port"])
        except (ValueError, KeyError, TypeError):
            if ready:  # it said something that is not the port: it is exiting; let it finish
                try:
                    self._proc.wait(timeout=10.0)
                except subprocess.TimeoutExpired:
                    pass
            self._stderr.seek(0)
            err = self._stderr.read().decode(errors="replace").strip()
            self.close()
            why = err.splitlines()[-1] if err else f"no answer within {timeout_s:g} s"
            raise RigError(f"the simulated rig {self.system!r} did not start: {why}") from None
        return self.port

    def close(self) -> None:
        """Stop the rig process (idempotent)."""
        proc = self._proc
        if proc.poll() is None:
            try:
                if proc.stdin:
                    proc.stdin.close()
                proc.wait(timeout=5.0)
            except (OSError, subprocess.TimeoutExpired):
                proc.kill()
                proc.wait()
        for f in (proc.stdin, proc.stdout, self._stderr):
            if f is not None and not f.closed:
                f.close()

    def __enter__(self) -> "RigProcess":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


if __name__ == "__main__":
    sys.exit(main())
