import math

import numpy as np
import pytest

from emonav_drake.robot.lip import LipState, lip_in_step, lip_step, lip_velocity, wrap_angle

OMEGA = math.sqrt(9.81 / 1.02)
T = 0.4


def test_eq1_against_a_hand_computed_step():
    # v_k = 0.2 m/s, u_v = 0.4 m/s, ω = √(9.81/1.02) = 3.101233, ωT = 1.240493
    # cosh(ωT) = 1.873280, sinh(ωT) = 1.584038
    # d = (0.2·1.873280 − 0.4)/(3.101233·1.584038) = −0.0051591 m (foot behind the CoM)
    # Δx = 0.2·1.584038/3.101233 + d·(1 − 1.873280) = 0.1021554 + 0.0045054 = 0.1066607 m
    s = lip_step(LipState(1.0, 2.0, 0.0, 0.2), 0.4, 0.0, OMEGA, T)
    assert s.x == pytest.approx(1.0 + 0.1066607, abs=1e-6)
    assert s.y == pytest.approx(2.0)
    assert s.speed == 0.4  # the LIP reaches the commanded speed at the next switch


def test_heading_turns_at_the_switch_and_the_step_follows_it():
    s0 = LipState(0.0, 0.0, 0.1, 0.3)
    s1 = lip_step(s0, 0.3, 0.2, OMEGA, T)
    assert s1.heading == pytest.approx(0.3)
    dx = math.hypot(s1.x, s1.y)
    assert math.atan2(s1.y, s1.x) == pytest.approx(0.3)
    # constant speed: Δx = v sinh/ω + d(1 − cosh) with d = v(cosh − 1)/(ω sinh)
    ch, sh = math.cosh(OMEGA * T), math.sinh(OMEGA * T)
    d = 0.3 * (ch - 1) / (OMEGA * sh)
    assert dx == pytest.approx(0.3 * sh / OMEGA + d * (1 - ch))


def test_in_step_trajectory_is_continuous_and_ends_at_the_step():
    s0 = LipState(0.5, -0.2, 0.4, 0.1)
    end = lip_step(s0, 0.35, -0.15, OMEGA, T)
    at_end = lip_in_step(s0, 0.35, -0.15, OMEGA, T, T)
    assert np.allclose(at_end, end, atol=1e-12)
    start = lip_in_step(s0, 0.35, -0.15, OMEGA, T, 0.0)
    assert (start.x, start.y, start.speed) == pytest.approx((0.5, -0.2, 0.1))
    # velocity is the derivative of position
    h = 1e-6
    a, b = (
        lip_in_step(s0, 0.35, -0.15, OMEGA, T, 0.2),
        lip_in_step(s0, 0.35, -0.15, OMEGA, T, 0.2 + h),
    )
    assert np.allclose((np.array(b[:2]) - a[:2]) / h, lip_velocity(a), atol=1e-5)
    with pytest.raises(ValueError, match="outside the step"):
        lip_in_step(s0, 0.35, 0.0, OMEGA, T, 0.5)


def test_wrap_angle():
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-0.1) == pytest.approx(-0.1)
