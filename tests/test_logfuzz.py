"""Regressions found by mutating real-world-shaped logs (truncations, flipped bytes, altered formats,
timestamps out of order) and running every command that takes a log on them: each input is made here
(tests/dataflash_writer.py, tests/ulog_writer.py or bytes written in the test), and each test checks the
contract of ../shared/spec/INTERFACES.md: one stderr line naming the file, exit 2 or 1, no traceback."""
from __future__ import annotations

from pathlib import Path

from dobwind.cli.app import main
from tests import atmos_logs
from tests.helpers import M300


def _garbled(path: Path) -> Path:
    """4 kB of bytes that are no DataFlash message in the middle of ``path``: DFReader skips them byte by
    byte, printing a "bad header" line for each, partly from compiled code to descriptor 2."""
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 4096] = bytes((7 * k + 13) % 256 for k in range(4096))
    path.write_bytes(bytes(data))
    return path


def test_profile_of_a_damaged_dataflash_log_prints_no_reader_chatter(tmp_path, capfd):
    """The position track (dobwind/io/position.py) read DataFlash with Python's redirect_stdout only:
    pymavlink's per-byte "bad header" lines reached stderr, 157 of them for a 4-byte flip in a real
    ArduCopter log. capfd reads descriptors 1 and 2 themselves."""
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = _garbled(atmos_logs.write_log(tmp_path / "f.bin", cols))
    capfd.readouterr()
    code = main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv"), "--allow", "uncalibrated"])
    done = capfd.readouterr()
    assert "bad header" not in done.out + done.err
    assert code == 0 or len(done.err.strip().splitlines()) == 1, done.err
