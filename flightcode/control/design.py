"""Start-up control design: continuous LQR and zero-order-hold discretization.

Both are ``scipy.linalg`` calls, the same ones python-control's ``lqr`` and ``c2d(method="zoh")``
make here (no slycot installed: ``control.care`` falls back to
``scipy.linalg.solve_continuous_are``). Importing python-control at start-up cost the flight
code 1.6 s on a quiet machine and 4-10 s on a loaded one (it imports scipy.signal and
matplotlib), every flight; scipy.linalg is already loaded by filterpy. The tests check both
functions against python-control to 1e-12 (tests/unit/flightcode/control/test_design.py).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigvals, expm, solve, solve_continuous_are


def lqr(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous LQR of dx/dt = A x + B u, cost integral of x'Qx + u'Ru.

    Args: a (n, n), b (n, m), q (n, n) symmetric >= 0, r (m, m) symmetric > 0.
    Returns: (K (m, n) with u = -K x, X (n, n) the Riccati solution, the closed-loop poles
    eig(A - B K) (n,) complex), as ``control.lqr``.
    """
    x = solve_continuous_are(a, b, q, r)
    k = solve(r, b.T @ x)
    return k, x, eigvals(a - b @ k)


def zoh(a: np.ndarray, b: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretization: (A_d (n, n), B_d (n, m)) for the period ``t_s`` in s,
    from the exponential of the block matrix [[A, B], [0, 0]] t_s."""
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n] = a
    block[:n, n:] = b
    phi = expm(block * t_s)
    return phi[:n, :n], phi[:n, n:]
