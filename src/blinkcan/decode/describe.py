"""One line of meaning per frame, read from the device descriptions (the seed of ``decode/``).

"keypad 15h: SDO write 2001h/01 LED on red = 004h", "keypad 15h: keys 4 pressed". Which node
is which device comes from the caller.
"""

from __future__ import annotations

from blinkcan.devices.model import DeviceDescription
from blinkcan.protocol.abort import describe_abort
from blinkcan.protocol.cob import HEARTBEAT, NMT, SDO_RX, SDO_TX, SYNC
from blinkcan.protocol.frame import Frame
from blinkcan.protocol.nmt import NmtCommand, NmtState
from blinkcan.protocol.sdo import EXPEDITED_UPLOAD_COMMAND, split_multiplexer

_UPLOAD_SIZES = {command: size for size, command in EXPEDITED_UPLOAD_COMMAND.items()}
_NMT_TEXT = {
    NmtCommand.START: "start",
    NmtCommand.STOP: "stop",
    NmtCommand.ENTER_PRE_OPERATIONAL: "enter pre-operational",
    NmtCommand.RESET_NODE: "reset node",
    NmtCommand.RESET_COMMUNICATION: "reset communication",
}
_STATE_TEXT = {
    NmtState.BOOT_UP: "boot-up",
    NmtState.STOPPED: "stopped",
    NmtState.OPERATIONAL: "operational",
    NmtState.PRE_OPERATIONAL: "pre-operational",
}


def bit_list(mask: int, offset: int = 1) -> str:
    """"1, 4, 12" for the set bits of a mask (bit 0 = item ``offset``)."""
    items = [str(i + offset) for i in range(mask.bit_length()) if mask >> i & 1]
    return ", ".join(items) if items else "none"


class FrameDescriber:
    """Describes frames for a set of known nodes (node id -> device description)."""

    def __init__(self, devices: dict[int, DeviceDescription]) -> None:
        self.devices = dict(devices)
        self._writing: dict[int, bool] = {}

    def _who(self, node_id: int) -> str:
        device = self.devices.get(node_id)
        return f"{device.kind if device else 'node'} {node_id:02X}h"

    def describe(self, frame: Frame) -> str:
        if frame.extended:
            return f"extended frame {frame.can_id:08X}h"
        can_id, data = frame.can_id, frame.data
        if can_id == NMT and len(data) >= 2:
            try:
                command = _NMT_TEXT[NmtCommand(data[0])]
            except ValueError:
                command = f"command {data[0]:02X}h"
            target = "all nodes" if data[1] == 0 else self._who(data[1])
            return f"NMT {command}, {target}"
        if can_id == SYNC:
            return "SYNC"
        function, node_id = can_id & 0x780, can_id & 0x7F
        who = self._who(node_id)
        if function == HEARTBEAT and len(data) == 1:
            if data[0] == NmtState.BOOT_UP:
                return f"{who}: boot-up"
            try:
                state = _STATE_TEXT[NmtState(data[0])]
            except ValueError:
                state = f"state {data[0]:02X}h"
            return f"{who}: heartbeat, {state}"
        device = self.devices.get(node_id)
        if function in (SDO_RX, SDO_TX) and len(data) == 8:
            return f"{who}: {self._sdo(node_id, device, function == SDO_RX, data)}"
        if device is not None:
            for layout in device.pdos:
                if layout.cob_id(node_id) == can_id:
                    return f"{who}: {self._pdo(layout.name, layout.decode(data))}"
        return f"{who}: frame {can_id:03X}h"

    def _sdo(self, node_id: int, device: DeviceDescription | None, request: bool,
             data: bytes) -> str:
        command = data[0]
        index, sub = split_multiplexer(data[1:4])
        entry = device.table.get(index, sub) if device else None
        name = f"{index:04X}h/{sub:02X}" + (f" {entry.label}" if entry else "")
        if request:
            ccs = command >> 5
            self._writing[node_id] = ccs == 1
            if ccs == 2:
                return f"SDO read {name}"
            if ccs == 1:
                if command & 0x02:
                    size = 4 - ((command >> 2) & 3) if command & 1 else 4
                    value = int.from_bytes(data[4 : 4 + size], "little")
                    return f"SDO write {name} = {value:X}h"
                return f"SDO segmented write {name}"
            if ccs == 3:
                return "SDO read next segment"
            if ccs == 4:
                return f"SDO abort {name}"
            return f"SDO request {command:02X}h"
        if command == 0x80:
            code = int.from_bytes(data[4:8], "little")
            return f"SDO abort {name}: {code:08X}h {describe_abort(code)}"
        writing = self._writing.get(node_id, False)
        if command == 0x60 or (command == 0x43 and writing):  # errata K3: 43h acknowledge
            return f"SDO write {name} done"
        if command in _UPLOAD_SIZES:
            raw = data[4 : 4 + _UPLOAD_SIZES[command]]
            if entry is not None and entry.data_type.is_string:
                return f"SDO value {name} = {raw.decode('ascii', 'replace')!r}"
            return f"SDO value {name} = {int.from_bytes(raw, 'little'):X}h"
        if command == 0x41:
            return f"SDO value {name}: {int.from_bytes(data[4:8], 'little')} bytes follow"
        if command >> 5 == 0:
            size = 7 - ((command >> 1) & 7)
            text = data[1 : 1 + size].decode("ascii", "replace")
            return f"SDO segment {text!r}" + (" (last)" if command & 1 else "")
        return f"SDO reply {command:02X}h"

    @staticmethod
    def _pdo(name: str, values: dict[str, int]) -> str:
        if name == "key_state":
            return f"keys pressed: {bit_list(values['keys'])} (tick {values['tick']})"
        if name in ("led_on", "led_blink"):
            verb = "LEDs on" if name == "led_on" else "LEDs blink"
            parts = [f"{colour} {bit_list(values[colour])}" for colour in ("red", "green", "blue")
                     if values[colour]]
            return f"{verb}: {'; '.join(parts) if parts else 'none'}"
        if name == "indicator_brightness":
            return f"indicator brightness {values['level']}/63"
        if name == "backlight_brightness":
            return f"backlight brightness {values['level']}/63"
        if name == "outputs":
            off, high = values["off"], values["high"] & ~values["off"]  # KBX §17: OFF wins
            return f"outputs OFF: {bit_list(off)}; HIGH: {bit_list(high)}"
        if name == "faults":
            return f"pins in FAULT: {bit_list(values['faults'])}"
        return f"{name} {values}"


__all__ = ["FrameDescriber", "bit_list"]
