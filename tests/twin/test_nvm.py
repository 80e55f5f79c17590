"""Non-volatile settings in a file: nothing acknowledged is lost, nothing found is replaced, one
twin at a time, nothing left behind by a killed writer."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from blinkcan.twin import KeyboxTwin, KeypadTwin, NvmError
from tests.conftest import frame
from tests.twin.trace import Bench

HEARTBEAT_200 = "> 615 2B 17 10 00 C8 00 00 00"
HARDWARE_ERROR = "< 595 80 17 10 00 00 00 06 06"  # 0606 0000h, see twin/base.py


def _disk_full(*_: object) -> None:
    raise OSError(28, "No space left on device")


def _stray_files(directory: Path, keep: str) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name not in (keep, f".{keep}.lock"))


def test_a_write_the_nvm_cannot_take_aborts_and_changes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "keypad.json"
    bench = Bench(KeypadTwin(nvm=path))
    bench.replay("on\n< 715 00")
    stored = path.read_text()
    with monkeypatch.context() as patch:
        patch.setattr(os, "replace", _disk_full)
        bench.replay(f"{HEARTBEAT_200}\n{HARDWARE_ERROR}")
        assert bench.twin.objects["producer_heartbeat_time"] == 0
        # the retry is tried again, not acknowledged as "unchanged"
        bench.replay(f"{HEARTBEAT_200}\n{HARDWARE_ERROR}")
        assert bench.twin.objects["producer_heartbeat_time"] == 0
    assert path.read_text() == stored
    assert _stray_files(tmp_path, "keypad.json") == []
    bench.replay(f"{HEARTBEAT_200}\n< 595 60 17 10 00 00 00 00 00")
    bench.twin.close()
    again = KeypadTwin(nvm=path)  # a power cycle in another process keeps it
    assert again.objects["producer_heartbeat_time"] == 200


def test_restore_defaults_the_nvm_cannot_take_aborts_and_changes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bench = Bench(KeyboxTwin(nvm=tmp_path / "keybox.json"))
    bench.replay("""
        on
        < 70C 00
        > 60C 2B 17 10 00 64 00 00 00
        < 58C 60 17 10 00 00 00 00 00
    """)
    monkeypatch.setattr(os, "replace", _disk_full)
    bench.replay("""
        > 60C 23 11 10 01 6C 6F 61 64
        < 58C 80 11 10 01 00 00 06 06
    """)
    assert bench.twin.objects["producer_heartbeat_time"] == 100


def test_a_file_corrupted_while_running_is_refused_at_reset_and_kept(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    bench = Bench(KeypadTwin(nvm=path))
    bench.replay(f"on\n< 715 00\n{HEARTBEAT_200}\n< 595 60 17 10 00 00 00 00 00")
    good = path.read_text()
    path.write_text("{garbage")
    bench.replay("> 000 81 15\n< 715 00")  # boots with the settings it last stored
    assert bench.twin.objects["producer_heartbeat_time"] == 200
    assert str(path) in bench.twin.snapshot()["nvm_error"]
    bench.replay("> 615 2B 17 10 00 64 00 00 00\n< 595 80 17 10 00 00 00 06 06")
    assert path.read_text() == "{garbage"
    path.write_text(good)  # repaired: the next reset reads it again
    bench.replay("> 000 81 15\n< 715 00\n> 615 2B 17 10 00 64 00 00 00\n"
                 "< 595 60 17 10 00 00 00 00 00")
    assert "nvm_error" not in bench.twin.snapshot()
    assert json.loads(path.read_text())["settings"]["producer_heartbeat_time"] == 100


def test_a_file_changed_by_someone_else_is_not_replaced(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    bench = Bench(KeypadTwin(nvm=path))
    bench.replay("on\n< 715 00")
    document = json.loads(path.read_text())
    document["settings"]["producer_heartbeat_time"] = 500
    edited = json.dumps(document)
    path.write_text(edited)
    bench.replay(f"{HEARTBEAT_200}\n{HARDWARE_ERROR}")
    assert path.read_text() == edited
    bench.replay("> 000 81 15\n< 715 00")  # a reset loads the edit
    assert bench.twin.objects["producer_heartbeat_time"] == 500


def test_a_second_twin_on_one_file_is_refused_until_the_first_closes(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    first = KeypadTwin(nvm=path)
    with pytest.raises(NvmError, match=f"{path} is in use by another twin"):
        KeypadTwin(nvm=path)
    first.close()
    KeypadTwin(nvm=path).close()


def _child(script: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(script)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)


def test_a_second_process_on_one_file_is_refused_naming_the_holder(tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    child = _child(f"""
        import sys
        from blinkcan.twin import KeypadTwin
        twin = KeypadTwin(nvm={str(path)!r})
        print("ready", flush=True)
        sys.stdin.read()
    """)
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "ready"
        with pytest.raises(NvmError, match=rf"{path} is in use .*process {child.pid}\)"):
            KeypadTwin(nvm=path)
    finally:
        child.communicate("")
    KeypadTwin(nvm=path).close()  # the kernel dropped the lock with the process


def test_a_writer_killed_mid_write_leaves_the_file_whole_and_nothing_behind(
        tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    child = _child(f"""
        import os, signal
        from blinkcan.protocol import Frame
        from blinkcan.twin import KeypadTwin
        twin = KeypadTwin(nvm={str(path)!r})
        twin.power_on(0.0)
        os.fsync = lambda fd: os.kill(os.getpid(), signal.SIGKILL)
        twin.receive(Frame(0x615, bytes.fromhex("2B171000C8000000")), 0.0)
    """)
    child.communicate("")
    assert child.returncode == -signal.SIGKILL
    twin = KeypadTwin(nvm=path)  # the file as it was before the killed write
    assert twin.objects["producer_heartbeat_time"] == 0
    twin.power_on(0.0)
    assert twin.receive(frame("615 2B 17 10 00 C8 00 00 00"), 0.0) == [
        frame("595 60 17 10 00 00 00 00 00")]
    assert _stray_files(tmp_path, "keypad.json") == []


def test_a_refused_value_never_reaches_the_file(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    bench = Bench(KeyboxTwin(nvm=tmp_path / "keybox.json"))
    bench.replay("on\n< 70C 00")
    writes: list[tuple[str, str]] = []
    real_replace = os.replace

    def counted(source: str, target: str) -> None:
        writes.append((source, target))
        real_replace(source, target)

    monkeypatch.setattr(os, "replace", counted)
    bench.replay("""
        > 60C 23 16 10 01 F4 01 00 01
        < 58C 80 16 10 01 30 00 09 06
    """)  # a reserved byte set: 0609 0030h (errata K8), and no NVM write at all
    assert writes == []


def test_a_directory_or_a_missing_directory_is_refused_naming_it(tmp_path: Path) -> None:
    with pytest.raises(NvmError, match="is a directory"):
        KeypadTwin(nvm=tmp_path)
    with pytest.raises(NvmError, match=r"directory .*nodir does not exist"):
        KeypadTwin(nvm=tmp_path / "nodir" / "x.json")
    assert not (tmp_path / "nodir").exists()
