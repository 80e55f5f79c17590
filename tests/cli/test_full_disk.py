"""A full disk (simulated by a file size limit, as ``ulimit -f``) while converting or
recording: one line naming the file, exit 1; a conversion leaves no half-written file, a
recording keeps whole frames up to its last flush, whatever the format (found by the attack
pass: .db was "unexpected OperationalError: disk I/O error", a recording ended in half a
frame)."""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from blinkcan.formats.log_writers import WRITERS
from blinkcan.formats.logs import read_messages
from tests.processes import multicast_bus, stop

#: the CLI under a file size limit of 64 KiB
LIMITED = ("import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (65536, 65536)); "
           "from blinkcan.cli.main import main; sys.argv[0] = 'blinkcan'; main()")
FORMATS = sorted({".pcap", *WRITERS} - {".mf4"})  # .mf4: asammdf, where it is installed


def limited(*arguments: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", LIMITED, *arguments], capture_output=True,
                          text=True, timeout=120, check=False)


@pytest.mark.parametrize("suffix", FORMATS)
def test_convert_onto_a_full_disk(tmp_path: Path, suffix: str) -> None:
    source = tmp_path / "big.log"
    source.write_text("".join(f"({n / 1000:.6f}) can0 195#0800000001\n" for n in range(20000)))
    target = tmp_path / f"out{suffix}"
    result = limited("convert", str(source), str(target))
    assert result.returncode == 1, result
    assert len(result.stderr.splitlines()) == 1, result.stderr
    assert result.stderr.startswith(f"Error: cannot write {target}: "), result.stderr
    assert not target.exists()


RECORDABLE = [".log", ".pcap", ".asc", ".blf", ".csv", ".trc"]


@pytest.mark.multiprocess
def test_a_recording_onto_a_full_disk_keeps_whole_frames(tmp_path: Path) -> None:
    """``record`` under a file size limit of 8 KiB: it ends with one line saying the file is
    kept, and each file reads back whole up to its last flush (a full disk left half a frame:
    '(1' in .log, a truncated packet header in .pcap; found by the attack pass)."""
    channel = f"239.74.{random.randint(1, 254)}.{random.randint(1, 254)}"
    port = random.randint(40000, 60000)
    host = multicast_bus(channel, port)
    small = LIMITED.replace("65536, 65536", "8192, 8192")
    targets = [tmp_path / f"full{suffix}" for suffix in RECORDABLE]
    children = [subprocess.Popen(
        [sys.executable, "-c", small, "record", str(target), "-i", "udp_multicast", "-c",
         channel, "--bus-kwargs", f"port={port}", "hop_limit=0", "--duration", "30"],
        stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        for target in targets]
    try:
        for child in children:  # each has joined the group when it says so
            assert child.stderr is not None
            assert "recording" in child.stderr.readline()
        for number in range(100):  # a hundred frames, flushed (at least every second)
            host.send(can.Message(arbitration_id=0x715, data=number.to_bytes(4, "big"),
                                  is_extended_id=False))
        time.sleep(2.5)
        deadline = time.monotonic() + 30
        while any(c.poll() is None for c in children) and time.monotonic() < deadline:
            number += 1  # then more than the disk takes
            host.send(can.Message(arbitration_id=0x715, data=number.to_bytes(4, "big"),
                                  is_extended_id=False))
            time.sleep(0.001)
        errors = {t.suffix: (c.wait(timeout=10), c.stderr.read() if c.stderr else "")
                  for t, c in zip(targets, children, strict=True)}
    finally:
        for child in children:
            stop(child)
            if child.stderr is not None:
                child.stderr.close()
        host.shutdown()
    for target in targets:
        status, error = errors[target.suffix]
        assert status == 1, (target.name, error)
        [line] = [line for line in error.splitlines() if line.startswith("Error: ")]
        assert line.startswith(f"Error: cannot write {target}: File too large; what was "
                               "recorded up to its last flush is in it"), line
        numbers = [int.from_bytes(m.data, "big") for m in read_messages(target)]
        assert numbers == list(range(len(numbers))), target.name
        assert len(numbers) >= 100, target.name


def test_a_conversion_whose_last_write_fails_leaves_no_temporary_file(tmp_path: Path) -> None:
    """The .db writer commits its last rows when it is closed: on a full disk that failed
    after the frames were written, and the temporary .out.db.XXXX.db stayed beside the
    target (found by the attack pass)."""
    source = tmp_path / "big.log"
    source.write_text("".join(f"({n / 1000:.6f}) can0 195#0800000001\n" for n in range(20000)))
    limited = ("import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (65536, 65536)); "
               "from blinkcan.cli.main import main; sys.argv[0] = 'blinkcan'; main()")
    result = subprocess.run([sys.executable, "-c", limited, "convert", str(source),
                             str(tmp_path / "out.db")], capture_output=True, text=True,
                            timeout=120, check=False)
    assert result.returncode == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.log"]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full here")
@pytest.mark.parametrize("arguments", [("export", "dbc", "keybox", "-o", "-"),
                                       ("export", "eds", "keypad", "-o", "-")])
def test_output_onto_a_full_device_is_one_line_saying_so(arguments: tuple[str, ...]) -> None:
    """Standard output on a full disk (/dev/full) was "Error: cannot use: No space left on
    device": use of what?"""
    with open("/dev/full", "w") as full:
        result = subprocess.run([sys.executable, "-m", "blinkcan", *arguments], stdout=full,
                                stderr=subprocess.PIPE, text=True, timeout=120, check=False)
    assert result.returncode == 1
    assert result.stderr == "Error: cannot write the output: No space left on device\n"
