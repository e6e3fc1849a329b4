"""Ground contact as a two-mode constraint: resting (held) or flying (integrated).

Theory of operation. The field is a level plane; the vehicle stands on its landing gear,
which puts the body origin ``gear_depth_m`` above the surface; that resting height is
altitude ``h = 0`` (``h = -p_N[2]`` of the body origin).

* **Resting**: position, attitude (level, heading kept) and zero velocities are held
  exactly, so a vehicle on the ground never jitters; only the rotors spin up or down. Each
  sub-step the plant evaluates the free-flight acceleration at the resting state; when its
  vertical component points up (thrust, with ground effect, exceeds weight) it lifts off.
* **Flying**: RK4. After each sub-step, if the body origin is below its resting height the
  vehicle lands: height clamped to 0, velocities and rates zeroed (an inelastic touchdown,
  friction stops sliding), attitude levelled with the heading kept. The contact is recorded
  (speed, tilt) so scenarios can judge hard landings; nothing can pass below the ground.

Contact uses the level-gear approximation (height of the body origin, not of the lowest
foot of a tilted vehicle) and differential thrust does not tip a resting vehicle over;
both are deliberate simplifications for a bench whose subject is flight control.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hil.plant import quat

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Touchdown:
    """One landing: sim time (ns), vertical speed (m/s, down positive), horizontal speed
    (m/s) and tilt of z_B from the vertical (rad) at the instant of contact."""

    t_ns: int
    v_down_mps: float
    v_horizontal_mps: float
    tilt_rad: float


def origin_height_m(x: list[float], cg_B_m: Vec3) -> float:
    """Altitude of the body origin (m) for a state whose position is the CG's."""
    qw, qx, qy, qz = x[6], x[7], x[8], x[9]
    # z_N component of R(q) c: third row of R times c.
    rc_z = (
        2.0 * (qx * qz - qw * qy) * cg_B_m[0]
        + 2.0 * (qy * qz + qw * qx) * cg_B_m[1]
        + (1.0 - 2.0 * (qx * qx + qy * qy)) * cg_B_m[2]
    )
    return rc_z - x[2]


def rest(x: list[float], cg_B_m: Vec3) -> None:
    """Put ``x`` (in place) at rest on the ground below/at its body origin, level, same heading."""
    q = (x[6], x[7], x[8], x[9])
    rc = quat.rotate(q, cg_B_m)
    origin_n, origin_e = x[0] - rc[0], x[1] - rc[1]
    level = quat.yaw_only(q)
    rl = quat.rotate(level, cg_B_m)
    x[0], x[1], x[2] = origin_n + rl[0], origin_e + rl[1], rl[2]
    x[3] = x[4] = x[5] = 0.0
    x[6], x[7], x[8], x[9] = level
    x[10] = x[11] = x[12] = 0.0


def touchdown_record(x: list[float], t_ns: int) -> Touchdown:
    """Describe the contact of state ``x`` (before it is put at rest)."""
    qx, qy = x[7], x[8]
    cos_tilt = 1.0 - 2.0 * (qx * qx + qy * qy)
    return Touchdown(
        t_ns=t_ns,
        v_down_mps=x[5],
        v_horizontal_mps=math.hypot(x[3], x[4]),
        tilt_rad=math.acos(max(-1.0, min(1.0, cos_tilt))),
    )
