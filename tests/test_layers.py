"""The layer contract of DESIGN.md, checked on the source: which layer may import which.

``cli -> web · fleet -> testing -> host · twin · decode · formats -> devices · runtime ->
protocol``, plus the explicit rules: ``protocol/``, ``devices/`` and ``twin/`` import none of
``can``, ``threading``, ``asyncio``, ``time``; ``host/``, ``decode/``, ``formats/`` and
``fleet/`` never import ``twin/``; the pure core imports without python-can and does no file
I/O (no ``open()``, no ``os``/``fcntl``/``pathlib``...: the NVM file store is
``formats/nvm_file.py``). Every import counts, also the ones inside a function. A new
subpackage must be placed in ``ALLOWED`` before it can land.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import blinkcan

PACKAGE = Path(blinkcan.__file__).parent
PURE = frozenset({"protocol", "devices", "twin"})
FORBIDDEN_IN_PURE = frozenset({"can", "threading", "asyncio", "time"})
_BELOW_DRIVERS = frozenset({"protocol", "devices", "runtime"})
#: layer -> the blinkcan layers its modules may import (its own included)
ALLOWED: dict[str, frozenset[str]] = {
    "protocol": frozenset({"protocol"}),
    "devices": frozenset({"protocol", "devices"}),
    "twin": frozenset({"protocol", "devices", "twin"}),
    # runtime/ drives twins on a bus (DESIGN.md: "Emulator drives twins on a bus")
    "runtime": frozenset({"protocol", "devices", "twin", "runtime"}),
    "host": _BELOW_DRIVERS | {"host"},
    "decode": frozenset({"protocol", "devices", "decode"}),
    "formats": _BELOW_DRIVERS | {"formats"},
    # fleet/ decodes logs into a dataset: the decoder, the log formats, the descriptions
    "fleet": _BELOW_DRIVERS | {"decode", "formats", "fleet"},
    "testing": _BELOW_DRIVERS | {"twin", "host", "decode", "formats", "testing"},
    "web": _BELOW_DRIVERS | {"twin", "host", "decode", "formats", "testing", "web"},
    "cli": _BELOW_DRIVERS | {"twin", "host", "decode", "formats", "testing", "web", "fleet",
                             "cli"},
    "__main__": frozenset({"cli"}),
    "__init__": frozenset({"protocol", "host", "errors"}),  # lazily, on first use (PEP 562)
    "errors": frozenset(),
}
# blinkcan.errors (the one root of blinkcan's errors) imports nothing: every layer may use it
ALLOWED = {layer: allowed | {"errors"} for layer, allowed in ALLOWED.items()}
#: imports a layer may make of one module above it, only inside a function (so the layer
#: imports and runs without it): a path given to a twin constructor (``KeypadTwin(nvm=PATH)``,
#: as the contract of DESIGN.md has it) is handed to the file store (``twin/nvm.py``), and
#: ``blinkcan.twin.JsonFileNvm`` still names it for earlier callers
LAZY: dict[str, frozenset[str]] = {"twin": frozenset({"blinkcan.formats.nvm_file"})}
#: modules that work on files or file descriptors: none is imported by the pure core
FILE_IO = frozenset({"os", "io", "fcntl", "msvcrt", "pathlib", "glob", "shutil", "tempfile",
                     "mmap", "fileinput", "sqlite3", "stat"})


def _layer(path: Path) -> str:
    relative = path.relative_to(PACKAGE)
    return relative.parts[0] if len(relative.parts) > 1 else relative.stem


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in the file."""
    found: list[tuple[int, str]] = []
    package = ".".join(("blinkcan", *path.relative_to(PACKAGE).parent.parts))
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the file's package
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                found.append((node.lineno, f"{base}.{node.module}" if node.module else base))
            elif node.module:
                found.append((node.lineno, node.module))
    return found


def _in_functions(tree: ast.AST) -> set[int]:
    """Lines of the imports made inside a function body."""
    return {node.lineno for function in ast.walk(tree)
            if isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef))
            for node in ast.walk(function) if isinstance(node, (ast.Import, ast.ImportFrom))}


def _type_checking_only(tree: ast.AST) -> set[int]:
    """Lines of the imports under ``if TYPE_CHECKING:`` (types for mypy; they never run)."""
    return {node.lineno for block in ast.walk(tree)
            if isinstance(block, ast.If) and getattr(block.test, "id", getattr(
                block.test, "attr", None)) == "TYPE_CHECKING"
            for statement in block.body for node in ast.walk(statement)
            if isinstance(node, (ast.Import, ast.ImportFrom))}


def file_io(tree: ast.AST) -> list[str]:
    """The file I/O of a module: imports of :data:`FILE_IO` modules that run, and calls of the
    built-in ``open``."""
    typing_only = _type_checking_only(tree)
    found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)) and node.lineno not in typing_only:
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [] if node.level or not node.module else [node.module])
            found.extend(f"line {node.lineno}: imports {name}" for name in names
                         if name.split(".")[0] in FILE_IO)
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "open":
            found.append(f"line {node.lineno}: open()")
    return found


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_every_subpackage_has_a_place_in_the_layers() -> None:
    unplaced = {_layer(path) for path in _sources()} - set(ALLOWED)
    assert not unplaced, f"place {sorted(unplaced)} in tests/test_layers.py ALLOWED"


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_follow_the_layers(path: Path) -> None:
    layer = _layer(path)
    allowed = ALLOWED.get(layer, frozenset())
    wrong = []
    lazy = _in_functions(ast.parse(path.read_text(), str(path)))
    for line, module in _imports(path):
        parts = module.split(".")
        if module in LAZY.get(layer, ()) and line in lazy:
            continue
        if parts[0] == "blinkcan" and len(parts) > 1 and parts[1] not in allowed:
            wrong.append(f"line {line}: {module} ({layer}/ may import {sorted(allowed)})")
        if layer in PURE and parts[0] in FORBIDDEN_IN_PURE:
            wrong.append(f"line {line}: {module} (the pure core does no I/O)")
    assert not wrong, "\n".join(wrong)


def test_the_pure_core_does_no_file_io() -> None:
    found = [f"{path.relative_to(PACKAGE)} {use}" for path in _sources()
             if _layer(path) in PURE for use in file_io(ast.parse(path.read_text(), str(path)))]
    assert found == []


def test_the_file_io_count_sees_what_it_counts() -> None:
    tree = ast.parse("import os\nfrom pathlib import Path\nimport fcntl as f\n"
                     "def g():\n    import tempfile\n    return open('x')\n"
                     "if TYPE_CHECKING:\n    from os import PathLike\nimport json\n")
    assert file_io(tree) == ["line 1: imports os", "line 2: imports pathlib",
                             "line 3: imports fcntl", "line 5: imports tempfile",
                             "line 6: open()"]


def test_only_a_function_makes_a_lazy_import() -> None:
    tree = ast.parse("from blinkcan.formats.nvm_file import nvm_file\n"
                     "def f():\n    from blinkcan.formats.nvm_file import JsonFileNvm\n")
    assert _in_functions(tree) == {3}


@pytest.mark.parametrize("module", ["blinkcan.protocol", "blinkcan.devices", "blinkcan.twin",
                                    "blinkcan.decode", "blinkcan"])
def test_pure_modules_import_without_python_can(module: str) -> None:
    code = (f"import sys, {module}\n"
            "bad = sorted({'can', 'threading', 'asyncio'} & set(sys.modules) - ALREADY)\n"
            "assert not bad, bad\n")
    # threading/asyncio may already be loaded by the interpreter itself: measure before
    prelude = "import sys\nALREADY = set(sys.modules)\n"
    result = subprocess.run([sys.executable, "-c", prelude + code], capture_output=True,
                            text=True, check=False)
    assert result.returncode == 0, result.stderr


def test_the_drivers_load_on_first_use() -> None:
    code = ("import sys, blinkcan\nassert 'blinkcan.host' not in sys.modules\n"
            "from blinkcan import Keypad, Frame\nassert 'blinkcan.host' in sys.modules\n"
            "print(Keypad.__name__, Frame.__name__)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["Keypad", "Frame"]
