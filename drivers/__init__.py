"""Drivers for DAQ devices speaking the EDDI wire protocol (``docs/protocol.md``).

>>> with open_device("serial:///dev/ttyACM0") as daq:   # doctest: +SKIP
...     daq.configure(rate_hz=51200, block_size=256)
...     daq.start()
...     block = daq.read_block(timeout_s=1.0)
"""

from __future__ import annotations

from drivers.channels import ChannelInfo
from drivers.daq import Block, Daq, DeviceInfo, Stats
from drivers.errors import BadUrlError
from drivers.transport import Transport, open_transport

__all__ = ["Block", "ChannelInfo", "Daq", "DeviceInfo", "Stats", "Transport", "open_device"]


def open_device(url: str, *, timeout_s: float = 2.0, queue_blocks: int = 1024, usb_backend: object = None) -> Daq:
    """Open the DAQ at ``url`` and identify it.

    Parameters
    ----------
    url : str
        ``serial:///dev/ttyACM0?baudrate=921600``, ``loop://``, ``socket://host:port``,
        ``rfc2217://host:port``, ``usb://VID:PID[/SERIAL]`` or ``audio://DEVICE?channels=...``
        (a PortAudio input, :mod:`drivers.audio`). (``sim://SYSTEM`` is opened by
        :func:`station.devices.open_device`, which starts the simulated rig.)
    timeout_s : float
        Reply timeout of every command, [s].
    queue_blocks : int
        Bound of the queue of received blocks.
    usb_backend : pyusb backend or None
        For ``usb://``: the backend to enumerate with (default libusb 1.0; tests hand in
        ``simulated_rig.usb.EmulatedUsbBackend``).

    Raises
    ------
    BadUrlError, DeviceNotFoundError, DeviceTimeoutError, ProtocolVersionError
        One line each: the URL is not understood, nothing is there, nothing answers, or it
        speaks another protocol version.
    """
    if isinstance(url, str) and url.lower().startswith("sim://"):
        raise BadUrlError(f"{url}: sim:// URLs are opened by station.devices.open_device (which starts the rig)")
    if isinstance(url, str) and url.lower().startswith("audio://"):
        from drivers.audio import open_audio

        return open_audio(url, timeout_s=timeout_s, queue_blocks=queue_blocks)  # type: ignore[return-value]
    transport = open_transport(url, usb_backend=usb_backend)
    try:
        return Daq(transport, timeout_s=timeout_s, queue_blocks=queue_blocks)
    except BaseException:
        transport.close()
        raise
