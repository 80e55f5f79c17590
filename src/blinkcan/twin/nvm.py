"""Non-volatile memory of a twin: where its stored settings live across power cycles.

A twin takes an :class:`Nvm`: ``None`` is a :class:`MemoryNvm` (settings kept in the twin
object, across ``power_off()``), and a store that keeps them elsewhere is opened outside this
pure layer, which does no I/O: the JSON file store is ``blinkcan.formats.nvm_file``, which the
command line's ``emulate --nvm`` opens. A twin may also be given an *opener* (called with its
model's identity, so the store can refuse another model's settings) or, as it always could, a
path: :func:`open_nvm` hands the path to the file store, the one import this layer makes of
another (a convenience of the public constructors, kept for callers; it does no I/O here).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Protocol, TypeAlias, runtime_checkable

from blinkcan.devices.model import DeviceDescription
from blinkcan.devices.objects import ObjectTable, Ranges, Value
from blinkcan.errors import NvmError

if TYPE_CHECKING:  # a type only: this layer opens no file
    from os import PathLike

__all__ = ["MemoryNvm", "Nvm", "NvmArgument", "NvmError", "NvmOpener", "open_nvm"]


@runtime_checkable
class Nvm(Protocol):
    def load(self) -> dict[str, Value] | None:
        """The stored settings, or None if nothing was ever stored."""
        ...

    def save(self, settings: dict[str, Value]) -> None:
        """Store ``settings``; raises :class:`NvmError` when they could not be stored."""
        ...

    def close(self) -> None:
        """Let go of the memory (a file's lock); later use may fail."""
        ...


#: Opens a store for a model: (model, generation, its object table, the stored settings that
#: are not objects, with their valid values) -> the store; ``formats.nvm_file.nvm_file(path)``
NvmOpener: TypeAlias = Callable[[str, str, ObjectTable, Mapping[str, Ranges]], Nvm]
#: What a twin's ``nvm`` argument takes
NvmArgument: TypeAlias = "Nvm | NvmOpener | str | PathLike[str] | None"


class MemoryNvm:
    """Settings kept in memory: they survive ``power_off()`` but not the process."""

    def __init__(self) -> None:
        self._settings: dict[str, Value] | None = None

    def load(self) -> dict[str, Value] | None:
        return None if self._settings is None else dict(self._settings)

    def save(self, settings: dict[str, Value]) -> None:
        self._settings = dict(settings)

    def close(self) -> None:
        pass


def open_nvm(nvm: NvmArgument, description: DeviceDescription,
             others: Mapping[str, Ranges] | None = None) -> Nvm:
    """The store a twin of ``description`` keeps its settings in; ``others``: its stored
    settings that are not objects of its table (the keypad's J1939 ones). A file store fails
    here when another twin holds the file."""
    if nvm is None:
        return MemoryNvm()
    if isinstance(nvm, Nvm):
        return nvm
    if callable(nvm):
        return nvm(description.model, description.generation, description.table,
                   dict(others or {}))
    # a path: the file store, outside the pure layer (imported only when a path is given)
    from blinkcan.formats.nvm_file import nvm_file  # noqa: PLC0415

    return nvm_file(nvm)(description.model, description.generation, description.table, others)
