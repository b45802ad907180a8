"""Independent references shared by several test files (written here, not by squealkit)."""

from __future__ import annotations

import math

import numpy as np


def nonlinear_rhs(model, mu, v_reg, speed=0.0):
    """Independent first-order form of the nonlinear contact on a flat disc: N cos(theta) =
    max(0, -kc b.x), friction mu tanh(w / v_reg) N along s f, w = v - s f.x' (paper eqs. 1-3)."""
    Minv = np.linalg.inv(model.mass_matrix())
    C = model.damping_matrix()
    K0 = model.stiffness_parts()[0]
    F0 = model.load_parts()[0]
    b, f = np.array([0.0, 1.0, -1.0]), np.array([-1.0, 0.0, 0.0])
    s, kc = model.sliding, model.kc

    def rhs(t, z):
        x, v = z[:3], z[3:]
        nc = max(0.0, -kc * (b @ x))
        w = speed - s * (f @ v)
        force = F0 - K0 @ x - C @ v + nc * (b + s * mu * math.tanh(w / v_reg) * f)
        return np.concatenate([v, Minv @ force])

    return rhs
