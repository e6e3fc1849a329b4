"""Transparent mode of an XBee module (AP=0), the base of :class:`emulators.xbee.module.XBeeModule`.

Host bytes are packetised after RO character times of silence at the line rate or at the
maximum payload; ``+++`` (CC) between guard times (GT) enters command mode, where ``AT``
lines are answered until ``ATCN`` or the CT timeout. The module's timers that drive this are
in ``XBeeModule.advance``; the radio and the AT commands are the module's.
"""

from __future__ import annotations

from enum import Enum, auto

from emulators.base import ByteDevice
from emulators.xbee.frames import AtStatus
from emulators.xbee.params import XBeeParams
from emulators.xbee.registers import Registers

NS_PER_MS = 1_000_000


class TextState(Enum):
    """Transparent mode: passing data, or answering AT lines."""

    DATA = auto()
    COMMAND = auto()


class TransparentMode(ByteDevice):
    """The transparent-mode state and its host bytes; the radio side (``_transmit``) and the
    AT commands (``_at``, ``_apply``) are the subclass's."""

    regs: Registers
    params: XBeeParams
    _text: TextState
    _tx_buf: bytearray
    _last_rx_ns: int
    _plus: int
    _plus_first_ns: int
    _plus_last_ns: int
    _cmd_line: bytearray
    _cmd_deadline_ns: int

    def _transmit(self, payload: bytes, dest16: int | None, dest64: int | None, options: int,
                  frame_id: int, t_ns: int) -> None:
        raise NotImplementedError

    def _at(self, name: str, param: bytes | str | None, t_ns: int, *, apply_now: bool,
            via: str) -> tuple[AtStatus, bytes]:
        raise NotImplementedError

    def _apply(self) -> None:
        raise NotImplementedError

    def _reset_text_state(self) -> None:
        self._text = TextState.DATA
        self._tx_buf = bytearray()
        self._last_rx_ns = -(1 << 62)  # "long ago": power-up counts as silence
        self._plus = 0
        self._plus_first_ns = 0
        self._plus_last_ns = 0
        self._cmd_line = bytearray()
        self._cmd_deadline_ns = 0

    def _transparent_bytes(self, data: bytes, t_ns: int) -> None:
        cc = self.regs.num("CC")
        gt_ns = self.regs.num("GT") * NS_PER_MS
        for b in data:
            if b == cc and self._plus == 0 and not self._tx_buf and t_ns - self._last_rx_ns >= gt_ns:
                self._plus, self._plus_first_ns, self._plus_last_ns = 1, t_ns, t_ns
            elif b == cc and 0 < self._plus < 3 and t_ns - self._plus_first_ns < gt_ns:
                self._plus += 1
                self._plus_last_ns = t_ns
            else:
                self._flush_plus()
                self._tx_buf.append(b)
                if len(self._tx_buf) >= self.params.max_payload:
                    self._packetise(t_ns)
            self._last_rx_ns = t_ns
        if self.regs.num("RO") == 0 and self._tx_buf and self._plus == 0:
            self._packetise(t_ns)

    def _flush_plus(self) -> None:
        if self._plus:
            self._tx_buf += bytes((self.regs.num("CC"),)) * self._plus
            self._plus = 0
            while len(self._tx_buf) >= self.params.max_payload:
                self._packetise(self._last_rx_ns)

    def _packetise(self, t_ns: int) -> None:
        chunk = bytes(self._tx_buf[: self.params.max_payload])
        del self._tx_buf[: self.params.max_payload]
        dh, dl = self.regs.num("DH"), self.regs.num("DL")
        if dh == 0 and dl <= 0xFFFF:
            self._transmit(chunk, dl, None, 0, 0, t_ns)
        else:
            self._transmit(chunk, None, (dh << 32) | dl, 0, 0, t_ns)

    def _command_bytes(self, data: bytes, t_ns: int) -> None:
        for b in data:
            if self._text is not TextState.COMMAND:  # ATCN earlier in this chunk: the rest is data
                self._transparent_bytes(bytes((b,)), t_ns)
                continue
            if b != 0x0D:
                if len(self._cmd_line) < 128:
                    self._cmd_line.append(b)
                continue
            line = self._cmd_line.decode("ascii", "replace").strip()
            self._cmd_line.clear()
            self._cmd_deadline_ns = t_ns + self.regs.num("CT") * 100 * NS_PER_MS
            self._command_line(line, t_ns)

    def _command_line(self, line: str, t_ns: int) -> None:
        if not line.upper().startswith("AT"):
            self._send(b"ERROR\r")
            return
        body = line[2:]
        if not body.strip():
            self._send(b"OK\r")
            return
        for part in body.split(","):
            part = part.strip()
            name, param = part[:2].upper(), part[2:].strip()
            status, value = self._at(name, param if param else None, t_ns, apply_now=False, via="text")
            if status != AtStatus.OK:
                self._send(b"ERROR\r")
                return
            if name == "CN":
                self._send(b"OK\r")
                self._exit_command_mode(t_ns)
                return
            if value:
                self._send(self.regs.encode_text(name).encode("ascii", "replace") + b"\r")
            else:
                self._send(b"OK\r")

    def _exit_command_mode(self, t_ns: int) -> None:
        self._text = TextState.DATA
        self._cmd_line.clear()
        self._last_rx_ns = t_ns
        self._apply()
