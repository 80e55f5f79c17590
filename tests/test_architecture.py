"""Architecture counts of DESIGN.md "Extension points" (issue 19), measured on the source.

(a) Private state used across modules: an attribute access ``X._name`` (or a method defined
    under that name) in one module, where ``_name`` belongs to a class of another blinkcan
    module: a subclass using or overriding its base's private attribute, or ``other._name``
    on an object whose class lives elsewhere. Twins extend through public hooks instead.
(b) Import cycles between blinkcan modules, counting every import: at the top, inside a
    function, under ``if TYPE_CHECKING:``, and ``import_module("...")`` with a literal name.
(c) Behaviour switched on a model outside ``devices/``: a comparison with a registered kind
    string (``kind == "keypad"``, ``device in ("keypad", "keybox")``), and a key or pin count
    written as a number (``range(1, 13)``, ``check_range("key", key, 1, 12)``,
    ``1 <= key <= 12``) where it is one of a registered face's counts. Every such place reads
    the model's description (its face, features, commands) instead.

(d) ``isinstance(..., SimulatedBus)`` outside the simulated port (``runtime/simport.py``): the
    transport is a Port (``runtime/port.py``); HostBus and the Emulator never ask which.

(a), (c) and (d) are 0 for the whole package (a driver class builds on ``host.device.Device``
through its public face: ``listen``, ``on_close``, ``pdo_frame``, ``heard`` and the hooks it
overrides), (b) for ``twin/``, ``runtime/`` and ``host/``. ``python -m
tests.test_architecture`` prints them for the package.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import blinkcan
from blinkcan.devices.registry import default_descriptions, models

PACKAGE = Path(blinkcan.__file__).parent


def _module_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    relative = Path(*name.split("."))
    return ((PACKAGE.parent / relative).with_suffix(".py").is_file()
            or (PACKAGE.parent / relative / "__init__.py").is_file())


@dataclass
class _Source:
    module: str
    path: Path
    tree: ast.Module
    is_package: bool

    def resolve(self, node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        package = self.module if self.is_package else self.module.rpartition(".")[0]
        for _ in range(node.level - 1):
            package = package.rpartition(".")[0]
        return f"{package}.{node.module}" if node.module else package


def _sources() -> dict[str, _Source]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module_of(path)
        found[module] = _Source(module, path, ast.parse(path.read_text(), str(path)),
                                path.name == "__init__.py")
    return found


# -- (b) import cycles --------------------------------------------------------------------------

def _imported_modules(source: _Source) -> set[str]:
    """Every blinkcan module ``source`` imports, wherever the import is."""
    targets: set[str] = set()
    for node in ast.walk(source.tree):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = source.resolve(node)
            for alias in node.names:
                child = f"{base}.{alias.name}"
                targets.add(child if _is_module(child) else base)
        elif (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(
                node.func, "attr", None)) == "import_module" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            targets.add(node.args[0].value)
    return {t for t in targets if t.startswith("blinkcan") and _is_module(t)} - {source.module}


def import_cycles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    sources = _sources()
    graph = {module: sorted(_imported_modules(source)) for module, source in sources.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for target in graph.get(module, ()):
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in on_stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == module:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in graph:
        if module not in index:
            visit(module)
    return sorted(cycles)


# -- (a) private state across modules -------------------------------------------------------------

def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


@dataclass
class _Class:
    module: str
    name: str
    bases: list[tuple[str, str]]  # (module, class) of blinkcan bases
    private: set[str] = field(default_factory=set)


def _defined_private(node: ast.ClassDef) -> set[str]:
    names: set[str] = set()
    for item in node.body:
        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) and _private(item.name):
            names.add(item.name)
        elif isinstance(item, (ast.Assign, ast.AnnAssign)):
            targets = item.targets if isinstance(item, ast.Assign) else [item.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name) and _private(t.id))
    for sub in ast.walk(node):
        if (isinstance(sub, ast.Attribute) and isinstance(sub.ctx, ast.Store)
                and isinstance(sub.value, ast.Name) and sub.value.id == "self"
                and _private(sub.attr)):
            names.add(sub.attr)
    return names


def _names_in_scope(source: _Source) -> dict[str, tuple[str, str]]:
    """Names of ``source`` that are classes: local ones and ``from M import C`` ones."""
    scope = {node.name: (source.module, node.name) for node in source.tree.body
             if isinstance(node, ast.ClassDef)}
    for found in ast.walk(source.tree):
        if isinstance(found, ast.ImportFrom):
            base = source.resolve(found)
            for alias in found.names:
                scope.setdefault(alias.asname or alias.name, (base, alias.name))
    return scope


def _classes(sources: dict[str, _Source]) -> dict[tuple[str, str], _Class]:
    classes = {}
    for source in sources.values():
        scope = _names_in_scope(source)
        for node in source.tree.body:
            if isinstance(node, ast.ClassDef):
                bases = [scope[b.id] for b in node.bases
                         if isinstance(b, ast.Name) and b.id in scope]
                classes[source.module, node.name] = _Class(source.module, node.name, bases,
                                                           _defined_private(node))
    # a re-exported class (blinkcan.twin.KeypadTwin) resolves to where it is defined
    for source in sources.values():
        for alias_name, (module, name) in _names_in_scope(source).items():
            if (module, name) in classes and (source.module, alias_name) not in classes:
                classes.setdefault((source.module, alias_name), classes[module, name])
    return classes


def _ancestors(cls: _Class, classes: dict[tuple[str, str], _Class]) -> Iterator[_Class]:
    seen: set[tuple[str, str]] = set()
    pending = list(cls.bases)
    while pending:
        key = pending.pop()
        base = classes.get(key)
        if base is None or (base.module, base.name) in seen:
            continue
        seen.add((base.module, base.name))
        yield base
        pending.extend(base.bases)


@dataclass(frozen=True)
class PrivateUse:
    module: str
    line: int
    name: str
    owner: str  # the module whose class defines the name

    def __str__(self) -> str:
        return f"{self.module}:{self.line} uses {self.name} of {self.owner}"


def private_uses() -> list[PrivateUse]:
    sources = _sources()
    classes = _classes(sources)
    defined_in: dict[str, set[str]] = {}
    for cls in classes.values():
        for name in cls.private:
            defined_in.setdefault(name, set()).add(cls.module)
    found: set[PrivateUse] = set()
    for source in sources.values():
        own = {name for (module, _), cls in classes.items() if module == source.module
               and cls.module == source.module for name in cls.private}
        for node in source.tree.body:
            if not isinstance(node, ast.ClassDef):
                continue
            cls = classes[source.module, node.name]
            inherited = {name: base.module for base in _ancestors(cls, classes)
                         if base.module != source.module for name in base.private}
            for sub in ast.walk(node):
                if isinstance(sub, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                        and sub.name in inherited:
                    found.add(PrivateUse(source.module, sub.lineno, sub.name,
                                         inherited[sub.name]))
                if not (isinstance(sub, ast.Attribute) and _private(sub.attr)):
                    continue
                on_self = ((isinstance(sub.value, ast.Name) and sub.value.id in ("self", "cls"))
                           or (isinstance(sub.value, ast.Call)
                               and getattr(sub.value.func, "id", None) == "super"))
                if on_self and sub.attr in inherited:
                    found.add(PrivateUse(source.module, sub.lineno, sub.attr,
                                         inherited[sub.attr]))
        for sub in ast.walk(source.tree):
            if not (isinstance(sub, ast.Attribute) and _private(sub.attr)):
                continue
            if isinstance(sub.value, ast.Name) and sub.value.id in ("self", "cls"):
                continue
            if isinstance(sub.value, ast.Call) and getattr(sub.value.func, "id", None) == "super":
                continue
            owners = defined_in.get(sub.attr, set()) - {source.module}
            if owners and sub.attr not in own:
                found.add(PrivateUse(source.module, sub.lineno, sub.attr, min(owners)))
    return sorted(found, key=lambda use: (use.module, use.line, use.name))


def _private_imports_in(source: _Source) -> list[PrivateUse]:
    """``from blinkcan.x import _name`` in another module: a module-level private name
    (a class, function or constant) reached into from outside its module."""
    return [PrivateUse(source.module, node.lineno, alias.name, source.resolve(node))
            for node in ast.walk(source.tree) if isinstance(node, ast.ImportFrom)
            and source.resolve(node).startswith("blinkcan")
            for alias in node.names if _private(alias.name)]


def private_imports() -> list[PrivateUse]:
    return [use for source in _sources().values() for use in _private_imports_in(source)]


# -- (c) kind strings and counts outside devices/ ----------------------------------------------

def _kinds() -> frozenset[str]:
    return frozenset(model.kind for model in models())


def _counts() -> frozenset[int]:
    """Every registered face's key and pin count, and one more (a ``range`` stop)."""
    faces = [description.face for description in default_descriptions()]
    counts = {count for face in faces for count in (face.keys, face.pins) if count}
    return frozenset(counts | {count + 1 for count in counts})


def _literal(node: ast.expr) -> object:
    return node.value if isinstance(node, ast.Constant) else None


@dataclass(frozen=True)
class ModelSwitch:
    module: str
    line: int
    what: str

    def __str__(self) -> str:
        return f"{self.module}:{self.line} {self.what}"


def _switches_in(tree: ast.AST, module: str, kinds: frozenset[str],
                 counts: frozenset[int]) -> list[ModelSwitch]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            strings = {_literal(element) for operand in operands for element in (
                operand.elts if isinstance(operand, (ast.Tuple, ast.List, ast.Set))
                else [operand])}
            if strings & kinds:
                found.append(ModelSwitch(module, node.lineno, "compares a kind string"))
            numbers = [_literal(operand) for operand in operands]
            if (len(numbers) == 3 and numbers[0] in (0, 1) and numbers[2] in counts
                    and not isinstance(numbers[2], bool)):
                found.append(ModelSwitch(module, node.lineno, f"bounds by {numbers[2]}"))
        elif isinstance(node, ast.Call):
            name = getattr(node.func, "id", getattr(node.func, "attr", None))
            arguments = [_literal(argument) for argument in node.args]
            if (name == "range" and len(arguments) >= 2 and arguments[0] in (0, 1)
                    and arguments[1] in counts) or (
                    name == "check_range" and len(arguments) == 4 and arguments[2] in (0, 1)
                    and arguments[3] in counts):
                found.append(ModelSwitch(module, node.lineno, f"counts to {arguments[-1]}"))
    return found


def model_switches() -> list[ModelSwitch]:
    kinds, counts = _kinds(), _counts()
    return [switch for module, source in _sources().items()
            if not module.startswith("blinkcan.devices")
            for switch in _switches_in(source.tree, module, kinds, counts)]


# -- (d) asking whether a bus is the simulated one ------------------------------------------------

SIMULATED_PORT = "blinkcan.runtime.simport"


def _simulated_bus_checks_in(tree: ast.AST, module: str) -> list[ModelSwitch]:
    found = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance"
                and len(node.args) == 2):
            kinds = node.args[1]
            names = kinds.elts if isinstance(kinds, ast.Tuple) else [kinds]
            if any(getattr(name, "id", getattr(name, "attr", None)) == "SimulatedBus"
                   for name in names):
                found.append(ModelSwitch(module, node.lineno, "asks for a SimulatedBus"))
    return found


def simulated_bus_checks() -> list[ModelSwitch]:
    return [check for module, source in _sources().items() if module != SIMULATED_PORT
            for check in _simulated_bus_checks_in(source.tree, module)]


# -- the assertions -------------------------------------------------------------------------------

def _in_twin(module: str) -> bool:
    return module.startswith("blinkcan.twin.") or module == "blinkcan.twin"


def test_no_twin_module_uses_another_modules_private_state() -> None:
    uses = [str(use) for use in private_uses() if _in_twin(use.module)]
    assert uses == []


def test_no_module_uses_another_modules_private_state() -> None:
    # host/ was the last: its drivers build on Device, Keypad on public, documented APIs
    assert [str(use) for use in private_uses()] == []


def test_no_module_imports_another_modules_private_name() -> None:
    assert [str(use) for use in private_imports()] == []


def test_the_private_import_count_sees_what_it_counts() -> None:
    source = _Source("blinkcan.host.pkp3500", PACKAGE / "host" / "pkp3500.py", ast.parse(
        "from blinkcan.host.aio import _AsyncDevice, AsyncDriver\n"
        "from .events import _Queue\nfrom os import _exit\n"), False)
    assert [(use.name, use.owner) for use in _private_imports_in(source)] == [
        ("_AsyncDevice", "blinkcan.host.aio"), ("_Queue", "blinkcan.host.events")]


def test_no_import_cycle_touches_twin() -> None:
    cycles = [cycle for cycle in import_cycles() if any(map(_in_twin, cycle))]
    assert cycles == []


def _in_transport(module: str) -> bool:
    return module.startswith(("blinkcan.runtime.", "blinkcan.host.")) or module in (
        "blinkcan.runtime", "blinkcan.host")


def test_no_import_cycle_touches_runtime_or_host() -> None:
    cycles = [cycle for cycle in import_cycles() if any(map(_in_transport, cycle))]
    assert cycles == []


def test_only_the_simulated_port_asks_for_a_simulated_bus() -> None:
    assert [str(check) for check in simulated_bus_checks()] == []


def test_the_simulated_bus_count_sees_what_it_counts() -> None:
    tree = ast.parse("if isinstance(bus, SimulatedBus): pass\n"
                     "x = isinstance(bus, (can.BusABC, simbus.SimulatedBus))\n"
                     "y = isinstance(bus, can.BusABC)\n")
    assert [check.line for check in _simulated_bus_checks_in(tree, "m")] == [1, 2]


def test_the_counts_see_what_they_count() -> None:
    # a subclass reading its base's private attribute, and a cycle through TYPE_CHECKING
    # and import_module, are found (so the zero above is not a blind spot)
    tree = ast.parse("class A(B):\n    def f(self):\n        return self._x\n")
    base = _Class("m1", "B", [], {"_x"})
    sub = _Class("m2", "A", [("m1", "B")], set())
    assert [b.name for b in _ancestors(sub, {("m1", "B"): base, ("m2", "A"): sub})] == ["B"]
    assert any(isinstance(n, ast.Attribute) and n.attr == "_x" for n in ast.walk(tree))
    cyclic = _Source("blinkcan.twin.registry", PACKAGE / "twin" / "registry.py", ast.parse(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from blinkcan.twin.keypad import KeypadTwin\n"
        "import_module('blinkcan.twin.pkp3500')\n"), False)
    assert _imported_modules(cyclic) == {"blinkcan.twin.keypad", "blinkcan.twin.pkp3500"}


def test_no_kind_string_or_count_switches_behaviour_outside_devices() -> None:
    assert [str(switch) for switch in model_switches()] == []


def test_the_model_switch_count_sees_what_it_counts() -> None:
    tree = ast.parse("if kind == 'keypad': pass\nif d in ('keybox',): pass\n"
                     "for key in range(1, 13): pass\ncheck_range('key', key, 1, 12)\n"
                     "ok = 1 <= key <= 12\nfine = range(1, 8)\n")
    found = _switches_in(tree, "m", frozenset({"keypad", "keybox"}), frozenset({12, 13}))
    assert [switch.line for switch in found] == [1, 2, 3, 4, 5]


def report() -> str:
    """The counts for the whole package, one finding a line."""
    uses = private_uses() + private_imports()
    cycles = import_cycles()
    switches = model_switches()
    checks = simulated_bus_checks()
    return "\n".join([
        f"(a) private attributes or names of another module used: {len(uses)}",
        *(f"    {use}" for use in uses),
        f"(b) import cycles (strongly connected groups of modules): {len(cycles)}",
        *(f"    {' <-> '.join(cycle)}" for cycle in cycles),
        f"(c) kind strings and key/pin counts outside devices/: {len(switches)}",
        *(f"    {switch}" for switch in switches),
        f"(d) isinstance(..., SimulatedBus) outside {SIMULATED_PORT}: {len(checks)}",
        *(f"    {check}" for check in checks),
    ]) + "\n"


if __name__ == "__main__":
    import sys

    sys.stdout.write(report())
