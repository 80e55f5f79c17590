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
from functools import cache

from blinkcan.devices.objects import NodeIdRelative, ObjectEntry, ObjectTable, Value
from blinkcan.protocol.abort import AbortCode

#: A write hook: called with the new value before it is stored; returns an abort code to refuse.
WriteHook = Callable[[int], "AbortCode | None"]
#: A read hook: the bytes an SDO upload returns instead of the stored value.
Reader = Callable[[], bytes]
#: Persists the stored settings as they are to become; returns an abort code when it cannot.
Persister = Callable[[dict[str, Value]], "AbortCode | None"]


class _Facts:
    """What the hot path needs of one entry, computed once per entry (shared by every twin
    whose table holds it): access, size, sign, valid spans, and its default's wire bytes."""

    __slots__ = ("acknowledge", "default", "default_raw", "entry", "readable", "signed", "size",
                 "spans", "stored", "writable")

    def __init__(self, entry: ObjectEntry) -> None:
        self.entry = entry
        self.readable = entry.access.readable
        self.writable = entry.access.writable
        self.stored = entry.stored
        self.acknowledge = entry.acknowledge
        self.size = entry.data_type.size
        self.signed = entry.data_type.is_signed
        self.spans = _valid_spans(entry)
        default = entry.default
        #: a node-independent default and its bytes, kept by every twin at that value
        self.default: Value | None = None if isinstance(default, NodeIdRelative) else default
        self.default_raw = b"" if self.default is None else entry.encode(self.default)


@cache
def _facts(entry: ObjectEntry) -> _Facts:
    """The one :class:`_Facts` of an entry (equal entries share it; a cache on a pure
    function of an immutable entry)."""
    return _Facts(entry)


class _Hooks:
    """What a twin registered on one entry (few entries have any)."""

    __slots__ = ("check", "hook", "keeps_value", "reader")

    def __init__(self) -> None:
        self.hook: WriteHook | None = None
        self.check: WriteHook | None = None
        self.reader: Reader | None = None
        self.keeps_value = True


class _Slot:
    """One entry's live value (its wire bytes cached: an upload is one look-up), the shared
    facts about it, and the hooks registered on it, if any."""

    __slots__ = ("facts", "hooks", "raw", "value")

    def __init__(self, facts: _Facts) -> None:
        self.facts = facts
        self.hooks: _Hooks | None = None
        self.value: Value = 0
        self.raw = b""


def _store_value(slot: _Slot, value: Value) -> None:
    facts = slot.facts
    if value.__class__ is facts.default.__class__ and value == facts.default:
        # the default's value and bytes objects are the ones every twin holds
        slot.value, slot.raw = facts.default, facts.default_raw
        return
    slot.value = value
    if facts.size is not None and isinstance(value, int):
        slot.raw = value.to_bytes(facts.size, "little", signed=facts.signed)
    else:
        slot.raw = facts.entry.encode(value)


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
    """Current values by entry name, served to an :class:`~blinkcan.protocol.SdoServer`.

    Per twin only the values are kept (one slot per entry, in the table's order); where the
    entries are, what they accept and their defaults' bytes are the table's and shared."""

    def __init__(self, table: ObjectTable, node_id: int) -> None:
        self.table = table
        layout = table.layout
        self._by_mux = layout.by_mux
        self._by_name = layout.by_name
        self._index_bytes = layout.index_bytes
        self._slots = [_Slot(_facts(entry)) for entry in table.entries]
        for slot in self._slots:
            _store_value(slot, slot.facts.entry.default_for(node_id))
        self._stored = tuple((slot.facts.entry.name, slot) for slot in self._slots
                             if slot.facts.stored)
        #: persists the stored settings before a write through SDO or RPDO changes one
        self.persist: Persister | None = None

    # -- Python side ----------------------------------------------------------------------

    def _slot(self, name: str) -> _Slot:
        return self._slots[self._by_name[name]]

    def __getitem__(self, name: str) -> Value:
        return self._slots[self._by_name[name]].value

    def get_int(self, name: str) -> int:
        value = self._slots[self._by_name[name]].value
        assert isinstance(value, int), name
        return value

    def set(self, name: str, value: Value) -> None:
        """Set a value with no checks (the device itself changing its state)."""
        _store_value(self._slots[self._by_name[name]], value)

    def _hooks(self, name: str) -> _Hooks:
        slot = self._slot(name)
        if slot.hooks is None:
            slot.hooks = _Hooks()
        return slot.hooks

    def set_hook(self, name: str, hook: WriteHook, keeps_value: bool = True,
                 check: WriteHook | None = None) -> None:
        """Run ``hook`` on every write of ``name`` (SDO or RPDO). With ``keeps_value=False``
        the written value is a command, not the entry's new value: the hook updates the
        store itself (the Keybox's 2008h masks read back the pin states, KBX §21).
        ``check`` refuses a value before anything happens, the NVM write included."""
        hooks = self._hooks(name)
        hooks.hook = hook
        hooks.check = check
        hooks.keeps_value = keeps_value

    def set_reader(self, name: str, reader: Reader) -> None:
        """Answer SDO reads of ``name`` with ``reader()``: an entry whose write sets one
        quantity and whose read shows another (MT M40: a write stores the startup tick
        counter, a read returns the live counter)."""
        self._hooks(name).reader = reader

    def write_from_pdo(self, name: str, value: int) -> AbortCode | None:
        """An RPDO writing a mapped entry: hooks run as for SDO, access is not checked."""
        return self._commit(self._slot(name), value)

    def _commit(self, slot: _Slot, value: Value, raw: bytes | None = None) -> AbortCode | None:
        """Check, persist, hook, store; ``raw`` is the value's wire encoding where the caller
        has it (an SDO download), so it is not encoded again."""
        hooks = slot.hooks
        if hooks is not None and hooks.check is not None:
            refusal = hooks.check(value)  # type: ignore[arg-type]
            if refusal is not None:
                return refusal
        keeps_value = hooks is None or hooks.keeps_value
        # an unchanged stored value is not written again (as devices spare their EEPROM)
        persist = self.persist if (slot.facts.stored and keeps_value
                                   and value != slot.value) else None
        if persist is not None:
            refusal = persist({**self.stored_values(), slot.facts.entry.name: value})
            if refusal is not None:
                return refusal  # nothing changed: the retry is tried again
        hook = None if hooks is None else hooks.hook
        if hook is not None:
            refusal = hook(value)  # type: ignore[arg-type]
            if refusal is not None:
                if persist is not None:
                    persist(self.stored_values())  # the file back to what memory holds
                return refusal
            if not keeps_value:
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
        for slot in self._slots:
            entry = slot.facts.entry
            if entry.stored:
                value = stored.get(entry.name, entry.default_for(node_id))
            elif entry.power_on_from is not None:
                source = self.table[entry.power_on_from]
                value = stored.get(source.name, source.default_for(node_id))
            else:
                value = entry.default_for(node_id)
            _store_value(slot, value)

    # -- SDO side (ObjectAccess) ------------------------------------------------------------

    def _missing(self, mux: bytes) -> AbortCode:
        if mux[:2] in self._index_bytes:
            return AbortCode.SUBINDEX_DOES_NOT_EXIST
        return AbortCode.OBJECT_DOES_NOT_EXIST

    def sdo_upload(self, mux: bytes) -> bytes | AbortCode:
        position = self._by_mux.get(mux)
        if position is None:
            return self._missing(mux)
        slot = self._slots[position]
        if not slot.facts.readable:
            return AbortCode.WRITE_ONLY
        hooks = slot.hooks
        if hooks is None or hooks.reader is None:
            return slot.raw
        return hooks.reader()

    def sdo_download(self, mux: bytes, data: bytes, size_indicated: bool) -> int:
        position = self._by_mux.get(mux)
        if position is None:
            return self._missing(mux)
        slot = self._slots[position]
        facts = slot.facts
        if not facts.writable:
            return AbortCode.READ_ONLY
        size = facts.size
        if size is None:  # a string
            text = facts.entry.decode(data)
            refusal = self._commit(slot, text)
            return facts.acknowledge if refusal is None else refusal
        if len(data) != size:
            if size_indicated:
                return AbortCode.DATA_TYPE_LENGTH_MISMATCH
            data = data[:size]
        # unsigned without the keyword: a call with keywords costs more (every request)
        value = (int.from_bytes(data, "little", signed=True) if facts.signed
                 else int.from_bytes(data, "little"))
        for low, high in facts.spans:
            if low <= value <= high:
                break
        else:
            return AbortCode.INVALID_VALUE
        # the wire bytes are the value's encoding when they are all of it (not a short
        # unsized expedited write to a wider entry)
        raw = None if len(data) != size else data if data.__class__ is bytes else bytes(data)
        if slot.hooks is not None or facts.stored:
            refusal = self._commit(slot, value, raw)
            if refusal is not None:
                return refusal
        elif raw is None:
            _store_value(slot, value)
        else:
            slot.value, slot.raw = value, raw
        return facts.acknowledge
