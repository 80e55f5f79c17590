"""The monitor's bus view follows the Keybox's fail-safe rules (README "Decisions"): a watchdog
trip, an NMT stop or a reboot means its outputs are OFF, whatever was commanded before."""

from __future__ import annotations

from blinkcan.decode import Decoder
from blinkcan.decode.view import BusView
from blinkcan.protocol import Frame
from blinkcan.twin import KeyboxTwin

OUTPUT_4_HIGH = Frame(0x20C, bytes.fromhex("0000080000000000"))  # KBX §17
HEARTBEAT_50_MS = Frame(0x60C, bytes.fromhex("2B17100032000000"))  # 1017h = 50 ms
WATCH_7FH_100_MS = Frame(0x60C, bytes.fromhex("231610016400_7F00".replace("_", "")))  # 1016h/01
HOST_HEARTBEAT = Frame(0x77F, b"\x05")


class Bench:
    """A Keybox twin, every frame on its bus decoded into one view."""

    def __init__(self) -> None:
        self.twin = KeyboxTwin()
        self.decoder = Decoder({0x0C: "keybox"})
        self.view = BusView()
        self._show(self.twin.power_on(0.0), 0.0)

    def _show(self, frames: list[Frame], now: float) -> None:
        for frame in frames:
            self.view.update(self.decoder.decode(frame, now))

    def send(self, frame: Frame, now: float) -> None:
        self._show([frame, *self.twin.receive(frame, now)], now)

    def advance(self, now: float) -> None:
        self._show(self.twin.advance(now), now)

    def output_4(self) -> str:
        return self.view.node(0x0C).outputs[4]


def test_a_watchdog_trip_shows_the_outputs_off() -> None:
    bench = Bench()
    bench.send(HEARTBEAT_50_MS, 0.0)
    bench.send(WATCH_7FH_100_MS, 0.0)
    bench.send(Frame(0x000, b"\x01\x0C"), 0.0)
    bench.send(OUTPUT_4_HIGH, 0.0)
    bench.send(HOST_HEARTBEAT, 0.01)  # the Keybox starts watching
    bench.advance(0.05)
    assert (bench.view.node(0x0C).state, bench.output_4()) == ("operational", "high")
    for step in range(2, 7):  # no host heartbeat from now on: the watchdog trips at 0.11 s
        bench.advance(step * 0.05)
    assert bench.twin.snapshot()["pins"][3]["state"] == "off"
    assert (bench.view.node(0x0C).state, bench.output_4()) == ("pre-operational", "off")


def test_enter_pre_operational_keeps_the_outputs_and_stop_switches_them_off() -> None:
    bench = Bench()
    bench.send(HEARTBEAT_50_MS, 0.0)
    bench.send(Frame(0x000, b"\x01\x0C"), 0.0)
    bench.send(OUTPUT_4_HIGH, 0.0)
    bench.advance(0.05)
    bench.send(Frame(0x000, b"\x80\x0C"), 0.06)  # enter pre-operational: outputs kept
    bench.advance(0.1)
    assert (bench.view.node(0x0C).state, bench.output_4()) == ("pre-operational", "high")
    bench.send(Frame(0x000, b"\x02\x00"), 0.11)  # stop, all nodes
    bench.advance(0.15)
    assert bench.twin.snapshot()["pins"][3]["state"] == "off"
    assert (bench.view.node(0x0C).state, bench.output_4()) == ("stopped", "off")


def test_a_reset_shows_the_outputs_off() -> None:
    bench = Bench()
    bench.send(Frame(0x000, b"\x01\x0C"), 0.0)
    bench.send(OUTPUT_4_HIGH, 0.0)
    assert bench.output_4() == "high"
    bench.send(Frame(0x000, b"\x82\x0C"), 0.1)  # reset communication
    assert bench.output_4() == "off"


def test_the_view_applies_off_wins_to_an_outputs_event() -> None:
    """KBX §17 (errata K12): a pin in both masks goes OFF. The view reads the rule from
    devices/ (commanded_outputs), not from the decoder having applied it: an event from
    elsewhere (a recorded one, another decoder) with both masks set shows the pin OFF."""
    from blinkcan.decode import Event, Kind

    view = BusView(Decoder({0x0C: "keybox"}))
    frame = Frame(0x20C, bytes.fromhex("0800080000000000"))
    view.update(Event(0.0, frame, Kind.PDO, "outputs", 0x0C, "keybox",
                      {"pdo": "outputs", "off": [4], "high": [4]}))
    assert view.node(0x0C).outputs[4] == "off"  # main: "high" (the later list won)
