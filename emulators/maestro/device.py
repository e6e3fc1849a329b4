"""The Pololu Maestro as a byte device on the ``esc`` port.

Three sub-protocols are recognised on the fly and may be mixed (0J40 5.c): compact
(``cmd data...``), Pololu (``AA dev cmd&7F data...``; other device numbers are skipped)
and Mini SSC (``FF address value``). The parser is a table over (state, byte class).

Peer misbehaviour is answered as the Maestro does: a data byte where a command was
expected, an unknown command, or a packet interrupted by a command byte set the serial
protocol error bit; a bad CRC-7 sets the CRC bit and the packet is ignored. Any error
sends the channels home (default: off = no pulses) when ``home_on_error``. Get Errors
replies with the register (little-endian) and clears it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, auto

from emulators.base import ByteDevice, DeviceEvent
from emulators.maestro.motion import ServoChannel
from emulators.maestro.params import MaestroParams
from emulators.maestro.protocol import (
    DATA_LENGTH,
    Command,
    ErrorBit,
    Prefix,
    crc7,
    join14,
)

NS_PER_US = 1_000


@dataclass(frozen=True, init=False)
class TargetsSet(DeviceEvent):
    """A complete Set Target / Set Multiple Targets / Mini SSC command was applied at
    ``t_ns``: channels ``first_channel`` .. + len-1 now have ``targets_qus`` (after
    clamping; 0 = off)."""

    first_channel: int
    targets_qus: tuple[int, ...]

    def __init__(self, t_ns: int, first_channel: int, targets_qus: tuple[int, ...]) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "first_channel", first_channel)
        object.__setattr__(self, "targets_qus", targets_qus)


@dataclass(frozen=True)
class ProtocolError(DeviceEvent):
    """Error bits ``error_bits`` were set at ``t_ns`` for ``reason``."""

    error_bits: int
    reason: str


class _State(Enum):
    IDLE = auto()
    DEVICE = auto()  # got 0xAA, want the device number
    POLOLU_COMMAND = auto()  # got AA dev, want the command with MSB clear
    DATA = auto()  # collecting a command's data (and CRC) bytes
    MINI_SSC = auto()  # got 0xFF, collecting address and value


class _Class(Enum):
    DATA = auto()
    COMMAND = auto()
    POLOLU = auto()
    MINI_SSC = auto()


#: the compact protocol's command bytes
_COMMAND_CODES = frozenset(int(c) for c in Command)


def _classify(b: int) -> _Class:
    if b < 0x80:
        return _Class.DATA
    if b == Prefix.POLOLU:
        return _Class.POLOLU
    if b == Prefix.MINI_SSC:
        return _Class.MINI_SSC
    return _Class.COMMAND


class Maestro(ByteDevice):
    """Mini Maestro servo controller; channels 0..3 drive motors 0..3.

    ``pulse_us(channel, t_ns)`` is the width on the output pin (0.0 = no pulses).
    """

    name = "esc"

    def __init__(self, params: MaestroParams, *, fast_path: bool = True) -> None:
        super().__init__()
        self.params = params
        #: False: every byte goes through the state table (the reference for the fast path).
        self.fast_path = fast_path
        self.channels = [ServoChannel(params.update_period_us * NS_PER_US) for _ in range(params.n_channels)]
        self.errors = 0
        self._state = _State.IDLE
        self._packet = bytearray()  # bytes of the packet so far (for the CRC)
        self._cmd: Command | None = None
        self._data = bytearray()
        self._for_us = True  # False while skipping a Pololu packet for another device
        self._next_update_ns = params.update_period_us * NS_PER_US
        self._t_ns = 0
        self._last_valid_ns = 0
        self._baud_ok = True
        self._table: dict[tuple[_State, _Class], Callable[[int, _Class], None]] = {
            (_State.IDLE, _Class.DATA): self._stray_data,
            (_State.IDLE, _Class.COMMAND): self._start_compact,
            (_State.IDLE, _Class.POLOLU): self._start_pololu,
            (_State.IDLE, _Class.MINI_SSC): self._start_mini_ssc,
            (_State.DEVICE, _Class.DATA): self._device_number,
            (_State.POLOLU_COMMAND, _Class.DATA): self._pololu_command,
            (_State.DATA, _Class.DATA): self._data_byte,
        }
        for cls in (_Class.COMMAND, _Class.POLOLU, _Class.MINI_SSC):
            for st in (_State.DEVICE, _State.POLOLU_COMMAND, _State.DATA):
                self._table[(st, cls)] = self._interrupted
        for cls in _Class:
            self._table[(_State.MINI_SSC, cls)] = self._mini_ssc_byte

    # -- time -----------------------------------------------------------------------
    def advance(self, t_ns: int) -> None:
        """Run position updates (speed/acceleration) and the serial timeout up to ``t_ns``."""
        if t_ns < self._t_ns:
            return
        self._t_ns = t_ns
        period = self.params.update_period_us * NS_PER_US
        if self._next_update_ns <= t_ns:
            if any(ch.moving for ch in self.channels):
                while self._next_update_ns <= t_ns:
                    for ch in self.channels:
                        ch.step()
                    self._next_update_ns += period
            else:  # nothing moving: skip the idle updates in one go
                n = (t_ns - self._next_update_ns) // period + 1
                self._next_update_ns += n * period
        timeout_ms = self.params.serial_timeout_ms
        if timeout_ms and t_ns - self._last_valid_ns >= timeout_ms * 1_000_000:
            if not self.errors & ErrorBit.SERIAL_TIMEOUT:
                self._error(ErrorBit.SERIAL_TIMEOUT, "serial timeout")
            self._last_valid_ns = t_ns

    def pulse_us(self, channel: int, t_ns: int) -> float:
        """Output pulse width of ``channel`` at ``t_ns`` in us (0.0 = no pulses)."""
        self.advance(t_ns)
        return self.channels[channel].position_qus / 4.0

    def line_settings_changed(self, baud: int, t_ns: int) -> None:
        """Over USB the rate is ignored; on the TTL UART a wrong rate gives signal errors."""
        super().line_settings_changed(baud, t_ns)
        self._baud_ok = self.params.usb_command_port or baud == self.params.baud

    # -- bytes in ----------------------------------------------------------------------
    def receive(self, data: bytes, t_ns: int) -> None:
        """Parse host bytes arriving at ``t_ns``; replies are queued in order."""
        self.advance(t_ns)
        self.counters["rx_bytes"] += len(data)
        if not self._baud_ok:
            self.counters["rx_bad_baud_bytes"] += len(data)
            self._error(ErrorBit.SERIAL_SIGNAL, "line rate mismatch")
            return
        if self.fast_path and self._state is _State.IDLE and self._whole_compact(data):
            return
        for b in data:
            self._table[(self._state, _classify(b))](b, _classify(b))

    def _whole_compact(self, data: bytes) -> bool:
        """One whole compact-protocol packet, as a flight loop writes it (one Set Multiple
        Targets a tick): executed at once, with the same effects as byte by byte through the
        table. False (nothing done) for anything else: that goes through the table."""
        code = data[0] if data else 0
        if code not in _COMMAND_CODES:  # data bytes, the Pololu and Mini SSC prefixes too
            return False
        cmd = Command(code)
        n = DATA_LENGTH[cmd]
        if n is None:  # Set Multiple Targets: n, first, 2n
            if len(data) < 2:
                return False
            n = 2 + 2 * data[1]
        crc = self.params.crc_enabled
        if len(data) != 1 + n + (1 if crc else 0) or max(data[1:], default=0) >= 0x80:
            return False
        self._reset()
        if crc:
            if crc7(data[:-1]) != data[-1]:
                self.counters["crc_errors"] += 1
                self._error(ErrorBit.SERIAL_CRC, "CRC mismatch")
                return True
            self._execute(cmd, data[1:-1])
        else:
            self._execute(cmd, data[1:])
        return True

    def _reset(self) -> None:
        self._state = _State.IDLE
        self._packet.clear()
        self._data.clear()
        self._cmd = None
        self._for_us = True

    def _stray_data(self, b: int, cls: _Class) -> None:
        self.counters["stray_data_bytes"] += 1
        self._error(ErrorBit.SERIAL_PROTOCOL, "data byte where a command was expected")

    def _interrupted(self, b: int, cls: _Class) -> None:
        self.counters["interrupted_packets"] += 1
        if self._for_us:
            self._error(ErrorBit.SERIAL_PROTOCOL, "packet interrupted by a command byte")
        self._reset()
        self._table[(_State.IDLE, cls)](b, cls)

    def _start_pololu(self, b: int, cls: _Class) -> None:
        self._reset()
        self._packet.append(b)
        self._state = _State.DEVICE

    def _device_number(self, b: int, cls: _Class) -> None:
        self._packet.append(b)
        self._for_us = b == self.params.device_number
        self._state = _State.POLOLU_COMMAND

    def _pololu_command(self, b: int, cls: _Class) -> None:
        self._packet.append(b)
        self._begin(b | 0x80)

    def _start_compact(self, b: int, cls: _Class) -> None:
        self._reset()
        self._packet.append(b)
        self._begin(b)

    def _begin(self, code: int) -> None:
        try:
            self._cmd = Command(code)
        except ValueError:
            if self._for_us:
                self.counters["unknown_commands"] += 1
                self._error(ErrorBit.SERIAL_PROTOCOL, f"unknown command 0x{code:02X}")
                self._reset()
            else:  # someone else's command: skip its data bytes until the next command
                self._cmd = None
                self._state = _State.DATA
            return
        self._state = _State.DATA
        self._data_complete_check()

    def _needed(self) -> int | None:
        """Data bytes (incl. CRC) this packet needs; None while still unknown."""
        assert self._cmd is not None
        n = DATA_LENGTH[self._cmd]
        if n is None:  # Set Multiple Targets: n, first, 2n
            if not self._data:
                return None
            n = 2 + 2 * self._data[0]
        return n + (1 if self.params.crc_enabled else 0)

    def _data_byte(self, b: int, cls: _Class) -> None:
        if self._cmd is None:  # skipping an unknown packet addressed elsewhere
            return
        self._packet.append(b)
        self._data.append(b)
        self._data_complete_check()

    def _data_complete_check(self) -> None:
        need = self._needed()
        if need is None or len(self._data) < need:
            return
        cmd, data, packet, for_us = self._cmd, bytes(self._data), bytes(self._packet), self._for_us
        self._reset()
        if not for_us:
            self.counters["packets_other_device"] += 1
            return
        if self.params.crc_enabled:
            if crc7(packet[:-1]) != packet[-1]:
                self.counters["crc_errors"] += 1
                self._error(ErrorBit.SERIAL_CRC, "CRC mismatch")
                return
            data = data[:-1]
        assert cmd is not None
        self._execute(cmd, data)

    def _start_mini_ssc(self, b: int, cls: _Class) -> None:
        self._reset()
        self._state = _State.MINI_SSC

    def _mini_ssc_byte(self, b: int, cls: _Class) -> None:
        if b == Prefix.MINI_SSC:  # 255 is never a Mini SSC data byte
            self._error(ErrorBit.SERIAL_PROTOCOL, "0xFF inside a Mini SSC packet")
            self._start_mini_ssc(b, cls)
            return
        self._data.append(b)
        if len(self._data) < 2:
            return
        address, value = self._data
        self._reset()
        channel = address - self.params.mini_ssc_offset
        if not 0 <= channel < self.params.n_channels:
            self.counters["mini_ssc_other_address"] += 1
            return
        p = self.params
        target = int(round(p.neutral_qus + (value - 127) * p.range_qus / 127))
        self._last_valid_ns = self._t_ns
        self.counters["commands"] += 1
        self.counters["cmd_mini_ssc"] += 1
        self._set_targets(channel, [target])

    # -- commands ------------------------------------------------------------------------
    def _execute(self, cmd: Command, d: bytes) -> None:
        self.counters[f"cmd_{cmd.name.lower()}"] += 1
        n_ch = self.params.n_channels
        if cmd in (Command.SET_TARGET, Command.SET_SPEED, Command.SET_ACCELERATION, Command.GET_POSITION) \
                and d[0] >= n_ch:
            self._error(ErrorBit.SERIAL_PROTOCOL, f"channel {d[0]} does not exist")
            return
        self._last_valid_ns = self._t_ns
        self.counters["commands"] += 1
        if cmd is Command.SET_TARGET:
            self._set_targets(d[0], [join14(d[1], d[2])])
        elif cmd is Command.SET_MULTIPLE_TARGETS:
            count, first = d[0], d[1]
            if count == 0 or first + count > n_ch:
                self._error(ErrorBit.SERIAL_PROTOCOL, "targets beyond the last channel")
                return
            self._set_targets(first, [join14(d[2 + 2 * i], d[3 + 2 * i]) for i in range(count)])
        elif cmd is Command.SET_SPEED:
            self.channels[d[0]].speed = join14(d[1], d[2])
        elif cmd is Command.SET_ACCELERATION:
            self.channels[d[0]].accel = min(255, join14(d[1], d[2]))
        elif cmd is Command.GET_POSITION:
            self._send(int(round(self.channels[d[0]].position_qus)).to_bytes(2, "little"))
        elif cmd is Command.GET_MOVING_STATE:
            self._send(bytes((1 if any(ch.moving for ch in self.channels) else 0,)))
        elif cmd is Command.GET_ERRORS:
            self._send(self.errors.to_bytes(2, "little"))
            self.errors = 0
        elif cmd is Command.GO_HOME:
            self._go_home()
        elif cmd is Command.GET_SCRIPT_STATUS:
            self._send(b"\x01")  # no script loaded: stopped
        # SET_PWM and the script commands are accepted and have no effect on the ESCs.

    def _clamp(self, target_qus: int) -> int:
        if target_qus == 0:
            return 0
        return min(self.params.max_target_qus, max(self.params.min_target_qus, target_qus))

    def _set_targets(self, first: int, targets: list[int]) -> None:
        applied = tuple(self._clamp(t) for t in targets)
        for i, t in enumerate(applied):
            self.channels[first + i].set_target(t)
        self._event(TargetsSet(self._t_ns, first, applied))

    def _go_home(self) -> None:
        home = self._clamp(self.params.home_qus)
        for ch in self.channels:
            ch.set_target(home)

    def _error(self, bit: ErrorBit, reason: str) -> None:
        self.errors |= int(bit)
        self.counters[f"error_{str(bit.name).lower()}"] += 1  # one bit: always named
        self._event(ProtocolError(self._t_ns, int(bit), reason))
        if self.params.home_on_error:
            self._go_home()
