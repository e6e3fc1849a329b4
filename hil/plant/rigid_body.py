"""Mass properties of the airframe and its payload (paper Eq. 3.1-3.3 need m, J and the CG).

The integrated equations (``dynamics.py``) are Newton-Euler about the CG::

    m dv/dt = R(q) F_B + m g e_z                 (NED, v of the CG)
    J dw/dt = M_B - w x (J w + h_rotors)          (body FRD, about the CG)

so every change of mass moves the CG and changes J about it. A payload is a point mass
(plus its own principal inertia, if given) at ``r_B_m`` from the body origin; the composite
inertia about the new CG follows from the parallel-axis theorem,
``J_c = sum_k (J_k + m_k (|d_k|^2 I - d_k d_k^T))`` with ``d_k`` from the new CG to part k.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hil.plant.params_vehicle import BodyParams

Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), CG from the body origin (body FRD, m), inertia tensor about the CG (kg m^2)."""

    mass_kg: float
    cg_B_m: Vec3
    inertia_B_kgm2: Mat3

    @property
    def inverse_inertia(self) -> Mat3:
        """J^-1 (1/(kg m^2))."""
        return inverse3(self.inertia_B_kgm2)


def base_mass_properties(body: BodyParams) -> MassProperties:
    """The empty vehicle's mass properties from its parameters."""
    jxx, jyy, jzz = body.inertia_B_kgm2
    jxy, jxz, jyz = body.inertia_offdiag_B_kgm2
    j = ((jxx, jxy, jxz), (jxy, jyy, jyz), (jxz, jyz, jzz))
    inverse3(j)  # fail early on a singular tensor
    return MassProperties(body.mass_kg, body.cg_B_m, j)


def with_payload(
    base: MassProperties,
    extra_mass_kg: float,
    r_B_m: Vec3,
    extra_inertia_kgm2: Vec3 | None = None,
) -> MassProperties:
    """Composite of ``base`` and a payload at ``r_B_m`` (principal inertia about its own CG)."""
    if not (extra_mass_kg >= 0.0 and math.isfinite(extra_mass_kg)):
        raise ValueError("extra_mass_kg must be finite and >= 0")
    if extra_mass_kg == 0.0:
        return base
    m0, c0 = base.mass_kg, base.cg_B_m
    m = m0 + extra_mass_kg
    c = tuple((m0 * c0[i] + extra_mass_kg * r_B_m[i]) / m for i in range(3))
    jp = extra_inertia_kgm2 or (0.0, 0.0, 0.0)
    j = [list(row) for row in base.inertia_B_kgm2]
    for i in range(3):
        j[i][i] += jp[i]
    _add_parallel_axis(j, m0, tuple(c0[i] - c[i] for i in range(3)))  # type: ignore[arg-type]
    _add_parallel_axis(j, extra_mass_kg, tuple(r_B_m[i] - c[i] for i in range(3)))  # type: ignore[arg-type]
    jt: Mat3 = (
        (j[0][0], j[0][1], j[0][2]),
        (j[1][0], j[1][1], j[1][2]),
        (j[2][0], j[2][1], j[2][2]),
    )
    inverse3(jt)
    return MassProperties(m, (c[0], c[1], c[2]), jt)


def _add_parallel_axis(j: list[list[float]], m: float, d: Vec3) -> None:
    d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    for a in range(3):
        for b in range(3):
            j[a][b] += m * ((d2 if a == b else 0.0) - d[a] * d[b])


def inverse3(m: Mat3) -> Mat3:
    """Inverse of a 3x3 matrix; ValueError if (numerically) singular."""
    (a, b, c), (d, e, f), (g, h, i) = m
    co00, co01, co02 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * co00 + b * co01 + c * co02
    scale = max(abs(x) for row in m for x in row)
    if not math.isfinite(det) or abs(det) <= 1e-12 * scale**3:
        raise ValueError(f"singular inertia tensor {m}")
    inv = 1.0 / det
    return (
        (co00 * inv, (c * h - b * i) * inv, (b * f - c * e) * inv),
        (co01 * inv, (a * i - c * g) * inv, (c * d - a * f) * inv),
        (co02 * inv, (b * g - a * h) * inv, (a * e - b * d) * inv),
    )
