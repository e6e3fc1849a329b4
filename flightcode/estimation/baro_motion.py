"""Does the barometer move with the vehicle? Its height change against the accelerometers'.

A blocked static port (water, an insect, tape left on after washing) traps the air the
sensor sees: its readings go on moving by the sensor's own noise, at a believable pressure,
so no range, step or flat-line test refuses them (:mod:`flightcode.estimation.plausibility`).
In a hover that is harmless. In a climb the altitude filter holds the height near the
trapped level while the vehicle rises, and the altitude loop climbs on without end.

What gives it away is that the barometer does not move when the vehicle does. Over a sliding
window of ``window_s``, judged at the end of every block of ``block_s``, the check compares
two height changes between the window's first and last blocks:

* the barometer's: the difference of the two blocks' mean barometric altitudes (one
  reading's 0.44 m of noise averages to about 0.06 m over the 100 readings of a 0.25 s
  block);
* the inertial one: the vertical acceleration integrated twice over the same samples,
  started at the end of the first block from the estimator's vertical velocity there (the
  only thing it takes from the estimator, which fused the barometer up to then).

When they differ by more than ``max_m`` the barometer does not measure the vehicle's height
(:attr:`BaroMotionCheck.refusing`): its readings are refused, and the estimate is moved to
the inertial height and velocity at the end of the window (:meth:`BaroMotionCheck.take_reanchor`),
from which the estimator carries on on the accelerometer alone. The barometer is taken back
when a whole window agrees again and its level is within ``max_m`` of the estimate: a port
that stays blocked at a level the vehicle has left is not taken back, one that clears is.

What the check leaves to others: an outlier or a level step is the estimator's gate's
(``kf.baro_gate_*``), so a block holding a reading the gate refused is dropped
(:meth:`BaroMotionCheck.reading_rejected`); a block with fewer than half its readings (the
ADC resyncing, a flat line refused) is dropped too, and the window starts again after it:
nothing is judged until it holds a whole window again. A block closes at the sample after
its last, once the gate has judged that last reading.

Error budget of one window (1.5 s; docs/flightcode.md "The barometer against the
accelerometers"): the estimator's velocity at the window's start (0.1 m/s in steady flight,
0.3 m/s in the hardest manoeuvres of the suite: up to 0.45 m), the accelerometer's residual
offset after the boot calibration (0.05 m/s^2: 0.06 m), the ADXL335's 10 % sensitivity
tolerance (10 % of the height change), two block means of the barometer (2 x 0.06 m).

Judged only while flying clear of the ground, as the loop says (the controllers fly and the
estimate is above ``kf.ground_effect_alt_m``, where rotor wash moves the static pressure by
up to 0.9 m and a touchdown saturates the accelerometer), and only from one window after the
estimate left the ground effect (below it the estimator fuses a barometer it distrusts, and
its velocity is not yet worth starting from). Pure: no I/O, no clock; times are sensor time.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import dataclass


@dataclass(frozen=True)
class _Block:
    """One block: means over its samples with a barometer reading, and its end state.

    Means: sensor time ``t_s`` (s since the check's restart), the barometric altitude
    ``baro_m``, the inertial double integral ``z_in_m`` and the estimate ``z_hat_m`` (m). End
    state: the time, the inertial integral's height and velocity, the estimator's height and
    velocity.
    """

    t_s: float
    baro_m: float
    z_in_m: float
    z_hat_m: float
    t_end_s: float
    z_in_end_m: float
    v_in_end_mps: float
    z_hat_end_m: float
    vz_hat_end_mps: float


class BaroMotionCheck:
    """Feed :meth:`add` once per sample; ``refusing`` says whether to fuse the barometer.

    Args:
        window_s: the window over which the height changes are compared, s (a whole number
            of blocks, at least two).
        block_s: the blocks whose means are compared at the window's ends, s.
        max_m: the largest believable disagreement of the two height changes (and, to take
            the barometer back, of its level and the estimate), m.

    Counters: ``windows`` (judged), ``disagreements`` (refusals started), ``taken_back``.
    ``worst_m`` is the largest disagreement of a window judged while the barometer was
    believed (the margin against ``max_m``; :meth:`take_worst` reads and clears it).
    """

    def __init__(self, window_s: float = 1.5, block_s: float = 0.25, max_m: float = 1.5) -> None:
        if not (math.isfinite(block_s) and block_s > 0.0):
            raise ValueError(f"block_s must be finite and > 0, got {block_s}")
        if not (math.isfinite(window_s) and window_s >= 2 * block_s):
            raise ValueError(f"window_s must be at least two blocks ({2 * block_s} s), got {window_s}")
        if not (math.isfinite(max_m) and max_m > 0.0):
            raise ValueError(f"max_m must be finite and > 0, got {max_m}")
        self.block_s = float(block_s)
        self.max_m = float(max_m)
        self._blocks_back = round(window_s / block_s)
        self._ring: deque[_Block] = deque(maxlen=self._blocks_back + 1)
        self.counters: Counter[str] = Counter()
        #: True while the barometer's motion disagrees with the vehicle's: do not fuse it.
        self.refusing = False
        self.worst_m = 0.0
        self._reanchor: tuple[float, float] | None = None
        self._a_last: float | None = None
        self._restart()

    def _restart(self) -> None:
        """Forget the window: the next judged sample starts the integrals and a block."""
        self._ring.clear()
        self._blocks = 0  # blocks closed since the restart
        self._v = 0.0  # inertial velocity since the restart, m/s
        self._z = 0.0  # inertial height since the restart, m
        self._t_s = 0.0  # sensor time since the restart, s (0: nothing judged since)
        self._block_end_s = self.block_s
        self._open_block()

    def _open_block(self) -> None:
        self._m = 0  # samples in the block
        self._n = 0  # of them with a barometer reading
        self._tainted = False  # one of its readings was an outlier to the estimator's gate
        self._st = self._sb = self._sz = self._shat = 0.0
        #: the estimator's (height m, velocity m/s) at the block's last sample, once it is full:
        #: the block closes at the next sample, after the gate has judged that last reading
        self._full: tuple[float, float] | None = None

    def add(self, dt_s: float, z_baro_m: float | None, a_up_mps2: float | None, z_hat_m: float,
            vz_hat_mps: float, judging: bool) -> bool:
        """Take one sample; True if its barometer reading must not be fused.

        Args:
            dt_s: sensor time since the previous sample, s.
            z_baro_m: barometric altitude, m up (None: no reading this sample).
            a_up_mps2: vertical acceleration, m/s^2 up (None: no believable reading this
                sample; the last one is held).
            z_hat_m, vz_hat_mps: the estimator's height (m) and vertical velocity (m/s) before
                this sample's update.
            judging: whether the vehicle flies clear of the ground (see the module docstring).
        """
        if a_up_mps2 is not None and math.isfinite(a_up_mps2):
            self._a_last = a_up_mps2
        a = self._a_last
        if not judging or a is None or not (math.isfinite(dt_s) and dt_s > 0.0):
            if self._t_s > 0.0:
                self._restart()
            return self.refusing
        if self._full is not None:
            self._close_block(*self._full)
        # the integrals are taken exactly at each sample (the same for both ends of a window)
        t = self._t_s = self._t_s + dt_s
        z = self._z = self._z + self._v * dt_s + 0.5 * a * dt_s * dt_s
        self._v += a * dt_s
        self._m += 1
        if z_baro_m is not None and math.isfinite(z_baro_m):
            self._n += 1
            self._st += t
            self._sb += z_baro_m
            self._sz += z
            self._shat += z_hat_m
        if t >= self._block_end_s:
            self._full = (z_hat_m, vz_hat_mps)
        return self.refusing

    def reading_rejected(self) -> None:
        """The estimator's own gate refused this sample's reading as an outlier (a spike, the
        first second of a level shift): the gate deals with those, and a window that holds
        one would judge the outlier, not the barometer's motion. The block is dropped."""
        self._tainted = True

    def _close_block(self, z_hat_m: float, vz_hat_mps: float) -> None:
        self._block_end_s += self.block_s
        n = self._n
        if 2 * n < self._m or self._tainted:
            self._ring.clear()  # a gap: the window starts again after it
            self._open_block()
            return
        block = _Block(self._st / n, self._sb / n, self._sz / n, self._shat / n, self._t_s, self._z, self._v,
                       z_hat_m, vz_hat_mps)
        self._open_block()
        self._ring.append(block)
        self._blocks += 1
        # a whole window since the last gap, and the estimator's velocity trusted from one
        # window after the estimate left the ground effect (see the module docstring)
        if len(self._ring) > self._blocks_back and self._blocks > 2 * self._blocks_back:
            self._judge(self._ring[0], block)

    def _judge(self, first: _Block, last: _Block) -> None:
        """Compare the height changes from ``first`` to ``last``; refuse, or take back."""
        self.counters["windows"] += 1
        # the inertial height from the end of the first block, started at the estimator's
        # velocity there: h(t) = z(t) - z(t0) - (v(t0) - vz_hat(t0)) (t - t0)
        slip = first.v_in_end_mps - first.vz_hat_end_mps
        d_inertial = (last.z_in_m - first.z_in_m) - slip * (last.t_s - first.t_s)
        disagreement = abs((last.baro_m - first.baro_m) - d_inertial)
        if not self.refusing:
            self.worst_m = max(self.worst_m, disagreement)
            if disagreement > self.max_m:
                self.refusing = True
                self.counters["disagreements"] += 1
                h_end = (last.z_in_end_m - first.z_in_end_m) - slip * (last.t_end_s - first.t_end_s)
                self._reanchor = (first.z_hat_end_m + h_end,
                                  first.vz_hat_end_mps + last.v_in_end_mps - first.v_in_end_mps)
        elif disagreement <= self.max_m and abs(last.baro_m - last.z_hat_m) <= self.max_m:
            self.refusing = False
            self.counters["taken_back"] += 1

    def take_reanchor(self) -> tuple[float, float] | None:
        """(height m, vertical velocity m/s) the estimate must move to, once, when a refusal
        starts: the inertial height and velocity at the end of the window; else None."""
        out, self._reanchor = self._reanchor, None
        return out

    def take_worst(self) -> float:
        """The largest disagreement judged since the last call, m (the stats line's margin)."""
        out, self.worst_m = self.worst_m, 0.0
        return out

    def on_ground(self) -> None:
        """The controllers are off (on the ground): the barometer is the only height reference
        there, so a refusal ends, and the window starts again."""
        self.refusing = False
        self._reanchor = None
        if self._t_s > 0.0:
            self._restart()
