"""The Moon orbital-plane element frame ``moon_op`` (Ely 2005, pp. 303-304; LuPNT ``MOON_OP``).

Construction at an epoch t, from the Earth's geometric state relative to the Moon in J2000 (DE421
through SPICE) and the lunar pole:

- z = unit(r_E x v_E): normal of the Earth's instantaneous (osculating) orbit about the Moon, which
  is the normal of the Moon's orbit about the Earth;
- x = unit(p x z), p = z-axis of ``MOON_ME`` in J2000: x lies along the intersection of the lunar
  equator and the Earth's apparent orbit plane (the node of the orbit on the lunar equator);
- y = z x x.

The axes are frozen at the epoch: elements in ``moon_op`` are Keplerian elements of the Cartesian
state expressed in these fixed axes. Ely (2005) takes p as the IAU Moon pole (Seidelmann et al.
2002, ``IAU_MOON`` in ``pck00010.tpc``); LuPNT, whose authors' group published the Bhamidipati et
al. (2023) OP-frame constellations, takes the ``MOON_ME`` z-axis (DE421 librations). The default
here is LuPNT's; :func:`moon_op_to_j2000` accepts ``pole_frame="IAU_MOON"`` for Ely's choice, and
tests/test_moon_op.py bounds the difference (the IAU model carries the main libration terms of the
pole: the poles agree to a few thousandths of a degree, and the node x, which the 6.7 deg angle
between pole and orbit normal amplifies about 9 times, to about 0.03 deg).

Physics check: the Moon's orbit is inclined about 5.145 deg to the ecliptic and the lunar equator
about 1.543 deg to it on the opposite side (Cassini's laws), so z lies about 5.1 deg from the
ecliptic pole and about 6.7 deg from the lunar pole, varying by a few tenths of a degree with the
solar perturbation of the osculating orbit.
"""

from __future__ import annotations

import numpy as np

from .ephemeris import body_states_mci, rotation

__all__ = ["POLE_FRAMES", "moon_op_axes_j2000", "moon_op_to_j2000"]

POLE_FRAMES = ("MOON_ME", "MOON_PA", "IAU_MOON")


def moon_op_axes_j2000(r_earth_km: np.ndarray, v_earth_kms: np.ndarray, pole_j2000: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) from ``moon_op`` to J2000: columns are the x, y, z axes in J2000.

    ``r_earth_km``, ``v_earth_kms``: the Earth's position and velocity relative to the Moon (J2000);
    ``pole_j2000``: the lunar pole (any length). Pure geometry, no SPICE.
    """
    r = np.asarray(r_earth_km, dtype=float)
    v = np.asarray(v_earth_kms, dtype=float)
    pole = np.asarray(pole_j2000, dtype=float)
    h = np.cross(r, v)
    z = h / np.linalg.norm(h)
    node = np.cross(pole, z)
    norm = np.linalg.norm(node)
    if not norm > 1e-9 * np.linalg.norm(pole):
        raise ValueError("moon_op is undefined: the lunar pole is parallel to the Earth's orbit normal")
    x = node / norm
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def moon_op_to_j2000(t_epoch_tdb_s: float, pole_frame: str = "MOON_ME") -> np.ndarray:
    """Rotation R (3, 3) with x_j2000 = R x_moon_op, the ``moon_op`` axes built at ``t_epoch_tdb_s``.

    SPICE kernels (planetary SPK, lunar PCK and frame kernels) must be loaded, e.g. with
    :func:`lnss_lib.ephemeris.ensure_kernels`. ``pole_frame``: the body-fixed frame whose z-axis is
    the lunar pole, one of :data:`POLE_FRAMES` (default ``MOON_ME``, as LuPNT).
    """
    if pole_frame not in POLE_FRAMES:
        raise ValueError(f"unknown lunar pole frame {pole_frame!r}; allowed: {', '.join(map(repr, POLE_FRAMES))}")
    t = float(t_epoch_tdb_s)
    if not np.isfinite(t):
        raise ValueError(f"epoch must be finite (TDB seconds past J2000); got {t_epoch_tdb_s!r}")
    earth = body_states_mci("EARTH", np.array([t]))[0]
    pole = rotation(pole_frame, "J2000", np.array([t]))[0][:, 2]
    return moon_op_axes_j2000(earth[:3], earth[3:], pole)
