"""Pure device behaviour: twins that answer frames as the real devices do. Time is an argument."""

from blinkcan.twin.base import CanopenTwin
from blinkcan.twin.keybox import KeyboxTwin
from blinkcan.twin.keypad import KeypadTwin
from blinkcan.twin.nvm import MemoryNvm, Nvm, NvmError

__all__ = ["CanopenTwin", "KeyboxTwin", "KeypadTwin", "MemoryNvm", "Nvm", "NvmError"]


def __getattr__(name: str) -> object:
    """``blinkcan.twin.JsonFileNvm``, for callers of earlier versions: the file store now
    lives in ``blinkcan.formats.nvm_file`` (this layer does no I/O) and loads on first use."""
    if name == "JsonFileNvm":
        from blinkcan.formats.nvm_file import JsonFileNvm  # noqa: PLC0415

        return JsonFileNvm
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
