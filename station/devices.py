"""Device URLs for the station: everything :func:`drivers.open_device` opens, plus ``sim://``.

``sim://SYSTEM[?seed=N&paced=1&transport=pty|usb]`` starts the simulated rig (physics of the
named system, emulated DAQ firmware) and opens it through the real driver code path:

* ``transport=pty`` (default): the rig runs in a process of its own, like a real device
  (:class:`simulated_rig.serve.RigProcess`): it builds its physics and compiles its simulator
  before it powers on and serves its firmware on a pseudo-terminal, which the driver opens as
  a serial port. A busy host or a cold JIT cache delays its power-on, never a command;
* ``transport=usb``: the firmware sits behind the emulated pyusb backend and the driver opens
  ``usb://1209:edd1/SIM-SYSTEM``.

Sample time is unpaced unless ``paced=1``: the rig runs as fast as the host reads (fast and
deterministic), or in real time. Closing the returned :class:`drivers.Daq` stops the rig.
"""

from __future__ import annotations

import urllib.parse
from dataclasses import dataclass
from typing import Any, Callable

import serial.tools.list_ports

import drivers
from drivers.errors import BadUrlError, DeviceNotFoundError, DriverError
from drivers.usb import DEFAULT_PID, DEFAULT_VID, list_usb_devices

_SIM_OPTIONS = {"seed", "paced", "transport"}


@dataclass(frozen=True)
class SimUrl:
    """A parsed ``sim://`` URL."""

    system: str
    seed: int | None = None
    paced: bool = False
    transport: str = "pty"


@dataclass(frozen=True)
class DeviceEntry:
    """One line of ``station devices``.

    Attributes
    ----------
    url : str
        What to pass to :func:`open_device`.
    kind : str
        ``"serial"``, ``"usb"`` or ``"sim"``.
    description : str
    speaks_protocol : bool or None
        True when known to be an EDDI DAQ, False when known not to be, None when unknown
        (serial ports are not probed unless asked).
    """

    url: str
    kind: str
    description: str
    speaks_protocol: bool | None = None


def simulated_systems() -> tuple[str, ...]:
    """Names accepted by ``sim://``."""
    from simulated_rig.mdof_systems import mdof_systems
    from simulated_rig.systems import SYSTEMS

    return tuple(SYSTEMS) + mdof_systems()


def parse_sim_url(url: str) -> SimUrl:
    """``sim://duffing-smooth?seed=3&paced=1`` -> :class:`SimUrl`.

    Raises
    ------
    BadUrlError
        On a malformed URL or option.
    DeviceNotFoundError
        On an unknown system (the message lists the known ones).
    """
    parts = urllib.parse.urlsplit(url)
    system = (parts.netloc + parts.path).strip("/")
    if parts.scheme != "sim" or not system:
        raise BadUrlError(f"expected sim://SYSTEM[?seed=N&paced=1&transport=pty|usb], got {url!r}")
    known = simulated_systems()
    if system not in known:
        raise DeviceNotFoundError(f"no simulated system {system!r}; known: {', '.join(known)}")
    opts: dict[str, Any] = {}
    for key, value in urllib.parse.parse_qsl(parts.query, keep_blank_values=True):
        if key not in _SIM_OPTIONS:
            raise BadUrlError(f"unknown sim option {key!r} in {url!r}; expected one of {sorted(_SIM_OPTIONS)}")
        if key == "seed":
            try:
                opts["seed"] = int(value)
            except ValueError:
                raise BadUrlError(f"sim option seed must be an integer, got {value!r}") from None
        elif key == "paced":
            opts["paced"] = value.lower() in ("1", "true", "yes", "")
        else:
            if value not in ("pty", "usb"):
                raise BadUrlError(f"sim option transport must be pty or usb, got {value!r}")
            opts["transport"] = value
    return SimUrl(system, **opts)


def open_device(url: str, *, timeout_s: float = 2.0, queue_blocks: int = 1024, usb_backend: object = None,
                while_starting: Callable[[], None] | None = None) -> drivers.Daq:
    """Open a DAQ by URL; ``sim://SYSTEM`` starts the simulated rig first.

    Parameters
    ----------
    url : str
        ``sim://SYSTEM[?seed=N&paced=1&transport=pty|usb]`` or any URL of
        :func:`drivers.open_device` (``serial://``, ``loop://``, ``socket://``, ``usb://``...).
    timeout_s : float
        Reply timeout of every command, [s].
    queue_blocks : int
        Bound of the driver's block queue.
    usb_backend : pyusb backend or None
        For ``usb://`` URLs.
    while_starting : callable, optional
        Run while a simulated rig process powers on (e.g. to warm up the host's JIT).

    Raises
    ------
    drivers.errors.DriverError
        One-line errors: bad URL, unknown device or system, no answer, other protocol version.
    """
    if not isinstance(url, str) or not url.lower().startswith("sim://"):
        return drivers.open_device(url, timeout_s=timeout_s, queue_blocks=queue_blocks, usb_backend=usb_backend)
    sim = parse_sim_url(url)
    if sim.transport == "usb":
        if sim.paced:
            raise BadUrlError("sim option paced=1 is only available with transport=pty")
        from simulated_rig.serve import build_firmware
        from simulated_rig.usb import EmulatedUsbBackend

        backend = EmulatedUsbBackend(build_firmware(sim.system, sim.seed))
        return drivers.open_device(
            f"usb://{DEFAULT_VID:04x}:{DEFAULT_PID:04x}/SIM-{sim.system}",
            timeout_s=timeout_s, queue_blocks=queue_blocks, usb_backend=backend,
        )
    from drivers.daq import Daq
    from drivers.transport import open_transport
    from simulated_rig.serve import RigProcess

    rig = RigProcess(sim.system, seed=sim.seed, paced=sim.paced)
    try:
        if while_starting is not None:
            while_starting()
        port = rig.wait_ready()
        transport = open_transport(f"serial://{port}")
        return Daq(transport, timeout_s=timeout_s, queue_blocks=queue_blocks, on_close=[rig.close])
    except BaseException:
        rig.close()
        raise


def list_devices(*, usb_backend: object = None, probe: bool = False, probe_timeout_s: float = 0.3) -> list[DeviceEntry]:
    """Serial ports (pyserial's ``list_ports``), USB devices speaking the protocol, and the
    simulated rig's systems.

    Parameters
    ----------
    usb_backend : pyusb backend or None
        Default libusb 1.0 (none found: no USB entries).
    probe : bool
        Open each serial port and ask it to identify (``speaks_protocol`` then True/False).
    probe_timeout_s : float
        Reply timeout of each probe, [s].
    """
    entries: list[DeviceEntry] = []
    for port in sorted(serial.tools.list_ports.comports(), key=lambda p: p.device):
        desc = port.description if port.description and port.description != "n/a" else ""
        if port.vid is not None:
            desc = f"{desc} [{port.vid:04x}:{port.pid:04x}]".strip()
        url = f"serial://{port.device}"
        speaks: bool | None = None
        if probe:
            try:
                with drivers.open_device(url, timeout_s=probe_timeout_s) as daq:
                    desc = f"{daq.info.model} serial {daq.info.serial} ({desc})" if desc else daq.info.model
                speaks = True
            except (DriverError, OSError):
                speaks = False
        entries.append(DeviceEntry(url, "serial", desc or port.device, speaks))
    for dev in list_usb_devices(usb_backend):
        desc = f"{dev.product or 'EDDI DAQ'} serial {dev.serial or '?'} (protocol v{dev.protocol_version})"
        entries.append(DeviceEntry(dev.url, "usb", desc, True))
    for name in simulated_systems():
        entries.append(DeviceEntry(f"sim://{name}", "sim", f"simulated rig: {name}", True))
    return entries
