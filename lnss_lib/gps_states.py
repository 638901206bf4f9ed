"""GPS positions seen from the Moon: SGP4 from the ``[gps]`` TLE set (TEME, UTC), rotated to J2000
and shifted to the Moon's centre (paper Section 2.2).

TLE reading and selection live in :mod:`lnss_lib.tle`, TEME -> J2000 and the time scales in
:mod:`lnss_lib.frames`; :mod:`lnss_lib.gps` computes the link from these states. Units and frames
are in the names: ``r_mci_km`` Moon-centred J2000, ``r_eci_km`` Earth-centred J2000, ``r_teme_km``
Earth-centred TEME, ``t_tdb_s`` TDB seconds past J2000 (SPICE ET).
"""

from __future__ import annotations

import datetime as dt
import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr
from sgp4.api import SGP4_ERRORS, Satrec, SatrecArray

from .config import data_path
from .constants import SECONDS_PER_DAY
from .ephemeris import body_states_mci
from .errors import ConfigError
from .frames import J2000_JD, teme_to_j2000, tt_centuries, utc_julian_dates
from .tle import TleRecord, gps_catalogue

if TYPE_CHECKING:
    from .settings import GpsSettings


def propagate_teme(records: list[TleRecord], jd_utc: np.ndarray, fr_utc: np.ndarray) -> np.ndarray:
    """SGP4 positions (gps, time, 3) in TEME, km; ``ValueError`` naming the first satellite and epoch SGP4 fails at:
    the satellite's catalogue number and file line, the epoch in UTC and its distance from the TLE's epoch (SGP4's
    mean elements leave their range far from it), and SGP4's reason."""
    sats = SatrecArray([Satrec.twoline2rv(r.line1, r.line2) for r in records])
    err, r_km, _ = sats.sgp4(np.asarray(jd_utc, dtype=float), np.asarray(fr_utc, dtype=float))
    if np.any(err != 0):
        k, j = np.argwhere(err != 0)[0]
        record, code = records[k], int(err[k, j])
        at_utc = dt.datetime(2000, 1, 1, 12) + dt.timedelta(
            days=float(jd_utc[j] - J2000_JD) + float(fr_utc[j])
        )
        days = (at_utc - record.epoch_utc).total_seconds() / SECONDS_PER_DAY
        raise ValueError(
            f"SGP4 cannot propagate {record.name} (catalogue number {record.satnum}, line "
            f"{record.file_line}) to {at_utc:%Y-%m-%dT%H:%M:%S} UTC, {days:+,.1f} days from its TLE epoch "
            f"{record.epoch_utc:%Y-%m-%dT%H:%M:%S} UTC: {SGP4_ERRORS.get(code, 'unknown error')} "
            f"(SGP4 error {code})"
        )
    return np.asarray(r_km)


_STATE_CACHE: dict[str, xr.Dataset] = {}


_STATE_CACHE_SIZE = 8


def gps_states_mci(
    gps: GpsSettings,
    start_tdb: str,
    t_tdb_s,
    *,
    tle_path: str | Path | None = None,
    sgp4_offset_s: float = 0.0,
) -> xr.Dataset:
    """GPS positions at TDB epochs: Dataset (gps, time, xyz) with ``r_mci_km``, ``r_eci_km``, ``r_teme_km``.

    SGP4 (TEME, UTC) -> J2000 (:func:`teme_to_j2000`) -> Moon-centred by adding the Earth's
    Moon-centred J2000 position (SPICE). Also holds ``rot_teme_to_j2000`` (time, i, j). Coords:
    ``prn``, ``name``, ``designator`` on ``gps``; ``time`` in TDB s. The default TLE set is dated
    November 2025 while the paper's epoch is May 2025: SGP4 then propagates about 6.5 months
    backwards. ``sgp4_offset_s`` evaluates SGP4 at t + offset while the Earth and the frame rotation
    stay at t: a GPS phase (along-track) error, to test how much the back-propagation matters.
    Results are cached per (file, exclusions, epochs, offset): compute once, reuse across designs.
    ``gps``: the ``[gps]`` section (TLE file and exclusions); ``start_tdb``: the study epoch
    (``epoch.start_tdb``, the default launch cut-off). The SPICE kernels must be loaded
    (:func:`lnss_lib.ephemeris.ensure_kernels`, as for the epochs ``t_tdb_s`` themselves).
    """
    t = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    path = Path(tle_path) if tle_path is not None else data_path(gps.tle_file)
    selection = {
        k: str(getattr(gps, k))
        for k in ("exclude_prn", "exclude_launched_after", "exclude_launches_from", "launch_dates")
    }
    key = hashlib.sha256(
        b"".join(
            [
                path.read_bytes(),
                repr(sorted(selection.items())).encode(),
                start_tdb.encode(),
                t.tobytes(),
                repr(float(sgp4_offset_s)).encode(),
            ]
        )
    ).hexdigest()
    if key in _STATE_CACHE:
        return _STATE_CACHE[key]
    if len(_STATE_CACHE) >= _STATE_CACHE_SIZE:
        _STATE_CACHE.clear()
    records, _ = gps_catalogue(gps, start_tdb, path)
    jd, fr = utc_julian_dates(t + float(sgp4_offset_s))
    try:
        r_teme = propagate_teme(records, jd, fr)
    except ValueError as error:
        raise ConfigError(
            f"gps.tle_file = {gps.tle_file!r} for the study from epoch.start_tdb = {start_tdb!r}: "
            f"{error}; use TLEs dated nearer the study epoch",
            key="gps.tle_file",
        ) from None
    rot = teme_to_j2000(tt_centuries(t))
    r_eci = np.einsum("tij,gtj->gti", rot, r_teme)
    earth_mci = body_states_mci("EARTH", t)[:, :3]
    r_mci = r_eci + earth_mci[None, :, :]
    ds = xr.Dataset(
        {
            "r_mci_km": (("gps", "time", "xyz"), r_mci),
            "r_eci_km": (("gps", "time", "xyz"), r_eci),
            "r_teme_km": (("gps", "time", "xyz"), r_teme),
            "rot_teme_to_j2000": (("time", "i", "j"), rot),
            "earth_mci_km": (("time", "xyz"), earth_mci),
        },
        coords={
            "gps": np.arange(len(records)),
            "time": t,
            "xyz": ["x", "y", "z"],
            "prn": ("gps", np.array([-1 if r.prn is None else r.prn for r in records])),
            "name": ("gps", [r.name for r in records]),
            "designator": ("gps", [r.designator for r in records]),
        },
        attrs={
            "frame": "J2000 (r_mci_km Moon-centred, r_eci_km Earth-centred); r_teme_km TEME",
            "time_scale": "TDB seconds past J2000",
            "tle_file": str(path),
            "propagator": "SGP4 (sgp4 package), UTC from SPICE deltet",
            "teme_to_j2000": "IAU-1976 precession, IAU-1980 nutation (13 terms), EqE 1982",
            "sgp4_offset_s": float(sgp4_offset_s),
        },
    )
    _STATE_CACHE[key] = ds
    return ds
