"""The open DAQ firmware (``firmware/``) running in QEMU, served on a pty like the Python rig.

:class:`QemuRig` builds the QEMU image if needed (``make -C firmware``, Debian's
``gcc-arm-none-eabi``), starts ``qemu-system-arm -M netduinoplus2`` with the firmware's USART
on ``-serial pty``, and puts a :class:`~simulated_rig.relay.PtyRelay` in front of QEMU's pty,
so the host opens a port whose reader QEMU always sees (QEMU discards what the guest writes
while no one holds its pty, and notices a new reader only once a second).

Everything on the wire (sequence numbers, CRC, sample counter, rate, the oscillator's
samples) comes from the firmware. The oscillator's parameters of a named ``system`` are
written into the firmware's RAM before boot with QEMU's generic loader; the firmware reports
the parameters it runs in the IDENTIFY reply (``scenario``).
"""

from __future__ import annotations

import os
import re
import select
import shutil
import struct
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from simulated_rig.errors import EmulatorError
from simulated_rig.relay import PtyRelay

#: The firmware source tree.
FIRMWARE_DIR = Path(__file__).resolve().parents[1] / "firmware"
#: The QEMU image, relative to :data:`FIRMWARE_DIR`.
QEMU_IMAGE = "build/qemu/eddi-daq-qemu.elf"
#: QEMU machines with the STM32F405 this firmware is built for.
MACHINES = ("netduinoplus2",)
#: Where the firmware looks for oscillator parameters at boot (see firmware/src/board_qemu.c).
OVERRIDE_ADDR = 0x2001FF00
OVERRIDE_MAGIC = 0xEDD15EED


@dataclass(frozen=True)
class FirmwareSystem:
    """Oscillator the firmware synthesises: m x'' + c1 v + k1 x + k3 x^3 = F(t).

    Attributes
    ----------
    mass_kg, c1, k1, k3 : float
        [kg], [N s/m], [N/m], [N/m^3].
    seed : int
        Noise generator seed (0: the firmware's own).
    builtin : bool
        The firmware's compiled-in default (nothing is written before boot).
    """

    mass_kg: float
    c1: float
    k1: float
    k3: float
    seed: int = 0
    builtin: bool = False


#: Systems ``station rig qemu --system`` accepts.
FIRMWARE_SYSTEMS: dict[str, FirmwareSystem] = {
    "duffing": FirmwareSystem(0.5, 0.8, 2000.0, 5.0e6, builtin=True),
    "duffing-soft": FirmwareSystem(0.8, 1.2, 1200.0, 2.0e6, seed=7),
    "duffing-stiff": FirmwareSystem(0.3, 0.5, 3500.0, 2.0e7, seed=11),
    "linear": FirmwareSystem(0.5, 0.8, 2000.0, 0.0, seed=3),
}


def toolchain_missing() -> str | None:
    """Why the emulated firmware cannot run here (None when it can)."""
    for tool in ("arm-none-eabi-gcc", "qemu-system-arm", "make"):
        if shutil.which(tool) is None:
            return f"{tool} not found (apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm make)"
    return None


def build_firmware(target: str = QEMU_IMAGE, *, timeout_s: float = 300.0) -> Path:
    """``make -C firmware TARGET`` (does nothing when up to date); returns the image path.

    Raises
    ------
    EmulatorError
        When the toolchain is missing or the build fails (the compiler's last line).
    """
    why = toolchain_missing()
    if why is not None:
        raise EmulatorError(f"cannot build the firmware: {why}")
    proc = subprocess.run(["make", "-s", "-C", str(FIRMWARE_DIR), target], capture_output=True, text=True,
                          timeout=timeout_s)
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines() or ["no output"]
        raise EmulatorError(f"firmware build failed: {lines[-1]}")
    return FIRMWARE_DIR / target


def loader_args(system: FirmwareSystem) -> list[str]:
    """QEMU ``-device loader`` options writing ``system``'s parameters before boot."""
    if system.builtin:
        return []
    words = [OVERRIDE_MAGIC] + [struct.unpack("<I", struct.pack("<f", v))[0]
                                for v in (system.mass_kg, system.c1, system.k1, system.k3)] + [system.seed]
    args: list[str] = []
    for i, w in enumerate(words):
        args += ["-device", f"loader,addr=0x{OVERRIDE_ADDR + 4 * i:08x},data=0x{w:08x},data-len=4"]
    return args


class QemuRig:
    """QEMU running the firmware, with a relay pty for the host (a context manager).

    Parameters
    ----------
    system : str
        One of :data:`FIRMWARE_SYSTEMS`.
    machine : str
        QEMU machine (:data:`MACHINES`).
    build : bool
        Run ``make`` first (a no-op when the image is up to date).
    corrupt_data_frame : int or None
        Let the relay corrupt one byte of this DATA frame (fault injection).
    tap : bool
        Let the relay decode the clean stream (for tests).
    link : str or None
        Also make a symlink to the host's pty at this path.
    start_timeout_s : float
        How long QEMU may take to announce its pty, [s].
    """

    def __init__(self, system: str = "duffing", *, machine: str = "netduinoplus2", build: bool = True,
                 corrupt_data_frame: int | None = None, tap: bool = False, link: str | None = None,
                 start_timeout_s: float = 20.0) -> None:
        if system not in FIRMWARE_SYSTEMS:
            raise EmulatorError(f"no firmware system {system!r}; known: {', '.join(FIRMWARE_SYSTEMS)}")
        if machine not in MACHINES:
            raise EmulatorError(f"QEMU machine must be one of {', '.join(MACHINES)}, got {machine!r}")
        self.system = system
        self.machine = machine
        self.build = build
        self.corrupt_data_frame = corrupt_data_frame
        self.tap = tap
        self.link = link
        self.start_timeout_s = start_timeout_s
        self.proc: subprocess.Popen[bytes] | None = None
        self.relay: PtyRelay | None = None
        self.qemu_port = ""

    @property
    def port(self) -> str:
        """The pty the host opens."""
        if self.relay is None:
            raise EmulatorError("the emulator is not running")
        return self.relay.port

    @property
    def url(self) -> str:
        return f"serial://{self.link or self.port}"

    def command(self, image: Path) -> list[str]:
        """The QEMU command line."""
        return ["qemu-system-arm", "-M", self.machine, "-nographic", "-monitor", "none", "-serial", "pty",
                "-kernel", str(image), *loader_args(FIRMWARE_SYSTEMS[self.system])]

    def start(self) -> "QemuRig":
        """Build if needed, start QEMU, open its pty through the relay.

        Raises
        ------
        EmulatorError
            Missing toolchain or QEMU, failed build, or QEMU not announcing its pty in time.
        """
        image = build_firmware() if self.build else FIRMWARE_DIR / QEMU_IMAGE
        if not image.exists():
            raise EmulatorError(f"no firmware image at {image}; run make -C firmware")
        if shutil.which("qemu-system-arm") is None:
            raise EmulatorError("qemu-system-arm not found (apt-get install qemu-system-arm)")
        try:
            self.proc = subprocess.Popen(self.command(image), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=subprocess.STDOUT)
            self.qemu_port = self._wait_for_pty()
            self.relay = PtyRelay(self.qemu_port, corrupt_data_frame=self.corrupt_data_frame, tap=self.tap)
            self.relay.wait_for_device(self.start_timeout_s)   # the firmware runs: no command gets lost
            self.relay.start()
            if self.link is not None:
                if os.path.lexists(self.link):
                    os.unlink(self.link)
                os.symlink(self.relay.port, self.link)
        except BaseException:
            self.close()
            raise
        return self

    def _wait_for_pty(self) -> str:
        assert self.proc is not None and self.proc.stdout is not None
        deadline = time.monotonic() + self.start_timeout_s
        seen = b""
        fd = self.proc.stdout.fileno()
        while time.monotonic() < deadline:
            r, _, _ = select.select([fd], [], [], 0.1)
            if r:
                chunk = os.read(fd, 4096)
                if not chunk:
                    break
                seen += chunk
                m = re.search(rb"redirected to (/dev/pts/\d+)", seen)
                if m:
                    return m.group(1).decode()
            if self.proc.poll() is not None:
                break
        text = seen.decode(errors="replace").strip().splitlines()
        raise EmulatorError(f"QEMU did not announce its serial pty within {self.start_timeout_s:g} s"
                            + (f": {text[-1]}" if text else ""))

    @property
    def error(self) -> BaseException | None:
        """What stopped the relay or QEMU, if anything did."""
        if self.relay is not None and self.relay.error is not None:
            return self.relay.error
        if self.proc is not None and self.proc.poll() is not None:
            return EmulatorError(f"QEMU exited with status {self.proc.returncode}")
        return None

    def close(self) -> None:
        """Stop the relay and QEMU (idempotent)."""
        if self.relay is not None:
            self.relay.close()
        if self.link is not None and os.path.islink(self.link):
            os.unlink(self.link)
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5)
        if self.proc is not None and self.proc.stdout is not None:
            self.proc.stdout.close()

    def __enter__(self) -> "QemuRig":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
