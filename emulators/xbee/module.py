"""One XBee-PRO 802.15.4 module as a byte device (``telemetry`` on the vehicle, ``ground``).

Host side: API mode (AP=1, escaped AP=2: TX16/TX64 requests, AT command/queue frames
with 0x88 responses, 0x89 TX status when the frame id is not 0, RX16/RX64 on reception,
0x8A modem status on reset) or transparent mode (AP=0: bytes are packetised after RO
character times of silence at the line rate or at 100 bytes; ``+++`` between guard times
enters command mode, where ``AT`` lines are answered until ``ATCN`` or the CT timeout).

Air side (driven by :class:`emulators.xbee.link.RadioLink`): :meth:`take_air_tx` hands
over the packets to transmit, :meth:`accepts`/:meth:`air_receive` deliver incoming ones,
:meth:`air_tx_done` reports the delivery result of one of ours.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from emulators.xbee import frames as fr
from emulators.xbee.frames import (
    ApiParser,
    AtStatus,
    FrameType,
    ModemStatus,
    RxOption,
    TxOption,
    TxStatus,
)
from emulators.xbee.params import XBeeParams, bd_to_baud
from emulators.xbee.packets import NO_16BIT, AtCommandHandled, ModeChanged, RfKind, RfPacket
from emulators.xbee.registers import REGISTERS, Registers, RegKind
from emulators.xbee.transparent import NS_PER_MS, TransparentMode, TextState

NS_PER_S = 1_000_000_000
REMOTE_APPLY = 0x02  # remote AT option: apply changes


class XBeeModule(TransparentMode):
    """An XBee-PRO 802.15.4 module; ``rng`` is reserved for module-side randomness (the
    link draws losses and RSSI noise from its own generator)."""

    def __init__(self, params: XBeeParams, rng: np.random.Generator, name: str = "telemetry") -> None:
        super().__init__()
        self.name = name
        self.params = params
        self.rng = rng
        self.regs = Registers(params)
        self._parser = ApiParser(escaped=self.ap == 2)
        self._air_tx: list[RfPacket] = []
        self._tag_frame_id: dict[int, int] = {}
        #: tag of an outgoing remote AT request -> (frame id, command, dest64, dest16)
        self._tag_remote: dict[int, tuple[int, bytes, int, int]] = {}
        self._next_tag = 1
        self._baud_ok = True
        self._t_ns = 0
        #: API frames waiting for their release time: (t_ns, frame data).
        self._delayed: deque[tuple[int, bytes]] = deque()
        self._reset_text_state()

    # -- identity ------------------------------------------------------------------------
    @property
    def ap(self) -> int:
        """Current API mode (0, 1, 2)."""
        return self.regs.num("AP")

    @property
    def baud(self) -> int:
        """Interface rate in bit/s (ATBD)."""
        return bd_to_baud(self.regs.num("BD"))

    @property
    def address16(self) -> int:
        """MY."""
        return self.regs.num("MY")

    @property
    def address64(self) -> int:
        """SH:SL."""
        return (self.regs.num("SH") << 32) | self.regs.num("SL")

    @property
    def in_command_mode(self) -> bool:
        """True in transparent command mode."""
        return self._text is TextState.COMMAND

    # -- host side -----------------------------------------------------------------------
    def reset(self, t_ns: int) -> None:
        """Power-up/hardware reset: in API mode the module announces it (0x8A, status 0)."""
        self.regs.pending.clear()
        self._parser = ApiParser(escaped=self.ap == 2)
        self._delayed.clear()
        self._reset_text_state()
        if self.ap:
            self._send_frame(fr.modem_status(ModemStatus.HARDWARE_RESET))

    def line_settings_changed(self, baud: int, t_ns: int) -> None:
        """A host at another rate than BD is not understood (and would read garbage)."""
        super().line_settings_changed(baud, t_ns)
        self._check_baud()

    def _check_baud(self) -> None:
        self._baud_ok = (not self.params.enforce_baud or self.host_baud is None
                         or self.host_baud == self.baud)
        if not self._baud_ok:
            self.counters["baud_mismatch"] += 1

    def receive(self, data: bytes, t_ns: int) -> None:
        """Bytes the host wrote, arriving at ``t_ns``."""
        self._t_ns = max(self._t_ns, t_ns)
        self.counters["rx_bytes"] += len(data)
        if not self._baud_ok:
            self.counters["rx_bad_baud_bytes"] += len(data)
            return
        if self._text is TextState.COMMAND:
            self._command_bytes(data, t_ns)
        elif self.ap:
            for frame in self._parser.feed(data):
                self._api_frame(frame, t_ns)
            pc = self._parser.counters
            self.counters["api_bad_checksum"] = pc.bad_checksum
            self.counters["api_skipped_bytes"] = pc.skipped_bytes
            self.counters["api_bad_length"] = pc.bad_length
        else:
            self._transparent_bytes(data, t_ns)

    def advance(self, t_ns: int) -> None:
        """Release delayed API answers; transparent-mode timers: guard times, RO
        packetisation, CT timeout."""
        self._t_ns = max(self._t_ns, t_ns)
        while self._delayed and self._delayed[0][0] <= t_ns:
            self._send_frame(self._delayed.popleft()[1])
        if self.ap:
            return
        gt_ns = self.regs.num("GT") * NS_PER_MS
        if self._text is TextState.COMMAND:
            if t_ns >= self._cmd_deadline_ns:
                self._exit_command_mode(t_ns)
            return
        if self._plus == 3 and t_ns - self._plus_last_ns >= gt_ns:
            self._plus = 0
            self._text = TextState.COMMAND
            self._cmd_line.clear()
            self._cmd_deadline_ns = t_ns + self.regs.num("CT") * 100 * NS_PER_MS
            self.counters["command_mode_entered"] += 1
            self._send(b"OK\r")
            return
        if 0 < self._plus < 3 and t_ns - self._plus_first_ns >= gt_ns:
            self._flush_plus()  # not a command sequence after all: they were data
        ro_ns = self.regs.num("RO") * 10 * NS_PER_S // self.baud
        if self._tx_buf and self._plus == 0 and t_ns - self._last_rx_ns >= ro_ns:
            self._packetise(self._last_rx_ns + ro_ns)

    # -- API mode ------------------------------------------------------------------------
    def _send_frame(self, frame_data: bytes) -> None:
        self._send(fr.encode_frame(frame_data, escaped=self.ap == 2))
        self.counters["api_frames_out"] += 1

    def _send_later(self, t_release_ns: int, frame_data: bytes) -> None:
        if t_release_ns <= self._t_ns:
            self._send_frame(frame_data)
        else:
            self._delayed.append((t_release_ns, frame_data))

    def _api_frame(self, fd: bytes, t_ns: int) -> None:
        kind = fd[0]
        self.counters["api_frames_in"] += 1
        if kind == FrameType.TX_REQUEST_16 and len(fd) >= 5:
            self._transmit(fd[5:], int.from_bytes(fd[2:4], "big"), None, fd[4], fd[1], t_ns)
        elif kind == FrameType.TX_REQUEST_64 and len(fd) >= 11:
            self._transmit(fd[11:], None, int.from_bytes(fd[2:10], "big"), fd[10], fd[1], t_ns)
        elif kind in (FrameType.AT_COMMAND, FrameType.AT_COMMAND_QUEUE) and len(fd) >= 4:
            name = fd[2:4].decode("ascii", "replace").upper()
            status, value = self._at(name, fd[4:] if len(fd) > 4 else None, t_ns,
                                     apply_now=kind == FrameType.AT_COMMAND, via="api")
            release_ns = t_ns + self.params.at_response_delay_us * 1_000
            software_reset = name == "FR" and status == AtStatus.OK
            if software_reset:  # answer, then restart: pending changes and buffers are gone
                self.regs.pending.clear()
                self._reset_text_state()
            if fd[1]:
                self._send_later(release_ns, fr.at_response(fd[1], fd[2:4], status, value))
            if software_reset:
                self._send_later(release_ns, fr.modem_status(ModemStatus.WATCHDOG_RESET))
        elif kind == FrameType.REMOTE_AT_COMMAND and len(fd) >= 15:
            self._remote_at_request(fd, t_ns)
        else:
            self.counters["api_frames_unsupported"] += 1

    def _remote_at_request(self, fd: bytes, t_ns: int) -> None:
        frame_id, options, command, param = fd[1], fd[12], fd[13:15], fd[15:]
        dest64, dest16 = int.from_bytes(fd[2:10], "big"), int.from_bytes(fd[10:12], "big")
        # 802.15.4: a known 16-bit address wins; 0xFFFE means "use the 64-bit one".
        addr16, addr64 = (dest16, None) if dest16 != NO_16BIT else (None, dest64)
        tag = self._queue_air(bytes((frame_id, options)) + command + param, addr16, addr64, ack=True,
                              broadcast_pan=False, t_ns=t_ns, kind=RfKind.REMOTE_AT_REQUEST)
        self._tag_remote[tag] = (frame_id, command, dest64, dest16)
        self.counters["remote_at_out"] += 1

    def _queue_air(self, payload: bytes, dest16: int | None, dest64: int | None, *, ack: bool,
                   broadcast_pan: bool, t_ns: int, kind: RfKind = RfKind.DATA) -> int:
        my = self.address16
        tag = self._next_tag
        self._next_tag += 1
        self._air_tx.append(RfPacket(
            t_ns, min(NO_16BIT, my), self.address64, dest16, dest64, bytes(payload), ack,
            broadcast_pan, self.regs.num("CH"), self.regs.num("ID"), tag, kind))
        return tag

    def _transmit(self, payload: bytes, dest16: int | None, dest64: int | None, options: int,
                  frame_id: int, t_ns: int) -> None:
        if len(payload) > self.params.max_payload:
            self.counters["tx_oversize"] += 1
            return
        mm = self.regs.num("MM")
        broadcast = dest16 == fr.BROADCAST_16 or dest64 == fr.BROADCAST_64
        ack = not broadcast and not options & TxOption.DISABLE_ACK and mm in (0, 2)
        tag = self._queue_air(payload, dest16, dest64, ack=ack, broadcast_pan=bool(options & TxOption.BROADCAST_PAN),
                              t_ns=t_ns)
        if frame_id:
            self._tag_frame_id[tag] = frame_id
        self.counters["rf_packets_out"] += 1

    # -- air side ------------------------------------------------------------------------
    def take_air_tx(self) -> list[RfPacket]:
        """Drain the packets the module has handed to its radio."""
        out, self._air_tx = self._air_tx, []
        return out

    def accepts(self, pkt: RfPacket) -> bool:
        """True if this module's MAC takes ``pkt`` (channel, PAN and address match)."""
        if pkt.channel != self.regs.num("CH"):
            return False
        if pkt.pan_id != self.regs.num("ID") and not pkt.broadcast_pan:
            return False
        if pkt.dest16 is not None:
            return pkt.dest16 == fr.BROADCAST_16 or (pkt.dest16 == self.address16 and self.address16 < NO_16BIT)
        return pkt.dest64 in (fr.BROADCAST_64, self.address64)

    def air_receive(self, pkt: RfPacket, t_ns: int, rssi_dbm: float) -> None:
        """Deliver a received packet to the host."""
        self.regs.values["DB"] = min(0xFF, max(0, int(round(-rssi_dbm))))
        if pkt.kind is RfKind.REMOTE_AT_REQUEST:
            self._remote_at_execute(pkt, t_ns)
            return
        if pkt.kind is RfKind.REMOTE_AT_RESPONSE:
            if self.ap and self._baud_ok and len(pkt.payload) >= 4 and pkt.payload[0]:
                p = pkt.payload
                self._send_frame(fr.remote_at_response(p[0], pkt.src64, pkt.src16, p[2:4], p[1], p[4:]))
            return
        self.counters["rf_packets_in"] += 1
        if not self._baud_ok:
            return
        if self.ap:
            opts = (RxOption.ADDRESS_BROADCAST if pkt.broadcast else 0) | (
                RxOption.PAN_BROADCAST if pkt.broadcast_pan else 0)
            if pkt.src16 == NO_16BIT:
                self._send_frame(fr.rx64(pkt.src64, rssi_dbm, pkt.payload, opts))
            else:
                self._send_frame(fr.rx16(pkt.src16, rssi_dbm, pkt.payload, opts))
        else:
            self._send(pkt.payload)

    def _remote_at_execute(self, pkt: RfPacket, t_ns: int) -> None:
        """Run a remote AT command from another module and send the answer back over the air."""
        p = pkt.payload
        if len(p) < 4:
            self.counters["remote_at_malformed"] += 1
            return
        name = p[2:4].decode("ascii", "replace").upper()
        status, value = self._at(name, p[4:] if len(p) > 4 else None, t_ns,
                                 apply_now=bool(p[1] & REMOTE_APPLY), via="remote")
        back16, back64 = (pkt.src16, None) if pkt.src16 != NO_16BIT else (None, pkt.src64)
        self._queue_air(bytes((p[0], int(status))) + p[2:4] + value, back16, back64, ack=True,
                        broadcast_pan=False, t_ns=t_ns, kind=RfKind.REMOTE_AT_RESPONSE)

    def air_tx_done(self, tag: int, status: TxStatus, t_ns: int) -> None:
        """The radio finished with our packet ``tag``: report it if the host asked (API)."""
        remote = self._tag_remote.pop(tag, None)
        if remote is not None:
            frame_id, command, dest64, dest16 = remote
            if status != TxStatus.SUCCESS and frame_id and self.ap and self._baud_ok:
                self._send_frame(fr.remote_at_response(frame_id, dest64, dest16, command, AtStatus.REMOTE_FAILED))
            return
        frame_id = self._tag_frame_id.pop(tag, 0)
        if status != TxStatus.SUCCESS:
            self.counters["tx_failed"] += 1
            if status == TxStatus.NO_ACK:
                self.regs.values["EA"] = min(0xFFFF, self.regs.num("EA") + 1)
        if frame_id and self.ap and self._baud_ok:
            self._send_frame(fr.tx_status(frame_id, status))

    # -- AT commands (both interfaces) -----------------------------------------------------------
    def _at(self, name: str, param: bytes | str | None, t_ns: int, *, apply_now: bool,
            via: str) -> tuple[AtStatus, bytes]:
        status, value = self._at_inner(name, param, apply_now)
        self.counters[f"at_{via}"] += 1
        self._event(AtCommandHandled(t_ns, name, int(status), via))
        return status, value

    def _at_inner(self, name: str, param: bytes | str | None, apply_now: bool) -> tuple[AtStatus, bytes]:
        spec = REGISTERS.get(name)
        if spec is None:
            return AtStatus.INVALID_COMMAND, b""
        if spec.kind is RegKind.EXEC:
            if name == "AC":
                self._apply()
            elif name == "RE":
                self.regs.restore_defaults()
                self._after_change({"AP", "BD"})
            return AtStatus.OK, b""
        if param is None or param == b"" or (isinstance(param, str) and not param.strip() and spec.kind is not RegKind.STRING):
            return AtStatus.OK, self.regs.encode_api(name)
        value = (Registers.decode_text(name, param) if isinstance(param, str)
                 else Registers.decode_api(name, param))
        if value is None or not self.regs.validate(name, value):
            return AtStatus.INVALID_PARAMETER, b""
        self.regs.stage(name, value)
        if apply_now:
            self._apply()
        return AtStatus.OK, b""

    def _apply(self) -> None:
        self._after_change(self.regs.apply())

    def _after_change(self, changed: set[str]) -> None:
        if "AP" in changed:
            self._parser = ApiParser(escaped=self.ap == 2)
            self._event(ModeChanged(self._t_ns, self.ap))
        if "BD" in changed:
            self._check_baud()
