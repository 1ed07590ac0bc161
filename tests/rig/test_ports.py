"""Port discovery: USB ids are recognized; the command prints JSON."""

import json
from types import SimpleNamespace

from click.testing import CliRunner

from whiskercal.cli import cli
from whiskercal.rig import ports


def _fake(device, vid=None, pid=None, description="n/a"):
    return SimpleNamespace(device=device, description=description, vid=vid, pid=pid, serial_number=None)


def test_recognizes_bridges():
    assert "CH340" in ports.recognize(0x1A86, 0x7523)
    assert "FT232" in ports.recognize(0x0403, 0x6001)
    assert "CP210x" in ports.recognize(0x10C4, 0xEA60)
    assert "Arduino" in ports.recognize(0x2341, 0x0043)
    assert ports.recognize(0x1234, 0x5678) is None
    assert ports.recognize(None, None) is None


def test_ports_json_lists_recognized_first(monkeypatch):
    fake_ports = [_fake("/dev/ttyS0"), _fake("/dev/ttyUSB0", 0x1A86, 0x7523, "USB Serial")]
    monkeypatch.setattr("serial.tools.list_ports.comports", lambda: fake_ports)
    result = CliRunner().invoke(cli, ["ports", "--json"], catch_exceptions=False)
    assert result.exit_code == 0
    listed = json.loads(result.output)
    assert [p["device"] for p in listed] == ["/dev/ttyUSB0", "/dev/ttyS0"]
    assert listed[0]["vid"] == "0x1A86" and "CH340" in listed[0]["recognized"]


def test_ports_text_without_ports(monkeypatch):
    monkeypatch.setattr("serial.tools.list_ports.comports", lambda: [])
    result = CliRunner().invoke(cli, ["ports"], catch_exceptions=False)
    assert "no serial ports found" in result.output
