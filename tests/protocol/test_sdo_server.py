"""The SDO server state machine alone, on a small fake dictionary: bytes in, bytes out."""

from __future__ import annotations

from blinkcan.protocol import AbortCode, SdoServer
from blinkcan.protocol.sdo import multiplexer


class FakeDictionary:
    """2000h/00: 4-byte value; 3000h/00: a writable string; 4000h/00 write-only; 5000h quirk 43h."""

    def __init__(self) -> None:
        self.values: dict[bytes, bytes] = {
            multiplexer(0x2000, 0): b"\x01\x02\x03\x04",
            multiplexer(0x3000, 0): b"",
        }
        self.written: list[tuple[int, int, bytes]] = []

    def sdo_upload(self, mux: bytes) -> bytes | AbortCode:
        if mux == multiplexer(0x4000, 0):
            return AbortCode.WRITE_ONLY
        if mux not in self.values:
            return AbortCode.OBJECT_DOES_NOT_EXIST
        return self.values[mux]

    def sdo_download(self, mux: bytes, data: bytes, size_indicated: bool) -> int:
        if mux == multiplexer(0x5000, 0):
            return 0x43
        if mux not in self.values:
            return AbortCode.OBJECT_DOES_NOT_EXIST
        self.values[mux] = data
        return 0x60


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def test_expedited_upload_sizes() -> None:
    fake = FakeDictionary()
    server = SdoServer(fake)
    for size, command in ((1, "4F"), (2, "4B"), (3, "47"), (4, "43")):
        fake.values[multiplexer(0x2000, 0)] = bytes(range(1, size + 1))
        reply = server.on_request(h("4000200000000000"))
        assert reply == h(command + "002000") + bytes(range(1, size + 1)) + bytes(4 - size)


def test_segmented_download_with_toggle_and_size() -> None:
    fake = FakeDictionary()
    server = SdoServer(fake)
    assert server.on_request(h("210030000A000000")) == h("6000300000000000")
    assert server.on_request(h("00") + b"Blink M") == h("2000000000000000")
    assert server.on_request(h("19") + b"ari" + bytes(4)) == h("3000000000000000")
    assert fake.values[multiplexer(0x3000, 0)] == b"Blink Mari"


def test_segmented_download_size_mismatch_and_toggle_error() -> None:
    server = SdoServer(FakeDictionary())
    server.on_request(h("2100300005000000"))
    assert server.on_request(h("0B") + b"ab" + bytes(5)) == h("8000300010000706")
    server.on_request(h("2000300000000000"))
    assert server.on_request(h("10") + bytes(7)) == h("8000300000000305")


def test_a_new_initiate_abandons_an_open_transfer() -> None:
    fake = FakeDictionary()
    server = SdoServer(fake)
    fake.values[multiplexer(0x3000, 0)] = b"0123456789"
    assert server.on_request(h("4000300000000000")) == h("410030000A000000")
    assert server.on_request(h("4000200000000000")) == h("4300200001020304")
    assert server.on_request(h("6000000000000000")) == h("8000000001000405")


def test_a_read_answered_before_still_abandons_an_open_transfer() -> None:
    # the server keeps the reply to an expedited read it answered (session 9); the same read
    # while an upload or a download is open still ends that transfer: its next segment request
    # is refused (CiA 301 §7.2.4.3.17)
    fake = FakeDictionary()
    server = SdoServer(fake)
    fake.values[multiplexer(0x3000, 0)] = b"0123456789"
    read = h("4000200000000000")
    assert server.on_request(read) == h("4300200001020304")
    for opening, segment in ((h("4000300000000000"), h("6000000000000000")),
                             (h("210030000A000000"), h("00") + b"Blink M")):
        server.on_request(opening)
        assert server.state.name != "IDLE"
        assert server.on_request(read) == h("4300200001020304")
        assert server.state.name == "IDLE"
        assert server.on_request(segment) == h("8000000001000405")


def test_client_abort_gets_no_reply_and_ends_the_transfer() -> None:
    fake = FakeDictionary()
    fake.values[multiplexer(0x3000, 0)] = b"0123456789"
    server = SdoServer(fake)
    server.on_request(h("4000300000000000"))
    assert server.on_request(h("8000300000000408")) is None
    assert server.on_request(h("6000000000000000")) == h("8000000001000405")


def test_empty_value_uploads_as_one_empty_segment() -> None:
    server = SdoServer(FakeDictionary())
    assert server.on_request(h("4000300000000000")) == h("4100300000000000")
    assert server.on_request(h("6000000000000000")) == h("0F00000000000000")


def test_write_only_and_quirk_acknowledge() -> None:
    server = SdoServer(FakeDictionary())
    assert server.on_request(h("4000400000000000")) == h("8000400001000106")
    assert server.on_request(h("2300500001000000")) == h("4300500000000000")


def test_short_requests_are_padded_and_answered() -> None:
    server = SdoServer(FakeDictionary())
    assert server.on_request(h("40002000")) == h("4300200001020304")
    assert server.on_request(b"") == h("8000000001000405")


def test_oversized_segmented_download_is_refused() -> None:
    server = SdoServer(FakeDictionary())
    assert server.on_request(h("2100300000100000")) == h("8000300005000405")


def test_a_request_reads_the_same_however_many_were_seen_and_in_any_form() -> None:
    # the server keeps the parse of requests it saw (bounded): the answer never depends on it,
    # whether the request has its 8 bytes or fewer (errata P10: read as padded)
    fake = FakeDictionary()
    server = SdoServer(fake)
    fake.values[multiplexer(0x2000, 0)] = b"\x07"
    expected = h("4F00200007000000")
    for round_ in range(3):
        for sub in range(1, 600):  # more distinct requests than the server keeps
            server.on_request(h("40002000") + sub.to_bytes(4, "little"))
        assert server.on_request(h("4000200000000000")) == expected, round_
        assert server.on_request(h("40002000")) == expected


def _segments_of(value: bytes) -> list[bytes]:
    """CiA 301 §7.2.4.3.7, written out: 7 bytes a segment, toggle from 0, n unused, c last."""
    out = []
    for k in range(max(1, -(-len(value) // 7))):
        chunk = value[7 * k : 7 * k + 7]
        last = 7 * k + 7 >= len(value)
        out.append(bytes(((k % 2) << 4 | (7 - len(chunk)) << 1 | last,)) + chunk
                   + bytes(7 - len(chunk)))
    return out


def test_segmented_uploads_of_every_length_read_again_and_after_a_change() -> None:
    """Every length from 5 to 22 bytes (a whole last segment included), read twice, then after
    the value changed: each read gets the segments of the value at its initiate."""
    fake = FakeDictionary()
    server = SdoServer(fake)
    mux = multiplexer(0x3000, 0)
    for size in range(5, 23):
        for value in (bytes(range(size)), bytes(range(size)), bytes(range(100, 100 + size))):
            fake.values[mux] = value
            assert server.on_request(h("4000300000000000")) == (
                h("41003000") + size.to_bytes(4, "little"))
            fake.values[mux] = b"changed meanwhile"  # not what this upload carries
            for k, segment in enumerate(_segments_of(value)):
                assert server.on_request(bytes((0x60 | (k % 2) << 4,)) + bytes(7)) == segment
            assert server.state.name == "IDLE"


def test_an_upload_segment_with_the_wrong_toggle_aborts_and_the_next_read_starts_over() -> None:
    fake = FakeDictionary()
    server = SdoServer(fake)
    fake.values[multiplexer(0x3000, 0)] = b"twenty bytes of text"
    server.on_request(h("4000300000000000"))
    assert server.on_request(h("6000000000000000")) == b"\x00twenty "
    assert server.on_request(h("6000000000000000")) == h("8000300000000305")  # toggle not 1
    server.on_request(h("4000300000000000"))
    assert server.on_request(h("6000000000000000")) == b"\x00twenty "
    assert server.on_request(h("7000000000000000")) == b"\x10bytes o"
    assert server.on_request(h("6000000000000000")) == b"\x03f text\x00"  # 6 bytes, last
