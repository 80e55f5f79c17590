"""Non-volatile settings in a file (``blinkcan.formats.nvm_file``): nothing acknowledged is lost,
nothing found is replaced, one twin at a time, nothing left behind by a killed writer. A twin
is given the file as a path (the public constructors) or as the store's opener (the CLI)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from blinkcan.formats.nvm_file import JsonFileNvm, nvm_file
from blinkcan.twin import KeyboxTwin, KeypadTwin, MemoryNvm, NvmError
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


# -- issue 18 item 4: a link is the file it names -------------------------------------------

def _emulate_child(nvm: Path) -> subprocess.Popen[str]:
    """``blinkcan emulate keybox --nvm NVM`` on a bus of its own (virtual: nothing crosses)."""
    return subprocess.Popen(
        [sys.executable, "-m", "blinkcan", "emulate", "keybox", "-q", "--nvm", str(nvm),
         "-i", "virtual", "-c", f"nvm-{os.getpid()}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "COLUMNS": "300"})


def _emulate_refused(nvm: Path) -> str:
    """The one line a second ``blinkcan emulate --nvm NVM`` prints when it is refused."""
    second = _emulate_child(nvm)
    try:
        output, _ = second.communicate(timeout=60)
    finally:
        if second.poll() is None:
            second.kill()
            second.communicate()
    assert second.returncode == 1, output
    return output


@pytest.mark.parametrize("link", ["symbolic", "hard"])
def test_a_second_emulator_on_a_link_to_a_file_in_use_is_refused(tmp_path: Path,
                                                                  link: str) -> None:
    real, alias = tmp_path / "real.json", tmp_path / "link.json"
    first = _emulate_child(real)
    try:
        assert first.stdout is not None
        assert "emulating" in first.stdout.readline()  # started: it holds real.json
        if link == "symbolic":
            alias.symlink_to(real.name)
        else:
            os.link(real, alias)
        output = _emulate_refused(alias)
    finally:
        first.terminate()
        first.communicate(timeout=30)
    lines = output.strip().splitlines()
    assert len(lines) == 1, output
    assert lines[0].startswith("Error: "), output
    assert str(alias) in output
    if link == "symbolic":
        assert f"is in use by another twin (process {first.pid})" in output
    else:
        assert "hard link" in output


def test_a_twin_on_a_symlink_writes_through_to_its_target(tmp_path: Path) -> None:
    real, alias = tmp_path / "real.json", tmp_path / "link.json"
    alias.symlink_to(real.name)  # dangling until the first write: the target is created
    first = KeyboxTwin(nvm=real)
    with pytest.raises(NvmError, match=rf"{alias} .*is in use by another twin"):
        KeyboxTwin(nvm=alias)
    first.close()
    bench = Bench(KeyboxTwin(nvm=alias))
    bench.replay("on\n< 70C 00\n> 60C 2B 17 10 00 DE 00 00 00\n< 58C 60 17 10 00 00 00 00 00")
    assert alias.is_symlink()
    assert os.readlink(alias) == real.name
    assert json.loads(real.read_text())["settings"]["producer_heartbeat_time"] == 0xDE
    assert _stray_files(tmp_path, "real.json") == ["link.json"]
    with pytest.raises(NvmError, match="is in use by another twin"):
        KeyboxTwin(nvm=real)
    bench.twin.close()
    assert KeyboxTwin(nvm=real).objects["producer_heartbeat_time"] == 0xDE


def test_a_symlinked_file_keeps_its_permissions(tmp_path: Path) -> None:
    real, alias = tmp_path / "real.json", tmp_path / "link.json"
    KeyboxTwin(nvm=real).close()
    real.chmod(0o600)
    alias.symlink_to(real)
    bench = Bench(KeyboxTwin(nvm=alias))
    bench.replay("on\n< 70C 00\n> 60C 2B 17 10 00 DE 00 00 00\n< 58C 60 17 10 00 00 00 00 00")
    assert real.stat().st_mode & 0o777 == 0o600


def test_a_hard_linked_file_is_refused_and_never_split(tmp_path: Path) -> None:
    real, alias = tmp_path / "real.json", tmp_path / "link.json"
    bench = Bench(KeyboxTwin(nvm=real))
    bench.replay("on\n< 70C 00")
    os.link(real, alias)  # linked while in use: the next write would split the two names
    stored = real.read_text()
    bench.replay("> 60C 2B 17 10 00 DE 00 00 00\n< 58C 80 17 10 00 00 00 06 06")
    assert real.read_text() == stored
    assert os.path.samefile(real, alias)
    bench.twin.close()
    for name in (real, alias):
        with pytest.raises(NvmError, match=rf"{name} has 2 names \(hard links\)"):
            KeyboxTwin(nvm=name)


# -- issue 18 item 5: a lock file that cannot be written ----------------------------------

def test_a_full_disk_at_open_is_an_nvm_error_naming_the_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "keypad.json"
    monkeypatch.setattr(os, "write", _disk_full)
    with pytest.raises(NvmError, match=rf"{path}.*No space left on device"):
        KeypadTwin(nvm=path)
    monkeypatch.undo()
    KeypadTwin(nvm=path).close()  # the failed opener let go of the lock


def test_a_file_size_limit_at_open_is_one_line_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "keybox.json"
    limited = ("import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0)); "
               "from blinkcan.cli.main import main; sys.argv[0] = 'blinkcan'; main()")
    result = subprocess.run(
        [sys.executable, "-c", limited, "emulate", "keybox", "--nvm", str(path),
         "-i", "virtual", "-c", f"nvm-{os.getpid()}"],
        capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 1, result
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"Error: cannot use NVM file {path}"), lines
    assert "File too large" in lines[0]


def test_a_twin_given_the_file_stores_opener_keeps_its_settings_in_the_file(
        tmp_path: Path) -> None:
    path = tmp_path / "keypad.json"
    bench = Bench(KeypadTwin(nvm=nvm_file(path), protocol="j1939"))  # J1939 ones beside
    with pytest.raises(NvmError, match="in use by another twin"):  # the opener took the lock
        KeypadTwin(nvm=path)
    bench.twin.close()
    stored = json.loads(path.read_text())
    assert stored["model"] == "pkp-2600-si"
    assert stored["settings"]["can_protocol"] == 1
    assert any(name.startswith("j1939_") for name in stored["settings"])
    KeypadTwin(nvm=nvm_file(path)).close()  # and reads it back


def test_a_twin_takes_any_store_as_it_is() -> None:
    store = MemoryNvm()
    KeyboxTwin(nvm=store).close()
    again = KeyboxTwin(nvm=store)
    assert again.stored_settings() == store.load()


def test_a_twin_given_neither_a_store_nor_a_path_is_a_type_error() -> None:
    with pytest.raises(TypeError):
        KeypadTwin(nvm=15)  # type: ignore[arg-type]


def test_the_file_store_keeps_its_old_name_in_the_twin_package() -> None:
    import blinkcan.twin

    assert blinkcan.twin.JsonFileNvm is JsonFileNvm


def test_a_twin_without_a_file_loads_no_file_store() -> None:
    code = ("import sys\nfrom blinkcan.twin import KeyboxTwin, KeypadTwin, MemoryNvm\n"
            "KeypadTwin().power_on(0.0); KeyboxTwin(nvm=MemoryNvm()).power_on(0.0)\n"
            "assert 'blinkcan.formats.nvm_file' not in sys.modules\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("text", ["[" * 100_000, '{"format": ' + "[" * 100_000],
                         ids=["deep", "deep-inside"])
def test_a_deeply_nested_file_is_an_nvm_error_and_kept(tmp_path: Path, text: str) -> None:
    """A hostile file nested 100,000 deep raised RecursionError (the CLI: 'unexpected
    RecursionError'), not the NvmError of a corrupt file (found by the attack pass)."""
    path = tmp_path / "keypad.json"
    path.write_text(text)
    with pytest.raises(NvmError, match=str(path)):
        KeypadTwin(nvm=path)
    assert path.read_text() == text


def test_a_file_far_larger_than_any_settings_is_refused_unread(tmp_path: Path) -> None:
    """A huge file was read whole into memory before it was found to be no NVM file."""
    path = tmp_path / "keypad.json"
    path.write_text(" " * (2 << 20) + "{}")
    with pytest.raises(NvmError, match=r"keypad\.json .*MiB"):
        KeypadTwin(nvm=path)
    assert path.stat().st_size == (2 << 20) + 2
