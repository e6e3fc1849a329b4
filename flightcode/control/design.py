"""Start-up control design: continuous LQR, zero-order-hold and Van Loan discretization.

All three are ``scipy.linalg`` calls, the same ones python-control's ``lqr`` and
``c2d(method="zoh")`` make here (no slycot installed: ``control.care`` falls back to
``scipy.linalg.solve_continuous_are``) and filterpy's ``van_loan_discretization`` makes.
Importing python-control at start-up cost the flight code 1.6 s on a quiet machine and 4-10 s
on a loaded one (it imports scipy.signal and matplotlib), every flight; importing anything of
filterpy imports all of it (its ``__init__`` loads every subpackage, scipy.stats and
scipy.ndimage among them): 0.9-1.2 s more. The tests check these functions against
python-control and filterpy (tests/unit/flightcode/control/test_design.py).
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


def van_loan(a: np.ndarray, g: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Van Loan's discretization of dx/dt = A x + G w, w unit white noise (C. F. van Loan,
    IEEE TAC 23(3), 1978): (Phi (n, n), Q_d (n, n)) for the period ``t_s`` in s, from the
    exponential of the block matrix [[-A, G G'], [0, A']] t_s, what
    ``filterpy.common.van_loan_discretization`` computes (same operations, same result)."""
    n = a.shape[0]
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -a.dot(t_s)
    block[:n, n:] = g.dot(g.T).dot(t_s)
    block[n:, n:] = a.T.dot(t_s)
    e = expm(block)
    phi = e[n:, n:].T
    return phi, phi.dot(e[:n, n:])
