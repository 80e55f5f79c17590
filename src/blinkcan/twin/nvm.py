"""Non-volatile memory of a twin: where its stored settings live across power cycles.

``None`` keeps them in the twin object; a path keeps them in a JSON file so they survive the
process too. The file is written atomically (temporary file, fsync, rename), and a file that is
corrupt or belongs to another model is refused with a clear error, never replaced.

This module is the pure core's one place of file I/O; it needs no clock and no bus.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Protocol

from blinkcan.devices.objects import ObjectTable, Ranges, Value

FORMAT = "blinkcan-nvm"
VERSION = 1


class NvmError(ValueError):
    """A non-volatile memory file that cannot be used."""


class Nvm(Protocol):
    def load(self) -> dict[str, Value] | None:
        """The stored settings, or None if nothing was ever stored."""
        ...

    def save(self, settings: dict[str, Value]) -> None: ...


class MemoryNvm:
    """Settings kept in memory: they survive ``power_off()`` but not the process."""

    def __init__(self) -> None:
        self._settings: dict[str, Value] | None = None

    def load(self) -> dict[str, Value] | None:
        return None if self._settings is None else dict(self._settings)

    def save(self, settings: dict[str, Value]) -> None:
        self._settings = dict(settings)


class JsonFileNvm:
    """Settings in a JSON file tagged with the model and generation that wrote it.
    ``others``: stored settings that are not objects of ``table`` (the keypad's J1939 ones)."""

    def __init__(self, path: str | os.PathLike[str], model: str, generation: str,
                 table: ObjectTable, others: Mapping[str, Ranges] | None = None) -> None:
        self.path = Path(path)
        self.model = model
        self.generation = generation
        self._table = table
        self._others = dict(others or {})

    def load(self) -> dict[str, Value] | None:
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return None
        except OSError as error:
            raise NvmError(f"cannot read NVM file {self.path}: {error.strerror}") from error
        try:
            document = json.loads(text)
        except json.JSONDecodeError as error:
            raise NvmError(f"NVM file {self.path} is not valid JSON ({error.msg}, line "
                           f"{error.lineno}); refusing to replace it") from error
        if not isinstance(document, dict) or document.get("format") != FORMAT:
            raise NvmError(f"{self.path} is not a blinkcan NVM file; refusing to replace it")
        if document.get("version") != VERSION:
            raise NvmError(f"{self.path} has NVM format version {document.get('version')!r}, "
                           f"this blinkcan reads version {VERSION}")
        model, generation = document.get("model"), document.get("generation")
        if (model, generation) != (self.model, self.generation):
            raise NvmError(f"{self.path} holds the settings of a {model} (generation "
                           f"{generation}), not of a {self.model} (generation "
                           f"{self.generation}); use another file")
        settings = document.get("settings")
        if not isinstance(settings, dict):
            raise NvmError(f"{self.path} has no settings object")
        return self._checked(settings)

    def _checked(self, settings: dict[str, object]) -> dict[str, Value]:
        checked: dict[str, Value] = {}
        for name, value in settings.items():
            if name in self._others:
                if not isinstance(value, int) or value not in self._others[name]:
                    raise NvmError(f"{self.path}: {name} = {value!r} is not valid "
                                   f"({self._others[name]})")
                checked[name] = value
                continue
            if name not in self._table or not self._table[name].stored:
                raise NvmError(f"{self.path}: {name!r} is not a stored setting of a {self.model}")
            entry = self._table[name]
            if not isinstance(value, (int, str)) or not entry.accepts(value):
                raise NvmError(f"{self.path}: {name} = {value!r} is not valid "
                               f"({entry.describe_valid()})")
            checked[name] = value
        return checked

    def save(self, settings: dict[str, Value]) -> None:
        document = {
            "format": FORMAT,
            "version": VERSION,
            "model": self.model,
            "generation": self.generation,
            "settings": dict(sorted(settings.items())),
        }
        text = json.dumps(document, indent=2) + "\n"
        directory = self.path.parent
        directory.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{self.path.name}.", dir=directory)
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                stream.write(text)
                stream.flush()
                os.fsync(stream.fileno())
            os.replace(temporary, self.path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
