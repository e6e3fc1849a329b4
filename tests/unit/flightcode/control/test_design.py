"""The start-up design functions against python-control and filterpy, the references they replace."""

from __future__ import annotations

import control as ct
import numpy as np
from filterpy.common import van_loan_discretization
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.control.design import lqr, van_loan, zoh
from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.control.reference import Prefilter3
from flightcode.estimation.altitude_kf import AltitudeKF


def test_the_paper_lqi_gains_equal_control_lqr() -> None:
    model = AltitudeModel()
    a, b, c = model.state_space()
    a_aug = np.block([[a, np.zeros((3, 1))], [-c, np.zeros((1, 1))]])
    b_aug = np.vstack([b, np.zeros((1, 1))])
    q, r = np.diag([0.0, 0.0, 0.0, 8.25e-3]), np.array([[1.0]])
    k_ref, x_ref, poles_ref = ct.lqr(a_aug, b_aug, q, r)
    k, x, poles = lqr(a_aug, b_aug, q, r)
    np.testing.assert_allclose(k, k_ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(x, x_ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(sorted(poles, key=lambda p: (p.real, p.imag)),
                               sorted(poles_ref, key=lambda p: (p.real, p.imag)), rtol=1e-10)
    ctrl = LqiAltitude(model)
    np.testing.assert_allclose(ctrl.F1, [0.1415, 0.1103, 0.00796], atol=5e-5)  # docs/controllers.md 3.2
    assert abs(ctrl.F2 - -0.0908) < 5e-5


@settings(max_examples=40, deadline=None)
@given(
    m=st.floats(0.5, 3.0), t1=st.floats(0.02, 0.3), q_int=st.floats(1e-4, 1.0), r=st.floats(0.1, 10.0),
    q_z=st.floats(0.0, 1.0),
)
def test_lqr_equals_control_lqr(m: float, t1: float, q_int: float, r: float, q_z: float) -> None:
    model = AltitudeModel(m_kg=m, F_max_N=max(25.0, 2.5 * m * 9.81), T1_s=t1)
    a, b, c = model.state_space()
    a_aug = np.block([[a, np.zeros((3, 1))], [-c, np.zeros((1, 1))]])
    b_aug = np.vstack([b, np.zeros((1, 1))])
    q, rr = np.diag([q_z, 0.0, 0.0, q_int]), np.array([[r]])
    k_ref, _, _ = ct.lqr(a_aug, b_aug, q, rr)
    k, _, _ = lqr(a_aug, b_aug, q, rr)
    np.testing.assert_allclose(k, k_ref, rtol=1e-9, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(w=st.floats(0.5, 50.0), t_s=st.floats(1e-4, 0.05))
def test_zoh_equals_control_c2d(w: float, t_s: float) -> None:
    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(w**3), -3.0 * w**2, -3.0 * w]])
    b = np.array([[0.0], [0.0], [w**3]])
    ref = ct.c2d(ct.ss(a, b, np.eye(3), np.zeros((3, 1))), t_s, method="zoh")
    a_d, b_d = zoh(a, b, t_s)
    np.testing.assert_allclose(a_d, ref.A, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b_d, ref.B, rtol=1e-12, atol=1e-14)


@settings(max_examples=40, deadline=None)
@given(w=st.floats(0.5, 50.0), t_s=st.floats(1e-4, 0.05),
       g_diag=st.lists(st.floats(0.0, 10.0), min_size=3, max_size=3))
def test_van_loan_equals_filterpy(w: float, t_s: float, g_diag: list[float]) -> None:
    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-(w**3), -3.0 * w**2, -3.0 * w]])
    g = np.diag(g_diag)
    phi_ref, q_ref = van_loan_discretization(a, g, t_s)
    phi, q = van_loan(a, g, t_s)
    # the same operations in the same order: the same floats
    np.testing.assert_array_equal(phi, phi_ref)
    np.testing.assert_array_equal(q, q_ref)


def test_the_kf_design_is_filterpys_and_its_filter_a_separate_copy() -> None:
    kf = AltitudeKF(AltitudeModel(), q_a=0.5, q_d=0.05, q_b=1e-6)
    a_c, _ = AltitudeKF.continuous_model(AltitudeModel())
    _, q_ref = van_loan_discretization(a_c, np.diag([0.0, 0.0, 0.5**0.5, 0.05**0.5, 1e-3]), kf.T_s)
    np.testing.assert_array_equal(kf.Q, 0.5 * (q_ref + q_ref.T))
    ref = kf.kf
    assert ref is kf.kf  # built once
    for name in ("F", "B", "H", "Q", "R"):
        np.testing.assert_array_equal(getattr(ref, name), getattr(kf, name))
        assert not np.shares_memory(getattr(ref, name), getattr(kf, name))


def test_the_flight_code_does_not_import_python_control_or_filterpy() -> None:
    """Start-up cost: python-control (with scipy.signal and matplotlib) and filterpy (with
    scipy.stats and scipy.ndimage) are for the tests."""
    import subprocess
    import sys

    code = ("import sys, flightcode.loop; "
            "print(sorted(m for m in sys.modules if m in ('control', 'filterpy', 'scipy.stats', 'scipy.ndimage') "
            "or m.startswith(('control.', 'matplotlib', 'filterpy.'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_kf_and_reference_designs_are_unchanged() -> None:
    kf = AltitudeKF(AltitudeModel())
    a_c, b_c = AltitudeKF.continuous_model(AltitudeModel())
    h = np.array([[1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0, 1.0]])
    ref = ct.c2d(ct.ss(a_c, b_c, h, np.zeros((2, 1))), kf.T_s, method="zoh")
    np.testing.assert_allclose(kf.kf.F, ref.A, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(kf.kf.B, ref.B, rtol=1e-12, atol=1e-15)
    assert Prefilter3(8.0, 0.0025).T_s == 0.0025
