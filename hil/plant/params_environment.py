"""Parameters of the vehicle's environment: the ISA atmosphere, the wind (mean,
turbulence, scheduled gusts).

Frozen dataclasses whose defaults are the paper's calm ISA day; each sets
``__pydantic_config__`` for ``hil/config/files.py`` (see ``hil/plant/params.py``, which
gathers every parameter class, for where the numbers come from and the frames). This
module imports nothing but the standard library; it also holds the checks the plant's
parameter modules share.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum, unique

#: Standard gravity, m/s^2 (ISO 80000-3; also the ISA g0 of docs/protocols.md section 3).
G0_MPS2 = 9.80665

Vec3 = tuple[float, float, float]


def _require(ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(what)


def _finite(values: tuple[float, ...]) -> bool:
    return all(math.isfinite(v) for v in values)


@unique
class GustShape(StrEnum):
    """Time profile of a scheduled gust (MIL-F-8785C discrete gust family)."""

    #: Full peak from start to start + duration.
    STEP = "step"
    #: peak/2 * (1 - cos(2 pi t / duration)): rises, peaks half-way, returns to zero.
    ONE_MINUS_COSINE = "1-cos"


@dataclass(frozen=True)
class EnvironmentParams:
    """ISA atmosphere with an altimeter setting and a field elevation (docs/protocols.md 3)."""

    __pydantic_config__ = {"extra": "forbid"}

    field_elevation_m: float = 0.0
    #: Sea-level pressure setting; 101325 Pa is ISA standard.
    qnh_Pa: float = 101325.0
    #: ISA temperature deviation (a "ISA+15" day is 15.0).
    temperature_offset_K: float = 0.0
    gravity_mps2: float = G0_MPS2

    def __post_init__(self) -> None:
        _require(self.qnh_Pa > 0.0 and self.gravity_mps2 > 0.0, "qnh_Pa and gravity must be > 0")
        _require(-500.0 <= self.field_elevation_m <= 10000.0, "field_elevation_m outside the troposphere")


@dataclass(frozen=True)
class GustParams:
    """One scheduled gust or wind step in NED, sim time."""

    __pydantic_config__ = {"extra": "forbid"}

    peak_N_mps: Vec3
    start_t_ns: int
    duration_ns: int
    shape: GustShape = GustShape.ONE_MINUS_COSINE

    def __post_init__(self) -> None:
        _require(self.duration_ns > 0, "gust duration_ns must be > 0")
        _require(_finite(self.peak_N_mps), "gust peak must be finite")


@dataclass(frozen=True)
class WindParams:
    """Mean wind + turbulence + scheduled gusts. Calm by default.

    Turbulence is either the Dryden model (``dryden = true``: MIL-F-8785C spectra and
    low-altitude intensities, with rotational components) or a simpler first-order
    Gauss-Markov process per NED axis with given RMS (``turbulence_sigma_N_mps``). Both are
    frozen turbulence carried past the vehicle at max(|mean horizontal wind|, min speed).
    """

    __pydantic_config__ = {"extra": "forbid"}

    mean_N_mps: Vec3 = (0.0, 0.0, 0.0)
    #: RMS turbulence per axis. MIL-F-8785C low altitude: sigma_w = 0.1 * W20 and
    #: sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h_ft)^0.4 (about 1.9 sigma_w at 10 m).
    turbulence_sigma_N_mps: Vec3 = (0.0, 0.0, 0.0)
    #: Scale lengths; MIL-F-8785C low altitude at h = 10 m: L_u = L_v = 67 m, L_w = 10 m.
    turbulence_length_m: Vec3 = (67.0, 67.0, 10.0)
    turbulence_min_speed_mps: float = 1.0
    #: Turbulence is sampled on this sim-time grid (independent of how step() is called).
    update_period_ns: int = 2_500_000
    gusts: tuple[GustParams, ...] = ()
    #: Dryden turbulence (MIL-F-8785C / MIL-HDBK-1797, hil/plant/dryden.py) instead of the
    #: per-axis Gauss-Markov above: intensities and scale lengths from the 20 ft wind W20 and
    #: the vehicle's height, plus the spatial gradients (p_g, q_g, r_g) that differ from rotor
    #: to rotor and so make moments.
    dryden: bool = False
    #: W20, the mean wind at 20 ft (m/s) that sets the intensities (sigma_w = 0.1 W20).
    #: None: the horizontal speed of ``mean_N_mps``. MIL-F-8785C: light 15 kt (7.7 m/s),
    #: moderate 30 kt, severe 45 kt.
    dryden_w20_mps: float | None = None
    #: The span ``b`` of the rotational-gust filters: rotor tip to rotor tip across the
    #: X frame, 2 x 0.25 m / sqrt(2) between hubs + 2 x 0.1524 m rotor radius = 0.66 m (Table 1).
    dryden_span_m: float = 0.66
    #: The spatial gradients (rotational gusts) on; off leaves a gust uniform over the airframe.
    dryden_gradients: bool = True

    def __post_init__(self) -> None:
        _require(all(s >= 0.0 for s in self.turbulence_sigma_N_mps), "turbulence sigma must be >= 0")
        _require(all(v > 0.0 for v in self.turbulence_length_m), "turbulence lengths must be > 0")
        _require(self.turbulence_min_speed_mps > 0.0, "turbulence_min_speed_mps must be > 0")
        _require(self.update_period_ns > 0, "update_period_ns must be > 0")
        _require(_finite(self.mean_N_mps), "mean wind must be finite")
        _require(self.dryden_span_m > 0.0, "dryden_span_m must be > 0")
        _require(self.dryden_w20_mps is None or self.dryden_w20_mps >= 0.0, "dryden_w20_mps must be >= 0")
        _require(
            not (self.dryden and any(s > 0.0 for s in self.turbulence_sigma_N_mps)),
            "choose one turbulence model: dryden or turbulence_sigma_N_mps",
        )
