"""The SDO client transfers against the twin's SDO server bytes, and their quirk leniency."""

from __future__ import annotations

import pytest

from blinkcan.protocol import Frame
from blinkcan.protocol.sdo_client import (
    DownloadTransfer,
    SdoAbortError,
    SdoProtocolError,
    UploadTransfer,
)
from blinkcan.twin import KeyboxTwin, KeypadTwin
from blinkcan.twin.base import CanopenTwin


def run(twin: CanopenTwin, transfer: UploadTransfer | DownloadTransfer) -> None:
    request: bytes | None = transfer.start()
    while request is not None:
        replies = twin.receive(Frame(0x600 + twin.node_id, request), 0.0)
        request = transfer.on_reply(replies[0].data)
    assert transfer.done


def keypad() -> KeypadTwin:
    twin = KeypadTwin()
    twin.power_on(0.0)
    return twin


def test_expedited_and_segmented_uploads() -> None:
    twin = keypad()
    upload = UploadTransfer(0x1000, 0)
    run(twin, upload)
    assert upload.value == bytes.fromhex("91010B00")
    for index, text in ((0x1008, b"BlinkMarine"), (0x100B, b"PKP2600SI"), (0x2200, b"FFFFFFFF")):
        upload = UploadTransfer(index, 0)
        run(twin, upload)
        assert upload.value == text


def test_downloads_and_the_43h_acknowledge() -> None:
    twin = keypad()
    run(twin, DownloadTransfer(0x1017, 0, (100).to_bytes(2, "little")))
    assert twin.objects["producer_heartbeat_time"] == 100
    keybox = KeyboxTwin(quirks="firmware")
    keybox.power_on(0.0)
    run(keybox, DownloadTransfer(0x1011, 1, b"load"))  # 43h accepted (errata K3)


def test_abort_names_node_object_and_meaning() -> None:
    transfer = DownloadTransfer(0x1017, 0, (5).to_bytes(2, "little"))
    with pytest.raises(SdoAbortError, match=r"1017h/00: aborted 06090030h, invalid value") as error:
        run(keypad(), transfer)
    assert error.value.code == 0x06090030


def test_segmented_download_against_the_server() -> None:
    from blinkcan.protocol.sdo_server import SdoServer
    from tests.protocol.test_sdo_server import FakeDictionary

    fake = FakeDictionary()
    server = SdoServer(fake)
    transfer = DownloadTransfer(0x3000, 0, b"a twenty byte string")
    request: bytes | None = transfer.start()
    while request is not None:
        reply = server.on_request(request)
        assert reply is not None
        request = transfer.on_reply(reply)
    assert fake.values[bytes.fromhex("003000")] == b"a twenty byte string"


@pytest.mark.parametrize("reply", [
    "43 01 10 00 00 00 00 00",  # another object
    "60 00 10 00 00 00 00 00",  # a download acknowledge to an upload
    "43 00 10",                 # too short
])
def test_replies_that_do_not_fit_are_errors(reply: str) -> None:
    upload = UploadTransfer(0x1000, 0)
    upload.start()
    with pytest.raises(SdoProtocolError):
        upload.on_reply(bytes.fromhex(reply.replace(" ", "")))


def test_a_4f_reply_for_a_16_bit_value_is_accepted() -> None:
    upload = UploadTransfer(0x1800, 5)  # errata P3: rev 1.1 prints 4Fh
    upload.start()
    assert upload.on_reply(bytes.fromhex("4F00180532000000")) is None
    assert upload.value == b"\x32"


def test_an_abort_is_any_command_specifier_4_frame() -> None:
    """CiA 301 §7.2.4.3.17: an abort is cs = 4; bits 4-0 are not used. A server that sets
    them still aborts the transfer (main took 81h for "unexpected reply")."""
    transfer = UploadTransfer(0x1008, 0)
    transfer.start()
    with pytest.raises(SdoAbortError, match="06020000h"):
        transfer.on_reply(bytes.fromhex("8108100000000206"))


@pytest.mark.parametrize(("command", "size", "segment", "outcome"), [
    (0x40, b"\x00\x00\x00\x00", b"\x01abcdefg", b"abcdefg"),  # no size stated: any length
    (0x41, b"\x07\x00\x00\x00", b"\x01abcdefg", b"abcdefg"),  # 7 stated, 7 came
    (0x41, b"\x05\x00\x00\x00", b"\x01abcdefg", "7 bytes, 5 announced"),
    (0x4D, b"\x07\x00\x00\x00", b"\x01abcdefg", b"abcdefg"),  # n bits ignored while e is clear
])
def test_segmented_upload_opening(command: int, size: bytes, segment: bytes,
                                  outcome: bytes | str) -> None:
    """CiA 301 §7.2.4.3.6: an initiate upload response with e clear opens a segmented upload;
    bytes 4-7 are its size only where s is set, and the segments must bring that many."""
    upload = UploadTransfer(0x2300, 0)
    upload.start()
    assert upload.on_reply(bytes((command,)) + b"\x00\x23\x00" + size) == b"\x60" + bytes(7)
    assert upload.size == (None if command & 0x01 == 0 else int.from_bytes(size, "little"))
    if isinstance(outcome, str):
        with pytest.raises(SdoProtocolError, match=outcome):
            upload.on_reply(segment)
        return
    assert upload.on_reply(segment) is None
    assert upload.done
    assert upload.value == outcome


def test_segmented_upload_opening_for_another_object_fails() -> None:
    upload = UploadTransfer(0x2300, 0)
    upload.start()
    with pytest.raises(SdoProtocolError, match="reply for"):
        upload.on_reply(b"\x41\x00\x24\x00\x07\x00\x00\x00")
