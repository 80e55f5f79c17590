"""What the fleet's modules import is what ``pip install 'blinkcan[fleet]'`` installs (issue 23:
the core's dependencies and the [fleet] extra): a package a module imports when it loads, found
in this environment only because something else (a test tool) brought it, would be an
ImportError on a user's machine."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from importlib.metadata import packages_distributions
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: what decode --parquet and blinkcan query load
ENTRY_MODULES = ("blinkcan.fleet.run", "blinkcan.fleet.query", "blinkcan.cli.parquet")


def _requirements(key: str) -> list[str]:
    """The requirements of a list in pyproject.toml (``dependencies = [...]``; Python 3.10
    has no tomllib)."""
    text = (ROOT / "pyproject.toml").read_text()
    block = re.search(rf"^{key} = \[(.*?)^\]", text, re.MULTILINE | re.DOTALL)
    assert block is not None, key
    return re.findall(r'^\s*"([^"]+)"', block.group(1), re.MULTILINE)


def _declared() -> set[str]:
    """The distributions the core and the [fleet] extra name (normalised)."""
    names = [*_requirements("dependencies"), *_requirements("fleet")]
    return {re.split(r"[\s<>=!~\[;]", name, maxsplit=1)[0].lower().replace("_", "-")
            for name in names}


def _loaded_blinkcan_modules() -> list[str]:
    probe = (f"import json, sys\nfor m in {ENTRY_MODULES!r}: __import__(m)\n"
             "print(json.dumps(sorted(n for n in sys.modules if n.startswith('blinkcan'))))")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)
    loaded: list[str] = json.loads(run.stdout)
    return loaded


def _imported_when_loaded(path: Path) -> set[str]:
    """The top-level packages a module imports as it loads (not under TYPE_CHECKING, not in
    functions: those load when used)."""
    found: set[str] = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
    return found


def test_every_package_the_fleet_imports_is_installed_by_the_extra() -> None:
    distributions = packages_distributions()
    declared = _declared()
    undeclared: dict[str, set[str]] = {}
    for module in _loaded_blinkcan_modules():
        spec_path = ROOT / "src" / Path(*module.split("."))
        path = spec_path / "__init__.py" if spec_path.is_dir() else spec_path.with_suffix(".py")
        for package in _imported_when_loaded(path):
            if package in sys.stdlib_module_names or package in ("blinkcan", "__future__"):
                continue
            owners = {d.lower().replace("_", "-") for d in distributions.get(package, [package])}
            if not owners & declared:
                undeclared.setdefault(package, set()).add(module)
    assert not undeclared, f"imported but not in the core or [fleet]: {undeclared}"
