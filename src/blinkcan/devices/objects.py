"""The object-table model: entries as data that every face of blinkcan reads.

An :class:`ObjectTable` is the single source of truth for one device model and generation: the
SDO server, the twins, the host drivers, the EDS and DBC writers and the decoder all read it.
Tables compose: a firmware generation is ``base.with_objects(...)``, a small delta.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum, IntEnum
from functools import cache

from blinkcan.protocol.sdo import multiplexer


class DataType(IntEnum):
    """CiA 301 data type codes (table 44), as EDS files name them."""

    BOOLEAN = 0x0001
    INTEGER8 = 0x0002
    INTEGER16 = 0x0003
    INTEGER32 = 0x0004
    UNSIGNED8 = 0x0005
    UNSIGNED16 = 0x0006
    UNSIGNED32 = 0x0007
    VISIBLE_STRING = 0x0009

    @property
    def size(self) -> int | None:
        """Bytes on the wire, or None for a string (any length)."""
        return _SIZES.get(self)

    @property
    def is_string(self) -> bool:
        return self is DataType.VISIBLE_STRING

    @property
    def is_signed(self) -> bool:
        return self in (DataType.INTEGER8, DataType.INTEGER16, DataType.INTEGER32)


_SIZES = {
    DataType.BOOLEAN: 1,
    DataType.INTEGER8: 1,
    DataType.INTEGER16: 2,
    DataType.INTEGER32: 4,
    DataType.UNSIGNED8: 1,
    DataType.UNSIGNED16: 2,
    DataType.UNSIGNED32: 4,
}


class Access(str, Enum):
    """SDO access, with the EDS spelling as value."""

    RO = "ro"
    WO = "wo"
    RW = "rw"
    CONST = "const"

    @property
    def readable(self) -> bool:
        return self is not Access.WO

    @property
    def writable(self) -> bool:
        return self in (Access.RW, Access.WO)


class ObjectKind(IntEnum):
    """CiA 306 object codes."""

    VAR = 7
    ARRAY = 8
    RECORD = 9


@dataclass(frozen=True)
class NodeIdRelative:
    """A default that depends on the node id (a COB-ID): ``offset + node id``."""

    offset: int

    def resolve(self, node_id: int) -> int:
        return self.offset + node_id


Value = int | str
Default = int | str | NodeIdRelative


@dataclass(frozen=True)
class Ranges:
    """A set of valid integer values as inclusive ranges, e.g. ``0, 10..65279`` (errata P1)."""

    spans: tuple[tuple[int, int], ...]

    def __contains__(self, value: object) -> bool:
        return isinstance(value, int) and any(lo <= value <= hi for lo, hi in self.spans)

    def __str__(self) -> str:
        return ", ".join(
            f"{lo:#x}" if lo == hi else f"{lo:#x}..{hi:#x}" for lo, hi in self.spans
        )

    @property
    def low(self) -> int:
        return min(lo for lo, _ in self.spans)

    @property
    def high(self) -> int:
        return max(hi for _, hi in self.spans)


def values(*items: int | tuple[int, int]) -> Ranges:
    """``values(0, (10, 65279))``: the valid values of an entry."""
    return Ranges(tuple((item, item) if isinstance(item, int) else item for item in items))


@dataclass(frozen=True)
class ObjectEntry:
    """One (index, sub-index) of an object dictionary.

    ``name`` is the entry's unique snake_case name in its table (what code refers to);
    ``label`` the human name (EDS ParameterName, decoder text). ``stored`` entries are
    non-volatile. ``power_on_from`` names the stored entry a live one is loaded from at power-on.
    ``acknowledge`` is the SDO download acknowledge command the device sends (60h, or a quirk).
    """

    index: int
    subindex: int
    name: str
    label: str
    data_type: DataType
    access: Access
    default: Default
    valid: Ranges | None = None
    stored: bool = False
    power_on_from: str | None = None
    acknowledge: int = 0x60
    pdo_mappable: bool = False
    unit: str = ""
    doc: str = ""

    @property
    def mux(self) -> bytes:
        return multiplexer(self.index, self.subindex)

    def default_for(self, node_id: int) -> Value:
        default = self.default
        return default.resolve(node_id) if isinstance(default, NodeIdRelative) else default

    def accepts(self, value: Value) -> bool:
        """Whether ``value`` is a valid value of this entry."""
        if self.data_type.is_string:
            return isinstance(value, str)
        if not isinstance(value, int) or isinstance(value, bool):
            return False
        size = self.data_type.size or 4
        if self.data_type.is_signed:
            in_type = -(1 << (8 * size - 1)) <= value < (1 << (8 * size - 1))
        else:
            in_type = 0 <= value < (1 << (8 * size))
        return in_type and (self.valid is None or value in self.valid)

    def encode(self, value: Value) -> bytes:
        """The value's bytes on the wire (little-endian integers, ASCII strings)."""
        if isinstance(value, str):
            return value.encode("ascii")
        size = self.data_type.size or 4
        return value.to_bytes(size, "little", signed=self.data_type.is_signed)

    def decode(self, data: bytes) -> Value:
        if self.data_type.is_string:
            return data.decode("ascii", errors="replace")
        return int.from_bytes(data, "little", signed=self.data_type.is_signed)

    def describe_valid(self) -> str:
        if self.valid is not None:
            return str(self.valid)
        if self.data_type.is_string:
            return "any text"
        size = self.data_type.size or 4
        return f"0x0..{(1 << (8 * size)) - 1:#x}"


@dataclass(frozen=True)
class ObjectDef:
    """One object (index): a VAR with a single entry, or a RECORD/ARRAY of entries."""

    index: int
    name: str
    label: str
    kind: ObjectKind
    entries: tuple[ObjectEntry, ...]


@dataclass(frozen=True)
class TableLayout:
    """Where each entry of a table is: its position in the table's order by name, by (index,
    sub-index) and by its SDO multiplexer bytes. A layout depends only on the entries' places
    and names, not on their values, so every table of one structure (a model at any factory
    node id) shares one: :func:`table_layout` computes it once."""

    by_name: Mapping[str, int]
    by_key: Mapping[tuple[int, int], int]
    by_mux: Mapping[bytes, int]
    #: the 2-byte (little-endian) indices the table has: an SDO abort says sub-index or object
    index_bytes: frozenset[bytes]


@cache
def table_layout(places: tuple[tuple[int, int, str], ...]) -> TableLayout:
    """The layout of entries at ``places`` ((index, sub-index, name) in the table's order);
    ValueError if a name is used twice. Cached: a pure function of an immutable argument."""
    by_name: dict[str, int] = {}
    for position, (_, _, name) in enumerate(places):
        if name in by_name:
            raise ValueError(f"entry name {name!r} used twice")
        by_name[name] = position
    return TableLayout(
        by_name=by_name,
        by_key={(index, subindex): position
                for position, (index, subindex, _) in enumerate(places)},
        by_mux={multiplexer(index, subindex): position
                for position, (index, subindex, _) in enumerate(places)},
        index_bytes=frozenset(index.to_bytes(2, "little") for index, _, _ in places),
    )


@dataclass(frozen=True)
class ObjectTable:
    """An ordered object dictionary description. Immutable; compose with :meth:`with_objects`.

    Its look-ups are the shared :class:`TableLayout` of its structure over its own entries, so
    a table costs little more than its entries (127 twins of a model hold one layout)."""

    objects: tuple[ObjectDef, ...]
    #: every entry, in order (what the layout's positions index)
    entries: tuple[ObjectEntry, ...] = field(init=False, repr=False, compare=False)
    layout: TableLayout = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        entries = tuple(entry for obj in self.objects for entry in obj.entries)
        object.__setattr__(self, "entries", entries)
        object.__setattr__(self, "layout", table_layout(
            tuple((entry.index, entry.subindex, entry.name) for entry in entries)))

    def __iter__(self) -> Iterator[ObjectEntry]:
        return iter(self.entries)

    def __getitem__(self, name: str) -> ObjectEntry:
        try:
            return self.entries[self.layout.by_name[name]]
        except KeyError:
            raise KeyError(f"no object entry named {name!r}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.layout.by_name

    def get(self, index: int, subindex: int) -> ObjectEntry | None:
        position = self.layout.by_key.get((index, subindex))
        return None if position is None else self.entries[position]

    def has_index(self, index: int) -> bool:
        return any(obj.index == index for obj in self.objects)

    def object_at(self, index: int) -> ObjectDef | None:
        for obj in self.objects:
            if obj.index == index:
                return obj
        return None

    def with_objects(self, *changes: ObjectDef) -> ObjectTable:
        """A table with ``changes`` replacing objects of the same index or added, sorted."""
        by_index = {obj.index: obj for obj in self.objects}
        for obj in changes:
            by_index[obj.index] = obj
        return ObjectTable(tuple(sorted(by_index.values(), key=lambda obj: obj.index)))

    def with_entries(self, **changes: dict[str, object]) -> ObjectTable:
        """A table where the named entries have some fields replaced (e.g. a quirk default)."""
        unknown = set(changes) - set(self.layout.by_name)
        if unknown:
            raise KeyError(f"no object entries named {sorted(unknown)}")
        objects = tuple(
            replace(obj, entries=tuple(
                replace(entry, **changes[entry.name])  # type: ignore[arg-type]
                if entry.name in changes else entry
                for entry in obj.entries))
            if any(entry.name in changes for entry in obj.entries) else obj
            for obj in self.objects)
        return ObjectTable(objects)

    def sharing(self, other: ObjectTable) -> ObjectTable:
        """``other`` holding this table's objects wherever they are equal (the same model
        described at another factory node id differs in one entry): equal, and cheap to keep."""
        mine = {obj.index: obj for obj in self.objects}
        objects = tuple(mine[obj.index] if mine.get(obj.index) == obj else obj
                        for obj in other.objects)
        if len(objects) == len(self.objects) and all(
                ours is theirs for ours, theirs in zip(objects, self.objects, strict=True)):
            return self
        return ObjectTable(objects)


# -- builders: the tables in devices/ read like the manuals' object lists -------------------


Sub = ObjectEntry  # an entry given to var()/record() before its index is known (index 0)


def var(index: int, label: str, sub: Sub) -> ObjectDef:
    """A VAR object: one entry at sub-index 0."""
    if sub.subindex != 0:
        raise ValueError("a VAR object has its value at sub-index 0")
    return ObjectDef(index, sub.name, label, ObjectKind.VAR, (replace(sub, index=index),))


def record(
    index: int,
    name: str,
    label: str,
    subs: Iterable[Sub],
    kind: ObjectKind = ObjectKind.RECORD,
    highest: int | None = None,
) -> ObjectDef:
    """A RECORD or ARRAY: sub 00h "highest sub-index supported" (errata P18) is added, read-only,
    its value the highest sub-index given unless ``highest`` says otherwise."""
    entries = [replace(s, index=index) for s in subs]
    top = highest if highest is not None else max(e.subindex for e in entries)
    count = ObjectEntry(
        index,
        0,
        f"{name}_highest_subindex",
        "Highest sub-index supported",
        DataType.UNSIGNED8,
        Access.RO,
        top,
    )
    return ObjectDef(index, name, label, kind, (count, *entries))


def u8(sub: int, name: str, label: str, access: Access, default: Default, **kw: object) -> Sub:
    return ObjectEntry(0, sub, name, label, DataType.UNSIGNED8, access, default, **kw)  # type: ignore[arg-type]


def u16(sub: int, name: str, label: str, access: Access, default: Default, **kw: object) -> Sub:
    return ObjectEntry(0, sub, name, label, DataType.UNSIGNED16, access, default, **kw)  # type: ignore[arg-type]


def u32(sub: int, name: str, label: str, access: Access, default: Default, **kw: object) -> Sub:
    return ObjectEntry(0, sub, name, label, DataType.UNSIGNED32, access, default, **kw)  # type: ignore[arg-type]


def text(sub: int, name: str, label: str, default: str, **kw: object) -> Sub:
    return ObjectEntry(0, sub, name, label, DataType.VISIBLE_STRING, Access.RO, default,
                       **kw)  # type: ignore[arg-type]


def mapping_value(index: int, subindex: int, bits: int) -> int:
    """A PDO mapping entry value: index, sub-index, length in bits (PKP §37: 2001 01 08)."""
    return (index << 16) | (subindex << 8) | bits
