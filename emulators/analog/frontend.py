"""The analog chain in front of the MCP3204: sensors, conditioning, pins, faults.

Per sensor signal (baro, accel X/Y/Z): the static transfer (with this unit's errors) is
held between ``update`` calls and drives the sensor's first-order response (1 ms for the
MPX5100AP, the output RC for each ADXL335 axis). Per ADC channel: the conditioning RC
(exact two-stage solution with the sensor stage), sensor noise as an Ornstein-Uhlenbeck
process (its variance reduced by the RC), the gain stage with its rails, then white
electrical noise at the pin. ``volts(channel, t_ns)`` is the MCP3204's sampler.

Determinism: all randomness comes from the one ``rng``; the same sequence of calls gives
the same values. Sensor noise at one instant is shared by repeated samples of that instant;
electrical noise is drawn afresh for every sample. After the sensors' unit draws, normals
come from the rng in blocks (conditioning.NormalStream): the same values in the same order.

Vibration (``set_vibration``): the rotor-imbalance tones at the ADXL335 are added to each
accelerometer channel at its sample instant, through that axis' output RC and the channel's
conditioning RC as their exact steady-state response (emulators/vibration.py): a 97 Hz tone
through the 50 Hz pole of a 0.1 uF capacitor keeps 46 % of its amplitude and lags 63 deg.
They scale with the unit's sensitivity and cross-axis terms like the static part; the
output swing is not applied to them (a few LSB against a 1.5 V margin).

Speed (this runs every tick and inside every ADC transaction): plain floats except for the
ADXL335's two 3x3 matrix products, which stay numpy's (BLAS may fuse multiply-adds, so a
scalar rewrite would not give the same bits); the filter exponentials are computed once per
step length.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from mypy_extensions import mypyc_attr

from emulators.analog.adxl335 import Adxl335
from emulators.analog.conditioning import (
    NormalStream,
    OuNoise,
    TwoStageStep,
    amplify,
    filtered_noise,
    tau_from_cutoff_s,
    two_stage,
)
from emulators.analog.mpx5100ap import Mpx5100ap
from emulators.analog.params import G0_MPS2, P_SEA_LEVEL_PA, AnalogParams
from emulators.vibration import Tone

SIGNALS = ("baro", "accel_x", "accel_y", "accel_z")
N_CHANNELS = 4


@dataclass(frozen=True)
class BaroFault:
    """p_sensed = p * scale + bias_Pa; sensor noise x noise_factor; frozen holds the output;
    port_blocked holds p, the pressure at the port, at its value when the port was blocked
    (the sensor and its noise go on)."""

    bias_Pa: float = 0.0
    scale: float = 1.0
    noise_factor: float = 1.0
    frozen: bool = False
    port_blocked: bool = False


@dataclass(frozen=True)
class AccelFault:
    """f_sensed = f_B * scale + bias (body axes, m/s^2); saturate pins each axis to a rail."""

    bias_mps2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float = 1.0
    noise_factor: float = 1.0
    frozen: bool = False
    saturate: bool = False


@mypyc_attr(allow_interpreted_subclasses=True)
class AnalogFrontEnd:
    """Sensors and conditioning for the four MCP3204 inputs."""

    def __init__(self, params: AnalogParams, rng: np.random.Generator) -> None:
        self.params = params
        self.counters: Counter[str] = Counter()
        self._rng = rng
        self.baro = Mpx5100ap(params.baro, rng)
        self.accel = Adxl335(params.accel, rng)
        self._tau_sensor = (self.baro.tau_s, *self.accel.tau_s)
        sensor_sigma = (self.baro.noise_V_rms, *self.accel.noise_V_rms)
        self._sig = [None if s == "none" else SIGNALS.index(s) for s in params.channel_map]
        self._tau_rc = [tau_from_cutoff_s(c.rc_cutoff_Hz) for c in params.conditioning]
        #: every normal drawn after the sensors' unit draws above, in draw order
        self._normals = NormalStream(rng)
        self._noise: list[OuNoise] = []
        for ch, sig in enumerate(self._sig):
            sigma, tau = (0.0, 0.0) if sig is None else filtered_noise(
                sensor_sigma[sig], self._tau_sensor[sig], self._tau_rc[ch]
            )
            self._noise.append(OuNoise(sigma, tau, self._normals))
        self._wired = tuple((ch, sig) for ch, sig in enumerate(self._sig) if sig is not None)
        self._steps_dt_ns: int | None = None  # step length the cached filter steps are for
        self._steps_rc: dict[int, TwoStageStep] = {}  # per wired channel: sensor + RC stages
        self._steps_sensor: tuple[TwoStageStep, ...] = ()  # per signal: the sensor stage
        self.baro_fault = BaroFault()
        self.accel_fault = AccelFault()
        self._p_last_Pa = P_SEA_LEVEL_PA  # the port's pressure at the last update
        self._p_trapped_Pa: float | None = None  # held while the port is blocked
        self._stuck: list[float | None] = [None] * N_CHANNELS
        self._open = [False] * N_CHANNELS
        self._open_from: list[tuple[int, float] | None] = [None] * N_CHANNELS  # (t_ns, V) drift start
        self._frozen: list[float | None] = [None] * N_CHANNELS
        # Until the first update the chain rests at sea level, level, 25 C.
        self._t_ns: int | None = None
        self._init_state(self._static(P_SEA_LEVEL_PA, (0.0, 0.0, -G0_MPS2), 25.0))
        # Vibration: volts per m/s^2 from body axes to each sensor axis (the linear part of
        # static_V), and per wired accel channel its tones as (omega, phase, real and
        # imaginary volts after the sensor and conditioning RCs), referred to _vib_t_ns.
        self._vib_V_per_mps2 = (
            (self.accel.sensitivity_V_per_g[:, None] * (self.accel.cross_axis @ self.accel.R_SB)) / G0_MPS2
        ).tolist()
        self._vib: dict[int, list[tuple[float, float, float, float]]] = {}
        self._vib_t_ns = 0

    # -- dynamics ----------------------------------------------------------------------
    def update(self, t_ns: int, p_Pa: float, f_B_mps2: Sequence[float], T_C: float) -> None:
        """Advance to ``t_ns`` with these inputs held since the previous update.

        ``p_Pa`` static pressure at the sensor port, ``f_B_mps2`` specific force in body
        axes (FRD, m/s^2, (0, 0, -9.81) at rest), ``T_C`` sensor temperature.
        """
        self._p_last_Pa = p_Pa
        u = self._static(p_Pa, f_B_mps2, T_C)
        if self._t_ns is None:
            self._init_state(u)
            self._t_ns = t_ns
            return
        if t_ns < self._t_ns:
            self.counters["update_backwards"] += 1
            return
        dt_ns = t_ns - self._t_ns
        if dt_ns != self._steps_dt_ns:
            dt_s = dt_ns * 1e-9
            tau = self._tau_sensor
            self._steps_rc = {ch: TwoStageStep(tau[sig], self._tau_rc[ch], dt_s) for ch, sig in self._wired}
            self._steps_sensor = tuple(TwoStageStep(tau[sig], 0.0, dt_s) for sig in range(4))  # first_order
            self._steps_dt_ns = dt_ns
        x1, x2, steps = self._x1, self._x2, self._steps_rc
        for ch, sig in self._wired:
            x2[ch] = steps[ch].apply(x1[sig], x2[ch], u[sig])
        for sig, step in enumerate(self._steps_sensor):
            x1[sig] = step.apply(x1[sig], 0.0, u[sig])
        self._u = u
        self._t_ns = t_ns

    def set_vibration(self, t_ns: int, tones: Sequence[Tone]) -> None:
        """Rotor vibration at the ADXL335 from now on: ``tones`` of specific force in body
        FRD axes, m/s^2, referred to ``t_ns`` (emulators/vibration.py); () for none. Each
        accelerometer channel adds them, through its RCs, at its sample instants."""
        self._vib_t_ns = t_ns
        if not tones:
            if self._vib:
                self._vib = {}
            return
        vib: dict[int, list[tuple[float, float, float, float]]] = {}
        for ch, sig in self._wired:
            if sig == 0:
                continue
            row = self._vib_V_per_mps2[sig - 1]
            tau_s, tau_rc = self._tau_sensor[sig], self._tau_rc[ch]
            out = []
            for tone in tones:
                w, re, im = tone.omega_radps, tone.re, tone.im
                a = row[0] * re[0] + row[1] * re[1] + row[2] * re[2]
                b = row[0] * im[0] + row[1] * im[1] + row[2] * im[2]
                # (a + j b) / ((1 + j w tau_s)(1 + j w tau_rc)): the sensor's RC, then the
                # channel's, with the denominator as p + j q (floats: native when compiled)
                x, y = w * tau_s, w * tau_rc
                p, q = 1.0 - x * y, x + y
                n = p * p + q * q
                out.append((w, tone.phase_rad, (a * p + b * q) / n, (b * p - a * q) / n))
            vib[ch] = out
        self._vib = vib

    def _vibration_V(self, ch: int, t_ns: int) -> float:
        tones = self._vib.get(ch)
        if not tones or self.accel_fault.saturate:
            return 0.0
        dt_s = (t_ns - self._vib_t_ns) * 1e-9
        v = 0.0
        for w, phase, cr, ci in tones:
            phi = phase + w * dt_s
            v += cr * math.cos(phi) - ci * math.sin(phi)
        return v * self.accel_fault.scale

    def volts(self, channel: int, t_ns: int) -> float:
        """Voltage at ADC input ``channel`` (0..3) at ``t_ns``, noise included."""
        if not 0 <= channel < N_CHANNELS:
            self.counters["bad_channel"] += 1
            return 0.0
        self.counters["samples"] += 1
        stuck = self._stuck[channel]
        if stuck is not None:
            v = stuck
        elif self._open[channel] or self._sig[channel] is None:
            v = self._floating(channel, t_ns)
        else:
            cond = self.params.conditioning[channel]
            v = amplify(self._sensor_V(channel, t_ns), cond)
            v += cond.noise_V_rms * self._normals.standard_normal()
        return v

    @property
    def latched_V(self) -> tuple[float, ...]:
        """Noise-free, vibration-free pin voltages at the last update (for the recorder)."""
        return tuple(
            0.0 if sig is None else amplify(self._x2[ch], self.params.conditioning[ch])
            for ch, sig in enumerate(self._sig)
        )

    # -- faults --------------------------------------------------------------------------
    def set_channel_stuck(self, ch: int, volts: float | None) -> None:
        """Force input ``ch`` to ``volts`` (None releases it)."""
        self._stuck[ch] = volts

    def set_channel_open(self, ch: int, open: bool) -> None:
        """Disconnect input ``ch``: from its next sample on it drifts from the connected
        (noise-free) voltage to the open level."""
        self._open[ch] = open
        self._open_from[ch] = None

    def set_baro_fault(
        self, bias_Pa: float = 0.0, scale: float = 1.0, noise_factor: float = 1.0, frozen: bool = False,
        port_blocked: bool = False,
    ) -> None:
        """Barometer fault, from the next update (frozen: output held from the next sample;
        port_blocked: the port's pressure held at the last update's)."""
        self.baro_fault = BaroFault(bias_Pa, scale, noise_factor, frozen, port_blocked)
        if not port_blocked:
            self._p_trapped_Pa = None
        elif self._p_trapped_Pa is None:
            self._p_trapped_Pa = self._p_last_Pa
        self._unfreeze(0, frozen)

    def set_accel_fault(
        self,
        bias_mps2: tuple[float, float, float] = (0.0, 0.0, 0.0),
        scale: float = 1.0,
        noise_factor: float = 1.0,
        frozen: bool = False,
        saturate: bool = False,
    ) -> None:
        """Accelerometer fault (all axes), from the next update."""
        bias = (float(bias_mps2[0]), float(bias_mps2[1]), float(bias_mps2[2]))
        self.accel_fault = AccelFault(bias, scale, noise_factor, frozen, saturate)
        for sig in (1, 2, 3):
            self._unfreeze(sig, frozen)

    # -- internals -------------------------------------------------------------------------
    def _init_state(self, u: list[float]) -> None:
        self._u = list(u)
        self._x1: list[float] = list(u)  # sensor stage per signal, V
        self._x2: list[float] = [0.0 if sig is None else u[sig] for sig in self._sig]  # pin node per channel

    def _static(self, p_Pa: float, f_B_mps2: Sequence[float], T_C: float) -> list[float]:
        bf, af = self.baro_fault, self.accel_fault
        if self._p_trapped_Pa is not None:
            p_Pa = self._p_trapped_Pa
        baro_V = self.baro.static_V(p_Pa * bf.scale + bf.bias_Pa, T_C)
        scale, bias = af.scale, af.bias_mps2
        f = (float(f_B_mps2[0]) * scale + bias[0], float(f_B_mps2[1]) * scale + bias[1],
             float(f_B_mps2[2]) * scale + bias[2])
        acc_V = self.accel.static_V_floats(f, T_C)
        if af.saturate:
            lo, hi = self.accel.swing_V
            half = self.params.accel.supply_V / 2.0
            mid = [half + o for o in self.accel.zero_g_offset_V.tolist()]
            return [baro_V, *(hi if v >= m else lo for v, m in zip(acc_V, mid, strict=True))]
        return [baro_V, *acc_V]

    def _sensor_V(self, ch: int, t_ns: int) -> float:
        sig = self._sig[ch]
        assert sig is not None
        frozen = self.baro_fault.frozen if sig == 0 else self.accel_fault.frozen
        if frozen and self._frozen[ch] is not None:
            return self._frozen[ch]  # type: ignore[return-value]
        x2 = self._x2[ch]
        t_state = self._t_ns if self._t_ns is not None else t_ns
        if t_ns > t_state:  # inputs held since the last update
            dt_s = (t_ns - t_state) * 1e-9
            x2 = two_stage(self._x1[sig], x2, self._u[sig], self._tau_sensor[sig], self._tau_rc[ch], dt_s)
        elif t_ns < t_state:
            self.counters["sample_before_update"] += 1
        factor = self.baro_fault.noise_factor if sig == 0 else self.accel_fault.noise_factor
        if self._vib:
            x2 += self._vibration_V(ch, t_ns)
        v = x2 + self._noise[ch].at(t_ns, factor)
        if frozen:
            self._frozen[ch] = v
        return v

    def _unfreeze(self, sig: int, frozen: bool) -> None:
        if not frozen:
            for ch, s in enumerate(self._sig):
                if s == sig:
                    self._frozen[ch] = None

    def _floating(self, ch: int, t_ns: int) -> float:
        p = self.params
        start = self._open_from[ch]
        if start is None:
            start = self._open_from[ch] = (t_ns, self.latched_V[ch])  # the node's voltage when cut
        t0, v0 = start
        dt_s = max(0, t_ns - t0) * 1e-9
        level = p.open_input_level_V
        v = level + (v0 - level) * (math.exp(-dt_s / p.open_input_tau_s) if p.open_input_tau_s > 0 else 0.0)
        return v + p.open_input_noise_V_rms * self._normals.standard_normal()
