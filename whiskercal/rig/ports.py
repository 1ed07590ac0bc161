"""Serial port discovery: list ports and recognize the USB bridges Arduino boards use."""

from __future__ import annotations

from dataclasses import asdict, dataclass

# (vendor id, product id or None for any) -> what that USB device is. A genuine Nano (classic)
# carries an FTDI FT232RL; most clones carry a WCH CH340; newer boards have Arduino's own ids.
USB_BRIDGES: dict[tuple[int, int | None], str] = {
    (0x2341, None): "Arduino (genuine board, Arduino LLC USB id)",
    (0x2A03, None): "Arduino (genuine board, Arduino.org USB id)",
    (0x1A86, 0x7523): "WCH CH340 USB-serial (Arduino Nano clones)",
    (0x1A86, 0x55D4): "WCH CH9102 USB-serial (Arduino Nano clones)",
    (0x0403, 0x6001): "FTDI FT232R USB-serial (Arduino Nano classic)",
    (0x0403, 0x6015): "FTDI FT231X USB-serial",
    (0x10C4, 0xEA60): "Silicon Labs CP210x USB-serial",
}


@dataclass(frozen=True)
class PortInfo:
    """One serial port: device path, USB ids (None if not USB), what we recognize it as."""

    device: str
    description: str
    vid: int | None
    pid: int | None
    serial_number: str | None
    recognized: str | None

    def as_dict(self) -> dict:
        """Plain values for JSON; USB ids as ``0x2341``-style strings."""
        values = asdict(self)
        values["vid"] = None if self.vid is None else f"0x{self.vid:04X}"
        values["pid"] = None if self.pid is None else f"0x{self.pid:04X}"
        return values


def recognize(vid: int | None, pid: int | None) -> str | None:
    """Name the USB bridge for a vendor/product id pair, or None when it is not a known one."""
    if vid is None:
        return None
    return USB_BRIDGES.get((vid, pid)) or USB_BRIDGES.get((vid, None))


def list_ports() -> list[PortInfo]:
    """Every serial port the OS reports, USB-recognized ones first, then by device path."""
    from serial.tools import list_ports as serial_list_ports

    found = [PortInfo(p.device, p.description or "", p.vid, p.pid, p.serial_number,
                      recognize(p.vid, p.pid)) for p in serial_list_ports.comports()]
    return sorted(found, key=lambda p: (p.recognized is None, p.device))
