"""ALIP prediction and foot placement (robot/alip.py) against hand-computed cases."""

import math

import numpy as np
import pytest

from emonav_drake.robot.alip import (
    alip_predict,
    foot_placement,
    lateral_momentum_target,
    mean_speed_factor,
    swing_height,
    swing_horizontal,
)
from emonav_drake.robot.lip import foot_offset

M, H, G, T = 46.0, 0.89, 9.81, 0.4


def test_foot_placement_against_a_hand_computed_case():
    # ℓ = √(9.81/0.89) = 3.320011, ℓT = 1.328004, cosh = 2.019255, sinh = 1.754250,
    # mHℓ = 46·0.89·3.320011 = 135.9212.
    # Now: x_c = 0.05 m, ℒ = 10 kg·m²/s, 0.1 s left (ℓτ = 0.332001):
    #   cosh = 1.055620, sinh = 0.338134
    #   x̂_c = 1.055620·0.05 + 0.338134·10/135.9212 = 0.052781 + 0.024877 = 0.077658 m
    #   ℒ̂ = 135.9212·0.338134·0.05 + 1.055620·10 = 2.297979 + 10.556205 = 12.854184
    # Target v = 0.3 m/s at the end of the next step: ℒ_des = 46·0.89·0.3 = 12.282
    #   x_c^des = (12.282 − 2.019255·12.854184)/(135.9212·1.754250)
    #           = −13.673880/238.43981 = −0.057347 m
    #   foot = x̂_c − x_c^des = 0.077658 + 0.057347 = 0.135006 m ahead of the stance foot
    ell = math.sqrt(G / H)
    mhl = M * H * ell
    tau = 0.1
    xe = math.cosh(ell * tau) * 0.05 + math.sinh(ell * tau) * 10 / mhl
    le = mhl * math.sinh(ell * tau) * 0.05 + math.cosh(ell * tau) * 10
    assert xe == pytest.approx(0.077658, abs=2e-6)
    assert le == pytest.approx(12.854184, abs=2e-5)
    xc_des = (M * H * 0.3 - math.cosh(ell * T) * le) / (mhl * math.sinh(ell * T))
    assert xc_des == pytest.approx(-0.057347, abs=2e-6)
    step = foot_placement(0.05, 10.0, tau, M * H * 0.3, M, H, T, G)
    assert step == pytest.approx(0.135006, abs=2e-6)


def test_prediction_matches_integrating_the_alip_ode():
    x, L = np.array([0.03, -0.08]), np.array([12.0, 6.0])
    dt = 1e-5
    xi, Li = x.copy(), L.copy()
    for _ in range(int(0.3 / dt)):
        xi, Li = xi + dt * Li / (M * H), Li + dt * M * G * xi
    xp, Lp = alip_predict(x, L, 0.3, M, H, G)
    np.testing.assert_allclose(xp, xi, rtol=1e-3)
    np.testing.assert_allclose(Lp, Li, rtol=1e-3)


def test_alip_placement_equals_the_papers_eq1_at_a_switch():
    # At a switch (remaining 0) with ℒ = m H v, ALIP places the foot d_k ahead of the CoM.
    omega = math.sqrt(G / H)
    for v, u in [(0.2, 0.4), (0.4, 0.0), (0.1, 0.25)]:
        step = foot_placement(0.0, M * H * v, 0.0, M * H * u, M, H, T, G)
        assert step == pytest.approx(foot_offset(v, u, omega, T), abs=1e-12)


def test_lateral_target_gives_a_periodic_gait_of_width_w():
    W = 0.22
    L_end = lateral_momentum_target(W, True, M, H, T, G)  # the right stance ends moving left
    assert L_end > 0 and lateral_momentum_target(W, False, M, H, T, G) == -L_end
    # Start of a right-stance step: CoM W/2 left of the foot, moving right (−ℒ_end)
    x, L = alip_predict(W / 2, -L_end, T, M, H, G)
    assert x == pytest.approx(W / 2, abs=1e-12) and L == pytest.approx(L_end, abs=1e-9)
    assert 0.8 < mean_speed_factor(math.sqrt(G / H), T) < 0.9


def test_swing_trajectory_lifts_off_and_lands():
    z0, dz0, _ = swing_height(0.0, T, 0.0, 0.08, 0.2)
    zm, dzm, _ = swing_height(T / 2, T, 0.0, 0.08, 0.2)
    z1, dz1, _ = swing_height(T, T, 0.0, 0.08, 0.2)
    assert (z0, dz0) == pytest.approx((0.0, 0.0))
    assert (zm, dzm) == pytest.approx((0.08, 0.0), abs=1e-12)
    assert (z1, dz1) == pytest.approx((0.0, -0.2), abs=1e-12)
    assert swing_height(T + 0.05, T, 0.0, 0.08, 0.2)[0] == pytest.approx(-0.01)
    p, v, _ = swing_horizontal(0.85 * T, T, np.zeros(2), np.array([0.3, -0.2]))
    np.testing.assert_allclose(p, [0.3, -0.2])
    np.testing.assert_allclose(v, 0.0, atol=1e-12)
