"""Orbit cases shared by the GVE, Delta-V and Delta-V study tests: states integrated here with scipy
(two-body plus a given acceleration) and the analytic J2 acceleration, independent of lnss_lib's propagator."""

import numpy as np
from scipy.integrate import solve_ivp

from lnss_lib.constants import SECONDS_PER_DAY
from lnss_lib.elements import elements_to_state, orbital_period_s

GM = 4902.7999671


R_REF = 1738.0


J2 = 1.0e-3  # about five times the Moon's, so the drift stands well above finite-difference noise


YEAR_S = 365.25 * SECONDS_PER_DAY


def random_elements(rng, m):
    """Elements [a, e, i, raan, aop, nu] of closed orbits well away from e = 0 and i = 0, pi."""
    return np.column_stack(
        [
            rng.uniform(2500.0, 9000.0, m),
            rng.uniform(0.05, 0.7, m),
            rng.uniform(0.2, np.pi - 0.2, m),
            rng.uniform(0.0, 2 * np.pi, m),
            rng.uniform(0.0, 2 * np.pi, m),
            rng.uniform(0.0, 2 * np.pi, m),
        ]
    )


def state_from_nu(el):
    """State from [a, e, i, raan, aop, nu] (converted through the mean anomaly)."""
    a, e, inc, raan, aop, nu = el
    ecc_anom = 2.0 * np.arctan2(np.sqrt(1 - e) * np.sin(nu / 2), np.sqrt(1 + e) * np.cos(nu / 2))
    mean_anom = ecc_anom - e * np.sin(ecc_anom)
    return elements_to_state(np.array([a, e, inc, raan, aop, mean_anom]), GM)


def j2_acceleration(r_vec):
    """Zonal J2 acceleration (km/s^2), pole along z."""
    x, y, z = r_vec
    r2 = x * x + y * y + z * z
    r = np.sqrt(r2)
    k = -1.5 * J2 * GM * R_REF**2 / r**5
    f = 5.0 * z * z / r2
    return k * np.array([x * (1 - f), y * (1 - f), z * (3 - f)])


def integrate(state0, t_eval, extra):
    """Two-body plus ``extra(state)`` acceleration, DOP853 at tight tolerances; (n, 6) states at t_eval."""

    def rhs(_, y):
        r = y[:3]
        return np.concatenate([y[3:], -GM * r / np.linalg.norm(r) ** 3 + extra(y)])

    sol = solve_ivp(
        rhs, (t_eval[0], t_eval[-1]), state0, method="DOP853", t_eval=t_eval, rtol=1e-12, atol=1e-12
    )
    assert sol.success
    return sol.y.T


def make_j2_arc():
    """Near-circular J2-only arc: a 2500 km, e 0.001, i 60 deg, six orbits sampled every 60 s."""
    el0 = np.array([2500.0, 0.001, np.radians(60.0), 0.4, 0.3, 0.0])
    period = orbital_period_s(el0[0], GM)
    t = np.arange(0.0, 6.0 * period, 60.0)
    states = integrate(elements_to_state(el0, GM), t, lambda y: j2_acceleration(y[:3]))
    return el0, t, states
