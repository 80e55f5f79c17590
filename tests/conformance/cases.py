"""The cases of the conformance suite, read from the model registry: every model, every
generation it declares, every quirk profile, and every protocol its description speaks
(CANopen, plus each protocol named in its features). A model added to the registry is a new
set of cases here without any change to the suite.

Known failures are listed in :data:`KNOWN_FAILURES` by check and case, each with the issue item
that fixes it, and run as ``xfail(strict=True)``: when the fix lands the test says so."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import pytest

from blinkcan.devices.model import QUIRK_PROFILES, DeviceDescription, Model
from blinkcan.devices.registry import models

#: protocols a description may name in its features besides CANopen, which every model speaks
OTHER_PROTOCOLS = ("j1939",)


@dataclass(frozen=True)
class Case:
    model: Model
    generation: str
    quirks: str
    protocol: str

    @property
    def description(self) -> DeviceDescription:
        return self.model.description(self.generation, self.quirks)

    @property
    def spec(self) -> str:
        return f"{self.model.name}@{self.generation}"

    @property
    def canopen(self) -> bool:
        return self.protocol == "canopen"

    def __str__(self) -> str:
        return f"{self.spec}-{self.quirks}-{self.protocol}"


def _cases() -> list[Case]:
    found = []
    for model in models():
        for generation in model.generations:
            for quirks in QUIRK_PROFILES:
                features = model.description(generation, quirks).features
                for protocol in ("canopen", *(p for p in OTHER_PROTOCOLS if p in features)):
                    found.append(Case(model, generation, quirks, protocol))
    return found


CASES = _cases()

#: (check, which cases) -> why it fails today (the issue item that fixes it)
KNOWN_FAILURES: dict[str, tuple[Callable[[Case], bool], str]] = {
}


def cases(check: str) -> list[object]:
    """The cases of one check, a known failure marked xfail(strict=True) with its reason."""
    params: list[object] = []
    for case in CASES:
        marks = []
        for name, (applies, reason) in KNOWN_FAILURES.items():
            if name.partition(":")[0] == check and applies(case):
                marks.append(pytest.mark.xfail(strict=True, reason=reason))
        params.append(pytest.param(case, id=str(case), marks=marks))
    return params
