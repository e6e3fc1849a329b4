"""Parameters of an XBee-PRO 802.15.4 ("Series 1") module and of the radio link between two."""

from __future__ import annotations

from dataclasses import dataclass

#: ``ATBD`` codes 0..7 -> interface rate in bit/s (802.15.4 manual); larger values are rates.
BD_RATES: tuple[int, ...] = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)


def bd_to_baud(bd: int) -> int:
    """Interface rate in bit/s for an ``ATBD`` value."""
    return BD_RATES[bd] if 0 <= bd < len(BD_RATES) else bd


@dataclass(frozen=True)
class XBeeParams:
    """One module's non-volatile settings (AT parameter names in brackets).

    Defaults are the vehicle's module: API mode (AP=1) at 115200 bit/s (BD=7; 9600 cannot
    carry 50 Hz telemetry, docs/protocols.md 8.3), 16-bit address MY=1 sending to the
    ground station at DL=0. ``hv``/``vr`` identify an XBee-PRO 802.15.4 (HV high byte 0x18
    = XBP24-Axx; VR not starting with 8, so digi-xbee sees "802.15.4"). ``sh``/``sl``
    serial number; ``ni`` node identifier (<= 20 chars); ``ch``/``pan_id`` channel and PAN;
    ``ce`` coordinator enable; ``ro`` packetisation timeout in character times; ``gt_ms``
    guard time; ``cc`` command character; ``ct_100ms`` command-mode timeout;
    ``rr`` XBee retries; ``mm`` MAC mode; ``pl`` power level; ``max_payload`` RF payload
    limit (100 bytes); ``enforce_baud`` a host at another line rate reads garbage and is
    not understood (counted; the module stays silent towards it); ``at_response_delay_us``
    time the module takes to answer an API AT command (a real module needs a few ms; an
    instant answer also trips a lost-wakeup race in digi-xbee's synchronous requests).
    """

    __pydantic_config__ = {"extra": "forbid"}

    ap: int = 1
    bd: int = 7
    my: int = 0x0001
    dh: int = 0x00000000
    dl: int = 0x00000000
    sh: int = 0x0013A200
    sl: int = 0x40A1B201
    ni: str = "VEHICLE"
    ch: int = 0x0C
    pan_id: int = 0x3332
    ce: int = 0
    hv: int = 0x1842
    vr: int = 0x10EF
    ro: int = 3
    gt_ms: int = 1000
    cc: int = 0x2B
    ct_100ms: int = 0x64
    rr: int = 0
    mm: int = 0
    pl: int = 4
    max_payload: int = 100
    enforce_baud: bool = True
    at_response_delay_us: int = 2_000

    def __post_init__(self) -> None:
        if self.ap not in (0, 1, 2):
            raise ValueError("ap must be 0 (transparent), 1 (API) or 2 (escaped API)")
        if not 0 <= self.my <= 0xFFFF or not 0 <= self.pan_id <= 0xFFFF:
            raise ValueError("my and pan_id are 16-bit")
        if len(self.ni) > 20:
            raise ValueError("ni is at most 20 characters")
        if not 1 <= self.max_payload <= 100:
            raise ValueError("max_payload must be 1..100")

    @property
    def baud(self) -> int:
        """Interface rate in bit/s."""
        return bd_to_baud(self.bd)


@dataclass(frozen=True)
class LinkParams:
    """The air between the modules.

    ``air_rate_bps`` 802.15.4 at 2.4 GHz (250 kbit/s); ``latency_s`` module processing
    time from the end of the UART frame to the start of transmission; ``loss_probability``
    chance that one transmission attempt is not received (seeded); ``mac_retries`` 802.15.4
    MAC retries on a missing ACK (3), multiplied by the modules' RR; ``dropouts`` windows
    ``(start_s, duration_s)`` in which nothing gets through (out of range);
    ``rssi_dbm``/``rssi_noise_db`` received signal strength reported in RX frames.
    """

    __pydantic_config__ = {"extra": "forbid"}

    air_rate_bps: int = 250_000
    latency_s: float = 0.001
    loss_probability: float = 0.0
    mac_retries: int = 3
    dropouts: tuple[tuple[float, float], ...] = ()
    rssi_dbm: float = -40.0
    rssi_noise_db: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.loss_probability <= 1.0:
            raise ValueError("loss_probability must be within [0, 1]")
        if self.air_rate_bps <= 0 or self.latency_s < 0 or self.mac_retries < 0:
            raise ValueError("air_rate_bps > 0, latency_s >= 0, mac_retries >= 0 required")
