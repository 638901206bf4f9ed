"""Receivers on the lunar surface (paper Section 2.1, eq. 1-2): a latitude-longitude grid on a
sphere fixed in the Moon-fixed frame, with each point's position, local East/North/Up axes and its
weight in the grid's statistics (uniform as in the paper, or by area).

:mod:`lnss_lib.dop` computes visibility and dilution of precision at these receivers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .sections import AREA_WEIGHTINGS

if TYPE_CHECKING:
    from .settings import DopSettings


WEIGHTINGS = AREA_WEIGHTINGS


@dataclass(frozen=True)
class SurfaceGrid:
    """Receivers on a sphere, fixed in the Moon-fixed frame (eq. 1-2).

    ``lat_deg`` (nlat,), ``lon_deg`` (nlon,); ``r_mf_km``, ``east``, ``north``, ``up``
    (nlat, nlon, 3): positions (km) and local unit vectors in Moon-fixed axes; ``weight``
    (nlat, nlon): sample weights summing to 1 (uniform unless an area weighting was chosen).
    At latitude -90 deg every longitude repeats the pole (as in the paper), with East/North
    turned by the longitude.
    """

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    radius_km: float
    weighting: str
    r_mf_km: np.ndarray
    east: np.ndarray
    north: np.ndarray
    up: np.ndarray
    weight: np.ndarray

    @property
    def n_points(self) -> int:
        return self.lat_deg.size * self.lon_deg.size

    @property
    def shape(self) -> tuple[int, int]:
        return self.lat_deg.size, self.lon_deg.size

    @classmethod
    def from_settings(cls, dop: DopSettings, radius_km: float) -> SurfaceGrid:
        """The :func:`surface_grid` described by ``[dop]`` on a sphere of ``radius_km`` (the mean lunar
        radius, ``constants.r_moon_mean_km``)."""
        return surface_grid(
            dop.lat_min_deg,
            dop.lat_max_deg,
            dop.lat_step_deg,
            dop.lon_min_deg,
            dop.lon_max_deg,
            dop.lon_step_deg,
            radius_km=radius_km,
            weighting=dop.area_weighting,
        )


def _inclusive_range(start: float, stop: float, step: float, name: str) -> np.ndarray:
    if not (np.isfinite(start) and np.isfinite(stop) and np.isfinite(step)) or step <= 0.0:
        raise ValueError(
            f"{name}: step must be positive and bounds finite; got {start}..{stop} step {step}"
        )
    if stop < start:
        raise ValueError(f"{name}: upper bound {stop} is below lower bound {start}")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    return start + step * np.arange(n)


def _area_weights(
    lat_deg: np.ndarray, lat_step_deg: float, nlon: int, weighting: str
) -> np.ndarray:
    """Weights (nlat, nlon) summing to 1.

    ``cos_lat``: proportional to cos(lat) (the pole gets none). ``cell_area``: area of the band
    [lat - step/2, lat + step/2] clipped to [-90, 90] deg, i.e. cos(lat) for interior rows and
    the polar cap shared among the repeated pole points.
    """
    lat = np.radians(lat_deg)
    if weighting == "none":
        row = np.ones_like(lat)
    elif weighting == "cos_lat":
        row = np.clip(np.cos(lat), 0.0, None)
    elif weighting == "cell_area":
        half = np.radians(lat_step_deg) / 2.0
        lo = np.clip(lat - half, -np.pi / 2, np.pi / 2)
        hi = np.clip(lat + half, -np.pi / 2, np.pi / 2)
        row = np.sin(hi) - np.sin(lo)
    else:
        raise ValueError(f"unknown area weighting {weighting!r}; allowed: {', '.join(WEIGHTINGS)}")
    if row.sum() <= 0.0:
        raise ValueError(
            f"area weighting {weighting!r} gives zero total weight for latitudes {lat_deg.tolist()}"
        )
    weights = np.repeat(row[:, None], nlon, axis=1)
    return weights / weights.sum()


def surface_grid(
    lat_min_deg: float = -90.0,
    lat_max_deg: float = -60.0,
    lat_step_deg: float = 10.0,
    lon_min_deg: float = 0.0,
    lon_max_deg: float = 350.0,
    lon_step_deg: float = 10.0,
    radius_km: float = 1737.4,
    weighting: str = "none",
) -> SurfaceGrid:
    """Latitude-longitude grid of eq. 1-2, bounds inclusive (defaults: 4 x 36 = 144 points).

    Latitudes must lie in [-90, 90] deg; ``weighting`` is one of ``none`` (the paper),
    ``cos_lat`` or ``cell_area`` (see :func:`_area_weights`).
    """
    lat = _inclusive_range(
        float(lat_min_deg), float(lat_max_deg), float(lat_step_deg), "latitude grid"
    )
    lon = _inclusive_range(
        float(lon_min_deg), float(lon_max_deg), float(lon_step_deg), "longitude grid"
    )
    if lat[0] < -90.0 or lat[-1] > 90.0:
        raise ValueError(
            f"grid latitudes must lie in [-90, 90] deg; got {lat_min_deg}..{lat_max_deg}"
        )
    if not np.isfinite(radius_km) or radius_km <= 0.0:
        raise ValueError(f"grid radius must be positive (km); got {radius_km!r}")
    phi, lam = np.meshgrid(np.radians(lat), np.radians(lon), indexing="ij")
    cphi, sphi, clam, slam = np.cos(phi), np.sin(phi), np.cos(lam), np.sin(lam)
    up = np.stack([cphi * clam, cphi * slam, sphi], axis=-1)
    east = np.stack([-slam, clam, np.zeros_like(clam)], axis=-1)
    north = np.stack([-sphi * clam, -sphi * slam, cphi], axis=-1)
    weight = _area_weights(lat, float(lat_step_deg), lon.size, weighting)
    return SurfaceGrid(
        lat, lon, float(radius_km), weighting, radius_km * up, east, north, up, weight
    )
