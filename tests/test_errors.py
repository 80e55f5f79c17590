"""One root for blinkcan's errors (issue 19): every exception class blinkcan defines derives
from ``blinkcan.BlinkcanError``, and those callers catch as built-ins keep that base too."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import blinkcan
from blinkcan import BlinkcanError


def _exception_classes() -> list[type[BaseException]]:
    found: dict[str, type[BaseException]] = {}
    for info in pkgutil.walk_packages(blinkcan.__path__, "blinkcan."):
        if info.name == "blinkcan.__main__":
            continue
        module = importlib.import_module(info.name)
        for _, value in inspect.getmembers(module, inspect.isclass):
            if issubclass(value, BaseException) and value.__module__.startswith("blinkcan"):
                found[f"{value.__module__}.{value.__qualname__}"] = value
    return [found[name] for name in sorted(found)]


CLASSES = _exception_classes()


def test_the_walk_finds_the_errors() -> None:
    names = {cls.__name__ for cls in CLASSES}
    assert {"SdoTimeoutError", "WrongDeviceError", "NvmError", "LogError"} <= names


@pytest.mark.parametrize("cls", CLASSES, ids=lambda cls: f"{cls.__module__}.{cls.__name__}")
def test_every_error_derives_from_blinkcan_error(cls: type[BaseException]) -> None:
    assert issubclass(cls, BlinkcanError)


@pytest.mark.parametrize(("name", "builtin"), [
    ("blinkcan.twin.nvm:NvmError", ValueError),
    ("blinkcan.formats.logs:LogError", ValueError),
    ("blinkcan.formats.pcap:PcapError", ValueError),
    ("blinkcan.web.guard:BodyError", ValueError),
    ("blinkcan.runtime.scheduler:StuckDeadlineError", RuntimeError),
])
def test_built_in_bases_are_kept(name: str, builtin: type[Exception]) -> None:
    module, _, attribute = name.partition(":")
    assert issubclass(getattr(importlib.import_module(module), attribute), builtin)


def test_blinkcan_error_is_exported_and_catches_an_sdo_timeout() -> None:
    from blinkcan.protocol.sdo_client import SdoTimeoutError

    assert "BlinkcanError" in blinkcan.__all__
    with pytest.raises(BlinkcanError):
        raise SdoTimeoutError("no reply", 0x15, 0x1000, 0)
