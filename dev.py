#!/usr/bin/env python3
"""Set up a local virtual environment and run blinkcan's main jobs.

    python3 dev.py demo    # the demo: twins on a virtual CAN bus, driven by a host
    python3 dev.py test    # the whole test suite
    python3 dev.py lint    # ruff and mypy
    python3 dev.py bench   # the benchmarks (anchor beside ours); bench NAME... runs only those
                           # (NAME: a module of benchmarks/, e.g. sdo_twin; --smoke: a short run)

Needs only python3. The environment lives in .venv and is refreshed whenever pyproject.toml changes.
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
STAMP = VENV / ".blinkcan-installed"


def _venv_python() -> Path:
    return VENV / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _ensure_venv() -> Path:
    wanted = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    python = _venv_python()
    if python.exists() and STAMP.exists() and STAMP.read_text() == wanted:
        return python
    if not python.exists():
        print("dev.py: creating .venv", file=sys.stderr)
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
    print("dev.py: installing blinkcan and its test tools into .venv", file=sys.stderr)
    pip = [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    subprocess.run([*pip, "--upgrade", "pip"], check=True)
    subprocess.run([*pip, "-e", f"{ROOT}[dev]"], check=True)
    STAMP.write_text(wanted)
    return python


def _run(arguments: list[str]) -> int:
    """Run a tool to its end. Ctrl-C reaches the tool too (the terminal signals both): wait
    for it to stop on its own, passing the signal on only if it did not get one (a
    KeyboardInterrupt traceback here, or a killed demo, would hide the tool's own answer)."""
    child = subprocess.Popen(arguments, cwd=ROOT)
    while True:
        try:
            return child.wait()
        except KeyboardInterrupt:
            try:
                return child.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                child.send_signal(signal.SIGINT)
            except KeyboardInterrupt:
                child.send_signal(signal.SIGINT)


def main(argv: list[str]) -> int:
    if not argv or argv[0] not in {"demo", "test", "lint", "bench"}:
        print(__doc__, file=sys.stderr)
        return 2
    job, rest = argv[0], argv[1:]
    python = str(_ensure_venv())
    if job == "demo":
        return _run([python, "-m", "blinkcan", "demo", *rest])
    if job == "test":
        return _run([python, "-m", "pytest", *rest])
    if job == "lint":
        ruff = _run([python, "-m", "ruff", "check", "."])
        mypy = _run([python, "-m", "mypy"])
        return ruff or mypy
    return _run([python, "-m", "benchmarks", *rest])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
