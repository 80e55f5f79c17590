"""The live object dictionary of a twin: current values of every entry of its object table.

This is where SDO requests meet the table: existence, access, length and range are checked here
in CiA 301 order (object, sub-index, access, length, value), then the twin's write hook for the
entry may refuse the value or act on it. Values are cached in their wire encoding, so an upload
is one dictionary look-up.

A stored setting is persisted *before* it is committed: if the twin's non-volatile memory cannot
take it, the write is refused with the persister's abort code and memory is left as it was, so
a retry is tried again rather than acknowledged as "unchanged" (an unchanged stored value is not
written again, as devices spare their EEPROM). An entry's ``check`` refuses a value before it is
persisted; if its hook refuses one afterwards, the previous settings are persisted back.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from blinkcan.devices.objects import ObjectEntry, ObjectTable, Value
from blinkcan.protocol.abort import AbortCode

#: A write hook: called with the new value before it is stored; returns an abort code to refuse.
WriteHook = Callable[[int], "AbortCode | None"]
#: A read hook: the bytes an SDO upload returns instead of the stored value.
Reader = Callable[[], bytes]
#: Persists the stored settings as they are to become; returns an abort code when it cannot.
Persister = Callable[[dict[str, Value]], "AbortCode | None"]


class _Slot:
    """One entry's live value and the facts about its type, computed once (hot path)."""

    __slots__ = ("acknowledge", "check", "entry", "hook", "keeps_value", "raw", "readable",
                 "reader", "signed", "size", "spans", "stored", "value", "writable")

    def __init__(self, entry: ObjectEntry, value: Value) -> None:
        self.entry = entry
        self.readable = entry.access.readable
        self.writable = entry.access.writable
        self.stored = entry.stored
        self.acknowledge = entry.acknowledge
        self.size = entry.data_type.size
        self.signed = entry.data_type.is_signed
        self.spans = _valid_spans(entry)
        self.hook: WriteHook | None = None
        self.check: WriteHook | None = None
        self.reader: Reader | None = None
        self.keeps_value = True
        self.value = value
        self.raw = entry.encode(value)


def _store_value(slot: _Slot, value: Value) -> None:
    slot.value = value
    if slot.size is not None and isinstance(value, int):
        slot.raw = value.to_bytes(slot.size, "little", signed=slot.signed)
    else:
        slot.raw = slot.entry.encode(value)


def _valid_spans(entry: ObjectEntry) -> tuple[tuple[int, int], ...]:
    """The entry's valid integer values as inclusive spans, clipped to its data type."""
    size = entry.data_type.size
    if size is None:
        return ()
    if entry.data_type.is_signed:
        low, high = -(1 << (8 * size - 1)), (1 << (8 * size - 1)) - 1
    else:
        low, high = 0, (1 << (8 * size)) - 1
    if entry.valid is None:
        return ((low, high),)
    return tuple((max(lo, low), min(hi, high)) for lo, hi in entry.valid.spans
                 if lo <= high and hi >= low)


class ObjectStore:
    """Current values by entry name, served to an :class:`~blinkcan.protocol.SdoServer`."""

    def __init__(self, table: ObjectTable, node_id: int) -> None:
        self.table = table
        self._slots: dict[bytes, _Slot] = {}
        self._by_name: dict[str, _Slot] = {}
        for entry in table:
            slot = _Slot(entry, entry.default_for(node_id))
            self._slots[entry.mux] = slot
            self._by_name[entry.name] = slot
        self._indices = frozenset(entry.index.to_bytes(2, "little") for entry in table)
        self._stored = [(name, slot) for name, slot in self._by_name.items() if slot.entry.stored]
        #: persists the stored settings before a write through SDO or RPDO changes one
        self.persist: Persister | None = None

    # -- Python side ----------------------------------------------------------------------

    def __getitem__(self, name: str) -> Value:
        return self._by_name[name].value

    def get_int(self, name: str) -> int:
        value = self._by_name[name].value
        assert isinstance(value, int), name
        return value

    def set(self, name: str, value: Value) -> None:
        """Set a value with no checks (the device itself changing its state)."""
        _store_value(self._by_name[name], value)

    def set_hook(self, name: str, hook: WriteHook, keeps_value: bool = True,
                 check: WriteHook | None = None) -> None:
        """Run ``hook`` on every write of ``name`` (SDO or RPDO). With ``keeps_value=False``
        the written value is a command, not the entry's new value: the hook updates the
        store itself (the Keybox's 2008h masks read back the pin states, KBX §21).
        ``check`` refuses a value before anything happens, the NVM write included."""
        slot = self._by_name[name]
        slot.hook = hook
        slot.check = check
        slot.keeps_value = keeps_value

    def set_reader(self, name: str, reader: Reader) -> None:
        """Answer SDO reads of ``name`` with ``reader()``: an entry whose write sets one
        quantity and whose read shows another (MT M40: a write stores the startup tick
        counter, a read returns the live counter)."""
        self._by_name[name].reader = reader

    def write_from_pdo(self, name: str, value: int) -> AbortCode | None:
        """An RPDO writing a mapped entry: hooks run as for SDO, access is not checked."""
        slot = self._by_name[name]
        return self._commit(slot, value)

    def _commit(self, slot: _Slot, value: Value, raw: bytes | None = None) -> AbortCode | None:
        """Check, persist, hook, store; ``raw`` is the value's wire encoding where the caller
        has it (an SDO download), so it is not encoded again."""
        if slot.check is not None:
            refusal = slot.check(value)  # type: ignore[arg-type]
            if refusal is not None:
                return refusal
        # an unchanged stored value is not written again (as devices spare their EEPROM)
        persist = self.persist if (slot.stored and slot.keeps_value
                                   and value != slot.value) else None
        if persist is not None:
            refusal = persist({**self.stored_values(), slot.entry.name: value})
            if refusal is not None:
                return refusal  # nothing changed: the retry is tried again
        hook = slot.hook
        if hook is not None:
            refusal = hook(value)  # type: ignore[arg-type]
            if refusal is not None:
                if persist is not None:
                    persist(self.stored_values())  # the file back to what memory holds
                return refusal
            if not slot.keeps_value:
                return None
        if raw is None:
            _store_value(slot, value)
        else:
            slot.value, slot.raw = value, raw
        return None

    def entries(self) -> Iterator[ObjectEntry]:
        return iter(self.table)

    def stored_values(self) -> dict[str, Value]:
        return {name: slot.value for name, slot in self._stored}

    def load(self, node_id: int, stored: dict[str, Value] | None) -> None:
        """Power-on values: stored entries from ``stored`` (or factory), live entries from
        their defaults or from the stored entry named by ``power_on_from``."""
        stored = stored or {}
        for slot in self._by_name.values():
            entry = slot.entry
            if entry.stored:
                value = stored.get(entry.name, entry.default_for(node_id))
            elif entry.power_on_from is not None:
                source = self.table[entry.power_on_from]
                value = stored.get(source.name, source.default_for(node_id))
            else:
                value = entry.default_for(node_id)
            self.set(entry.name, value)

    # -- SDO side (ObjectAccess) ------------------------------------------------------------

    def _missing(self, mux: bytes) -> AbortCode:
        if mux[:2] in self._indices:
            return AbortCode.SUBINDEX_DOES_NOT_EXIST
        return AbortCode.OBJECT_DOES_NOT_EXIST

    def sdo_upload(self, mux: bytes) -> bytes | AbortCode:
        slot = self._slots.get(mux)
        if slot is None:
            return self._missing(mux)
        if not slot.readable:
            return AbortCode.WRITE_ONLY
        reader = slot.reader
        return slot.raw if reader is None else reader()

    def sdo_download(self, mux: bytes, data: bytes, size_indicated: bool) -> int:
        slot = self._slots.get(mux)
        if slot is None:
            return self._missing(mux)
        if not slot.writable:
            return AbortCode.READ_ONLY
        size = slot.size
        if size is None:  # a string
            text = slot.entry.decode(data)
            refusal = self._commit(slot, text)
            return slot.acknowledge if refusal is None else refusal
        if len(data) != size:
            if size_indicated:
                return AbortCode.DATA_TYPE_LENGTH_MISMATCH
            data = data[:size]
        # unsigned without the keyword: a call with keywords costs more (every request)
        value = (int.from_bytes(data, "little", signed=True) if slot.signed
                 else int.from_bytes(data, "little"))
        for low, high in slot.spans:
            if low <= value <= high:
                break
        else:
            return AbortCode.INVALID_VALUE
        # the wire bytes are the value's encoding when they are all of it (not a short
        # unsized expedited write to a wider entry)
        raw = None if len(data) != size else data if data.__class__ is bytes else bytes(data)
        if slot.hook is not None or slot.stored:
            refusal = self._commit(slot, value, raw)
            if refusal is not None:
                return refusal
        elif raw is None:
            _store_value(slot, value)
        else:
            slot.value, slot.raw = value, raw
        return slot.acknowledge
