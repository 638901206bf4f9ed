"""The user's position error in metres: a user range error budget per satellite and epoch, and the weighted
least-squares position error it gives over the south-pole grid.

Budget (``[navigation_error]``): satellite k's 1-sigma user range error at epoch t, seen at elevation el,

    sigma_k^2 = SISE(age_k(t))^2 + receiver_noise^2 + (lunar_multipath_zenith / sin el)^2,

with the signal-in-space error growing with the age of the broadcast orbit and clock since the satellite's last
upload, SISE(age) = sise_at_upload + sise_growth (age / sise_growth_age)^p, p = 0, 1, 2 for the ``constant``,
``linear`` and ``quadratic`` laws (``constant``: sise_at_upload alone).

Uploads (:func:`upload_contact`): stations on a spherical Earth (radius ``constants.r_earth_km``) at the profile's
latitudes and longitudes, turned with the Earth (SPICE ``IAU_EARTH``, pck00010); a satellite is uploaded at every
sampled epoch at which some station sees it at least ``station_mask_deg`` above its horizon and the segment
between them misses the Moon (the Earth itself hides it below any mask >= 0). Every satellite's ephemeris is
fresh at the start of the arc; a satellite no station sees during the arc is never uploaded and ages with the
arc (:func:`ephemeris_age_s` flags it).

Position error: the fix of eq. 5 weighted by 1 / sigma_k^2; its covariance is (sum_k g_k g_k^T / sigma_k^2)^-1,
whose position block the DOP grid's compiled pass computes beside the DOP from the same lines of sight
(:func:`lnss_lib.dop.dop_and_error_arrays`): horizontal (local East and North) and vertical 1-sigma. With
every sigma_k equal to sigma they are sigma HDOP and sigma VDOP. The 95 % errors are 2 sigma_H (2drms: 95 %
for an error ellipse with one dominant axis, 98 % for a circular one) and 1.96 sigma_V.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from .constants import SECONDS_PER_HOUR
from .dop import metrics_and_errors_for_settings
from .ephemeris import body_states_mci, rotation
from .surface_grid import SurfaceGrid

if TYPE_CHECKING:
    from .settings import BodyConstants, DopSettings, NavigationErrorSettings

__all__ = [
    "HORIZONTAL_95_PER_SIGMA",
    "VERTICAL_95_PER_SIGMA",
    "sise_m",
    "uere_variance_m2",
    "station_states",
    "upload_contact",
    "ephemeris_age_s",
    "errors_95_m",
    "error_metrics",
    "PositionErrors",
    "position_errors",
    "error_percentiles",
]

HORIZONTAL_95_PER_SIGMA = (
    2.0  # 2drms: between 95.4 % (one dominant axis) and 98.2 % (circular) of fixes
)
VERTICAL_95_PER_SIGMA = 1.959964  # two-sided 95 % of a normal error
SISE_POWER = {"constant": 0, "linear": 1, "quadratic": 2}


def sise_m(nav: NavigationErrorSettings, age_s) -> np.ndarray:
    """1-sigma signal-in-space error (m) after ``age_s`` seconds since the last upload (any shape)."""
    age = np.asarray(age_s, dtype=float)
    if np.any(age < 0.0) or not np.all(np.isfinite(age)):
        raise ValueError(
            f"ephemeris ages must be finite and >= 0 s; got a minimum of {np.min(age)!r}"
        )
    power = SISE_POWER[nav.sise_law]
    if power == 0:
        return np.full_like(age, nav.sise_at_upload_m)
    return (
        nav.sise_at_upload_m
        + nav.sise_growth_m * (age / (nav.sise_growth_age_h * SECONDS_PER_HOUR)) ** power
    )


def uere_variance_m2(nav: NavigationErrorSettings, age_s) -> np.ndarray:
    """User range error variance (m^2) apart from the elevation-dependent lunar multipath: SISE^2 + receiver^2."""
    return sise_m(nav, age_s) ** 2 + nav.receiver_noise_m**2


def station_states(
    nav: NavigationErrorSettings, constants: BodyConstants, t_tdb_s
) -> tuple[np.ndarray, np.ndarray]:
    """Upload stations' positions (km) and local verticals, Moon-centred J2000, each (station, time, 3)."""
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    lat = np.radians(np.asarray(nav.station_lat_deg, dtype=float))
    lon = np.radians(np.asarray(nav.station_lon_deg, dtype=float))
    up_fixed = np.stack(
        [np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1
    )
    to_j2000 = np.swapaxes(rotation("J2000", "IAU_EARTH", times), -1, -2)  # (time, 3, 3)
    up = np.einsum("tij,sj->sti", to_j2000, up_fixed)
    earth_km = body_states_mci("EARTH", times)[:, :3]
    return earth_km[None] + constants.r_earth_km * up, up


def upload_contact(
    r_mci_km, station_km, station_up, mask_deg: float, r_moon_km: float
) -> np.ndarray:
    """(sat, time) True where some station sees the satellite: elevation >= ``mask_deg`` and the station-satellite
    segment clear of the lunar sphere of radius ``r_moon_km``. ``r_mci_km`` (sat, time, 3); ``station_km`` and
    ``station_up`` (station, time, 3), Moon-centred J2000 (:func:`station_states`)."""
    r = np.asarray(r_mci_km, dtype=float)
    d = r[:, None] - station_km[None]  # (sat, station, time, 3)
    rho2 = np.einsum("...i,...i->...", d, d)
    above = np.einsum("...i,...i->...", d, station_up[None]) >= np.sin(
        np.radians(mask_deg)
    ) * np.sqrt(rho2)
    p_dot_d = np.einsum("...i,...i->...", station_km[None], d)
    along = -p_dot_d / rho2  # the segment's closest approach to the Moon
    p2 = np.einsum("...i,...i->...", station_km, station_km)[None]
    miss = (along <= 0.0) | (along >= 1.0) | (p2 - p_dot_d * p_dot_d / rho2 > r_moon_km * r_moon_km)
    return np.any(above & miss, axis=1)


def ephemeris_age_s(contact, t_tdb_s) -> tuple[np.ndarray, np.ndarray]:
    """(age (sat, time) in s since each satellite's last upload, never_uploaded (sat,) bool).

    ``contact`` (sat, time): uploads (:func:`upload_contact`). Every ephemeris is fresh at the first epoch; a
    satellite with no contact ages from there through the arc (and is flagged ``never_uploaded``).
    """
    contact = np.asarray(contact, dtype=bool)
    times = np.asarray(t_tdb_s, dtype=float)
    if contact.ndim != 2 or contact.shape[1] != times.size:
        raise ValueError(f"contact must have shape (sat, {times.size}); got {contact.shape}")
    index = np.where(contact, np.arange(times.size), 0)
    last = np.maximum.accumulate(index, axis=1)  # epoch of the last upload (0: the start)
    return times[None, :] - times[last], ~contact.any(axis=1)


def errors_95_m(sigma_h_m, sigma_v_m) -> tuple[np.ndarray, np.ndarray]:
    """The 95 % errors 2 sigma_H and 1.96 sigma_V of 1-sigma errors, a sample without a fix (NaN) infinite."""
    return (
        HORIZONTAL_95_PER_SIGMA * np.where(np.isnan(sigma_h_m), np.inf, sigma_h_m),
        VERTICAL_95_PER_SIGMA * np.where(np.isnan(sigma_v_m), np.inf, sigma_v_m),
    )


def error_metrics(
    nav: NavigationErrorSettings, sigma_h_m, sigma_v_m, weights, age_s, never_uploaded
) -> dict[str, float]:
    """The scalar metre metrics (:data:`lnss_lib.keys.NAVIGATION_ERROR_KEYS`) of (time, point) 1-sigma errors.

    ``horizontal_error_95_m`` / ``vertical_error_95_m``: 95th percentile over every grid-epoch sample of the 95 %
    errors 2 sigma_H and 1.96 sigma_V, a sample without a fix counting as infinite (NaN when more than 5 % have
    none); ``position_error_avail_pct``: share of the samples, weighted by ``weights`` (point,) as the DOP
    availability, whose 95 % errors meet ``requirement_horizontal_95_m`` (and ``requirement_vertical_95_m`` unless
    0); ``ephemeris_age_max_h``: the oldest ephemeris; ``satellites_never_uploaded``.
    """
    h95, v95 = errors_95_m(sigma_h_m, sigma_v_m)
    with np.errstate(invalid="ignore"):
        met = h95 <= nav.requirement_horizontal_95_m
        if nav.requirement_vertical_95_m > 0.0:
            met &= v95 <= nav.requirement_vertical_95_m
    w = np.asarray(weights, dtype=float)
    h_pct, v_pct = (float(np.percentile(x, 95.0, method="higher")) for x in (h95, v95))
    return {
        "horizontal_error_95_m": h_pct if np.isfinite(h_pct) else float("nan"),
        "vertical_error_95_m": v_pct if np.isfinite(v_pct) else float("nan"),
        "position_error_avail_pct": min(
            100.0, 100.0 * float(np.mean((met @ w) / (np.ones_like(w) @ w)))
        ),
        "ephemeris_age_max_h": float(np.max(age_s)) / SECONDS_PER_HOUR,
        "satellites_never_uploaded": int(np.sum(never_uploaded)),
    }


@dataclass(frozen=True)
class PositionErrors:
    """A constellation's position errors over the grid: ``sigma_h_m``, ``sigma_v_m`` (time, point) 1-sigma,
    ``age_s`` (sat, time) ephemeris ages, ``contact`` (sat, time) uploads, ``never_uploaded`` (sat,), and the
    DOP metrics of the same pass (``dop_stats``, :func:`lnss_lib.dop.dop_metrics`'s keys)."""

    sigma_h_m: np.ndarray
    sigma_v_m: np.ndarray
    age_s: np.ndarray
    contact: np.ndarray
    never_uploaded: np.ndarray
    dop_stats: dict

    def metrics(self, nav: NavigationErrorSettings, grid: SurfaceGrid) -> dict[str, float]:
        """:func:`error_metrics` with the grid's sample weights."""
        return error_metrics(
            nav,
            self.sigma_h_m,
            self.sigma_v_m,
            grid.weight.reshape(-1),
            self.age_s,
            self.never_uploaded,
        )


def position_errors(
    nav: NavigationErrorSettings,
    dop: DopSettings,
    grid: SurfaceGrid,
    r_mf_km,
    r_mci_km,
    t_tdb_s,
    stations: tuple[np.ndarray, np.ndarray],
    r_moon_km: float,
) -> PositionErrors:
    """Uploads, ephemeris ages, user range errors and the position errors (with the DOP) of satellites at
    ``r_mf_km`` (Moon-fixed) and ``r_mci_km`` (Moon-centred J2000), both (sat, time, 3) km, at ``t_tdb_s``;
    ``stations``: :func:`station_states` at those epochs."""
    contact = upload_contact(r_mci_km, *stations, nav.station_mask_deg, r_moon_km)
    age_s, never = ephemeris_age_s(contact, t_tdb_s)
    stats, sigma_h, sigma_v = metrics_and_errors_for_settings(
        dop, r_mf_km, grid, uere_variance_m2(nav, age_s), nav.lunar_multipath_zenith_m
    )
    return PositionErrors(sigma_h, sigma_v, age_s, contact, never, stats)


def error_percentiles(errors: PositionErrors, grid: SurfaceGrid, t_tdb_s) -> xr.Dataset:
    """95th percentiles of the 95 % horizontal and vertical errors: maps over the arc (``horizontal_95_map_m``,
    ``vertical_95_map_m``, (lat, lon)) and time series over the grid (``horizontal_95_series_m``,
    ``vertical_95_series_m``, (time,)); a sample without a fix counts as infinite, a percentile it decides is NaN."""
    nlat, nlon = grid.shape
    out = {}
    for name, values in zip(
        ("horizontal", "vertical"), errors_95_m(errors.sigma_h_m, errors.sigma_v_m)
    ):
        maps = np.percentile(values, 95.0, axis=0, method="higher").reshape(nlat, nlon)
        series = np.percentile(values, 95.0, axis=1, method="higher")
        out[f"{name}_95_map_m"] = (("lat", "lon"), np.where(np.isfinite(maps), maps, np.nan))
        out[f"{name}_95_series_m"] = (("time",), np.where(np.isfinite(series), series, np.nan))
    return xr.Dataset(
        out,
        coords={"lat": grid.lat_deg, "lon": grid.lon_deg, "time": np.asarray(t_tdb_s, dtype=float)},
        attrs={
            "definition": "95th percentile of 2 sigma_H (horizontal) and 1.96 sigma_V (vertical)"
        },
    )
