"""GPS constellation and the GPS-LNSS link (paper Section 2.2, eq. 15-24, Table 1).

Four layers, pure kernels apart from orchestration:

* **TLE input** (:func:`read_tle`, :func:`select_satellites`): every element line is validated
  here (length and column layout, line number, modulo-10 checksum, satellite number of line 1 vs
  line 2) before ``sgp4`` parses it; a bad line raises ``ValueError`` naming the file, the line
  number and what is wrong. Name and PRN come from the title lines. Satellites can be dropped by
  PRN, by launch (international designator ``YYYY-NNN``) or by launch date (default: launched
  after the simulation epoch, so GPS BIII-8 / PRN 21, launched 2025-05-30, is out at 2025-05-01).
  A TLE carries no launch date: it is taken from ``gps.launch_dates`` when listed there, else
  estimated as TLE epoch - revolution number / mean motion (within a few weeks for GPS), and in
  any case bounded by the launch year of the designator.
* **Frames** (:func:`teme_to_j2000`): SGP4 gives positions in TEME (true equator, mean equinox of
  date) at UTC epochs. TDB -> UTC goes through SPICE ``deltet`` and TDB -> TT through ``unitim``.
  TEME -> J2000 is r_J2000 = P^T N^T R3(-EqE) r_TEME with IAU-1976 precession (P), IAU-1980
  nutation (N) truncated to its 13 terms of amplitude >= 10 mas, and the 1982 equation of the
  equinoxes EqE = dpsi cos(eps_mean) (the TEME convention of Vallado et al. 2006). The 93 skipped
  nutation terms sum to at most :data:`NUTATION_SKIPPED_DPSI_MAS` in longitude and
  :data:`NUTATION_SKIPPED_DEPS_MAS` in obliquity, a frame error below 0.12 arcsec (15 m at GPS
  radius); the IAU-1976/1980 models themselves differ from IAU-2006/2000A by up to about 0.1 arcsec
  (about 10 m) and the J2000/ICRF frame bias (23 mas) is ignored as SPICE does. All of this is far below the
  error of SGP4 itself (kilometres) and irrelevant for visibility and DOP seen from the Moon.
* **Link kernels** (eq. 15-24): lunar occultation cone (eq. 17-18), off-boresight angle (eq. 19-20),
  Earth occultation with the atmospheric margin (eq. 21) plus the ray / WGS-84 ellipsoid test,
  beam mask, link budget (eq. 22-24), GPS-LNSS PDOP with the clock column (eq. 5-7) and the
  95th-percentile ("2-sigma") filtered mean.
* **Orchestration**: :func:`gps_states_mci` (computed once per run, cached, reused across
  designs) and :func:`gps_link` / :func:`gps_link_summary`.

Units and frames are in the names: ``r_mci_km`` Moon-centred J2000, ``r_eci_km`` Earth-centred
J2000, ``r_teme_km`` Earth-centred TEME, ``t_tdb_s`` TDB seconds past J2000 (SPICE ET).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import spiceypy as spice
import xarray as xr
from sgp4.api import SatrecArray, Satrec

from .config import data_path
from .constellation import PAPER_TABLE_4 as _PAPER
from .ephemeris import body_states_mci, ensure_kernels

BOLTZMANN_J_K = 1.380649e-23
C_M_S = 299792458.0
WGS84_A_KM = 6378.137
WGS84_INV_FLATTENING = 298.257223563
MIN_VISIBLE = 4
PDOP_FILTERS = ("percentile95", "sigma2", "none")
ARCSEC_RAD = np.pi / (180.0 * 3600.0)
SECONDS_PER_CENTURY = 36525.0 * 86400.0
J2000_JD = 2451545.0

# IAU-1980 nutation series (Seidelmann 1992, Explanatory Supplement 3.222; SOFA nut80), the 13 terms
# with |dpsi amplitude| >= 100 x 0.1 mas. Columns: multipliers of l, l', F, D, Omega; dpsi sine
# coefficient and its rate per Julian century; deps cosine coefficient and its rate (0.1 mas).
_NUT80_TERMS = np.array([
    [0, 0, 0, 0, 1, -171996.0, -174.2, 92025.0, 8.9],
    [0, 0, 2, -2, 2, -13187.0, -1.6, 5736.0, -3.1],
    [0, 0, 2, 0, 2, -2274.0, -0.2, 977.0, -0.5],
    [0, 0, 0, 0, 2, 2062.0, 0.2, -895.0, 0.5],
    [0, 1, 0, 0, 0, 1426.0, -3.4, 54.0, -0.1],
    [1, 0, 0, 0, 0, 712.0, 0.1, -7.0, 0.0],
    [0, 1, 2, -2, 2, -517.0, 1.2, 224.0, -0.6],
    [0, 0, 2, 0, 1, -386.0, -0.4, 200.0, 0.0],
    [1, 0, 2, 0, 2, -301.0, 0.0, 129.0, -0.1],
    [0, -1, 2, -2, 2, 217.0, -0.5, -95.0, 0.3],
    [1, 0, 0, -2, 0, -158.0, 0.0, -1.0, 0.0],
    [0, 0, 2, -2, 1, 129.0, 0.1, -70.0, 0.0],
    [-1, 0, 2, 0, 2, 123.0, 0.0, -53.0, 0.0],
])
# Sum of |amplitude| (incl. the rate terms at 2025) of the 93 IAU-1980 terms left out above (mas).
NUTATION_SKIPPED_DPSI_MAS = 88.0
NUTATION_SKIPPED_DEPS_MAS = 29.6


# --------------------------------------------------------------------------------------------
# TLE input
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class TleRecord:
    """One satellite of a TLE file: title, identifiers and the two validated element lines."""

    name: str
    prn: int | None
    satnum: int
    designator: str            # international designator "YYYY-NNNP" (e.g. "2025-116A")
    launch_year: int
    launch_number: int
    epoch_utc: dt.datetime
    rev_number: int            # revolution number at epoch (line 2, columns 64-68)
    mean_motion_rev_day: float
    line1: str
    line2: str
    file_line: int             # 1-based line number of line 1 in its file


def tle_checksum(line: str) -> int:
    """Modulo-10 checksum of a TLE line: digits count their value, '-' counts 1, over columns 1-68."""
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


# Columns (0-based) that must hold a blank, and numeric fields (start, stop) that must parse.
_BLANKS = {1: (1, 8, 17, 32, 43, 52, 61, 63), 2: (1, 7, 16, 25, 33, 42, 51)}
_FIELDS = {
    1: {"satellite number": (2, 7), "epoch year": (18, 20), "epoch day": (20, 32), "element set number": (64, 68)},
    2: {"satellite number": (2, 7), "inclination": (8, 16), "RAAN": (17, 25), "eccentricity": (26, 33),
        "argument of perigee": (34, 42), "mean anomaly": (43, 51), "mean motion": (52, 63),
        "revolution number": (63, 68)},
}


def _check_element_line(line: str, expected: int, path: Path, line_no: int) -> None:
    """Raise ``ValueError`` naming file and line if ``line`` is not a well-formed TLE line ``expected``."""
    where = f"{path}: line {line_no}"
    if len(line) != 69:
        raise ValueError(f"{where}: TLE line {expected} must be 69 characters long, got {len(line)}: {line!r}")
    if line[0] != str(expected):
        raise ValueError(f"{where}: expected TLE line number {expected} in column 1, got {line[0]!r}")
    for col in _BLANKS[expected]:
        if line[col] != " ":
            raise ValueError(
                f"{where}: TLE line {expected} column {col + 1} must be blank, got {line[col]!r} "
                "(column layout of the standard two-line format)")
    for field, (lo, hi) in _FIELDS[expected].items():
        text = line[lo:hi].strip()
        try:
            float(text.replace(" ", ""))
        except ValueError:
            raise ValueError(
                f"{where}: TLE line {expected} columns {lo + 1}-{hi} ({field}) are not a number: {line[lo:hi]!r}"
            ) from None
    if not line[68].isdigit():
        raise ValueError(f"{where}: TLE line {expected} column 69 must be the checksum digit, got {line[68]!r}")
    if tle_checksum(line) != int(line[68]):
        raise ValueError(
            f"{where}: bad checksum on TLE line {expected}: column 69 says {line[68]} but the "
            f"modulo-10 sum of columns 1-68 is {tle_checksum(line)}")


def _designator(line1: str, path: Path, line_no: int) -> tuple[str, int, int]:
    """("YYYY-NNNP", launch year, launch number) from line 1 columns 10-17; ("", 0, 0) when blank."""
    raw = line1[9:17]
    if not raw.strip():
        return "", 0, 0
    match = re.fullmatch(r"(\d{2})(\d{3})([A-Z ]{1,3})", raw.rstrip().ljust(6))
    if not match:
        raise ValueError(f"{path}: line {line_no}: international designator {raw!r} is not YYNNNP (columns 10-17)")
    yy, number, piece = int(match.group(1)), int(match.group(2)), match.group(3).strip()
    year = 1900 + yy if yy >= 57 else 2000 + yy
    return f"{year}-{number:03d}{piece}", year, number


def read_tle(path: str | Path) -> list[TleRecord]:
    """Satellites of a TLE file (two-line or three-line format), each element line validated.

    A title line (any line not starting with "1 " or "2 ") names the next element set; the PRN is
    read from "PRN nn" in it. Raises ``ValueError`` naming the file and line for a malformed line,
    a line 1 without its line 2, or different satellite numbers on lines 1 and 2.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"TLE file not found: {path}")
    lines = path.read_text().splitlines()
    records: list[TleRecord] = []
    title: str | None = None
    k = 0
    while k < len(lines):
        line = lines[k].rstrip()
        if not line.strip():
            k += 1
            continue
        if line[:2] == "2 " or (line[:1] == "2" and len(line) > 60):
            raise ValueError(f"{path}: line {k + 1}: TLE line 2 without a preceding line 1")
        if not (line[:2] == "1 " or (line[:1] == "1" and len(line) > 60)):
            title = line.strip()
            k += 1
            continue
        _check_element_line(line, 1, path, k + 1)
        if k + 1 >= len(lines):
            raise ValueError(f"{path}: line {k + 1}: TLE line 1 is not followed by a line 2")
        line2 = lines[k + 1].rstrip()
        _check_element_line(line2, 2, path, k + 2)
        if line[2:7] != line2[2:7]:
            raise ValueError(
                f"{path}: lines {k + 1}-{k + 2}: satellite number {line[2:7].strip()} on line 1 "
                f"differs from {line2[2:7].strip()} on line 2")
        designator, year, number = _designator(line, path, k + 1)
        sat = Satrec.twoline2rv(line, line2)
        epoch = dt.datetime(2000 + sat.epochyr if sat.epochyr < 57 else 1900 + sat.epochyr, 1, 1) + \
            dt.timedelta(days=sat.epochdays - 1.0)
        name = title or f"NORAD {int(line[2:7])}"
        prn_match = re.search(r"PRN\s*0*(\d+)", name)
        records.append(TleRecord(
            name=name, prn=int(prn_match.group(1)) if prn_match else None, satnum=int(line[2:7]),
            designator=designator, launch_year=year, launch_number=number, epoch_utc=epoch,
            rev_number=int(line2[63:68].strip() or 0), mean_motion_rev_day=float(line2[52:63]),
            line1=line, line2=line2, file_line=k + 1))
        title = None
        k += 2
    if not records:
        raise ValueError(f"{path}: no TLE element sets found")
    return records


def launch_date(record: TleRecord, launch_dates: dict | None = None) -> tuple[dt.date, str]:
    """(launch date, source): from ``launch_dates`` (designator -> ISO date) or estimated.

    The estimate is TLE epoch - revolution number / mean motion, clamped to the designator's launch
    year when the TLE gives a designator; source is "table" or "estimate".
    """
    listed = (launch_dates or {}).get(record.designator) or (launch_dates or {}).get(record.designator[:8])
    if record.designator and listed:
        try:
            return dt.date.fromisoformat(str(listed)), "table"
        except ValueError:
            raise ValueError(f"gps.launch_dates: launch date of {record.designator} must be an ISO date "
                             f"YYYY-MM-DD; got {listed!r}") from None
    estimate = (record.epoch_utc - dt.timedelta(days=record.rev_number / record.mean_motion_rev_day)).date()
    if not record.launch_year:
        return estimate, "estimate"
    first, last = dt.date(record.launch_year, 1, 1), dt.date(record.launch_year, 12, 31)
    return min(max(estimate, first), last), "estimate"


def _parse_launch(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d{4})-(\d{3})", text.strip())
    if not match:
        raise ValueError(f"launch cut-off must be an international designator 'YYYY-NNN'; got {text!r}")
    return int(match.group(1)), int(match.group(2))


def select_satellites(records: list[TleRecord], *, exclude_prn=(), launched_after: dt.date | None = None,
                      launches_from: str | None = None, launch_dates: dict | None = None
                      ) -> tuple[list[TleRecord], pd.DataFrame]:
    """Satellites kept after the exclusions, and a table of every satellite with the reason if dropped.

    ``exclude_prn``: PRNs to drop; ``launched_after``: drop satellites launched after this date
    (see :func:`launch_date`); ``launches_from``: drop this launch "YYYY-NNN" and all later ones.
    """
    cutoff = _parse_launch(launches_from) if launches_from else None
    drop_prn = {int(p) for p in exclude_prn}
    kept, rows = [], []
    for rec in records:
        date, source = launch_date(rec, launch_dates)
        reason = ""
        if rec.prn is not None and rec.prn in drop_prn:
            reason = f"PRN {rec.prn} excluded"
        elif cutoff is not None and (rec.launch_year, rec.launch_number) >= cutoff:
            reason = f"launch {rec.designator[:8]} at or after {launches_from}"
        elif launched_after is not None and date > launched_after:
            reason = f"launched {date} ({source}) after {launched_after}"
        if not reason:
            kept.append(rec)
        rows.append({"name": rec.name, "prn": rec.prn, "designator": rec.designator, "launch_date": date,
                     "launch_date_source": source, "tle_epoch_utc": rec.epoch_utc, "included": not reason,
                     "reason": reason})
    if not kept:
        raise ValueError("every GPS satellite was excluded: check gps.exclude_prn and the launch cut-offs")
    return kept, pd.DataFrame(rows)


def gps_catalogue(profile: dict, tle_path: str | Path | None = None) -> tuple[list[TleRecord], pd.DataFrame]:
    """Read the profile's (or a user's) TLE file and apply the profile's ``[gps]`` exclusions."""
    cfg = profile["gps"]
    path = Path(tle_path) if tle_path is not None else data_path(cfg["tle_file"])
    after = str(cfg.get("exclude_launched_after", "epoch"))
    if after == "epoch":
        cutoff = dt.date.fromisoformat(profile["epoch"]["start_tdb"][:10])
    elif after == "none":
        cutoff = None
    else:
        try:
            cutoff = dt.date.fromisoformat(after)
        except ValueError:
            raise ValueError(
                f"gps.exclude_launched_after must be 'epoch', 'none' or an ISO date; got {after!r}") from None
    return select_satellites(read_tle(path), exclude_prn=cfg.get("exclude_prn", []), launched_after=cutoff,
                             launches_from=cfg.get("exclude_launches_from") or None,
                             launch_dates=cfg.get("launch_dates", {}))


# --------------------------------------------------------------------------------------------
# Time scales and TEME -> J2000
# --------------------------------------------------------------------------------------------

def utc_julian_dates(t_tdb_s) -> tuple[np.ndarray, np.ndarray]:
    """UTC Julian dates (whole part, fraction) of TDB epochs, for ``sgp4``; SPICE ``deltet`` (ET - UTC).

    Needs the leap-second kernel (:func:`lnss_lib.ephemeris.ensure_kernels`).
    """
    et = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    utc_s = et - np.array([spice.deltet(float(e), "ET") for e in et])
    days = utc_s / 86400.0
    whole = np.floor(days)
    return J2000_JD + whole, days - whole


def tt_centuries(t_tdb_s) -> np.ndarray:
    """Julian centuries of TT past J2000 (SPICE ``unitim`` TDB -> TDT)."""
    et = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    return np.array([spice.unitim(float(e), "TDB", "TDT") for e in et]) / SECONDS_PER_CENTURY


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Passive (frame) rotations R_axis(angle), shape (n, 3, 3): x' = R x (Vallado's ROT1/2/3)."""
    a = np.atleast_1d(angle)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros((a.size, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis - 1]
    out[:, axis - 1, axis - 1] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = s
    out[:, j, i] = -s
    return out


def precession_iau1976(t_tt_cy) -> np.ndarray:
    """IAU-1976 precession P (n, 3, 3): r_mean_of_date = P r_J2000 (Lieske 1977 angles zeta, theta, z)."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    zeta = (2306.2181 + (0.30188 + 0.017998 * t) * t) * t * ARCSEC_RAD
    theta = (2004.3109 + (-0.42665 - 0.041833 * t) * t) * t * ARCSEC_RAD
    z = (2306.2181 + (1.09468 + 0.018203 * t) * t) * t * ARCSEC_RAD
    return _rot(3, -z) @ _rot(2, theta) @ _rot(3, -zeta)


def mean_obliquity_iau1980(t_tt_cy) -> np.ndarray:
    """Mean obliquity of the ecliptic (rad), IAU 1980."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    return (84381.448 + (-46.8150 + (-0.00059 + 0.001813 * t) * t) * t) * ARCSEC_RAD


def nutation_iau1980(t_tt_cy, terms: np.ndarray = _NUT80_TERMS) -> tuple[np.ndarray, np.ndarray]:
    """Nutation in longitude and obliquity (rad) from the IAU-1980 series ``terms`` (default: 13 largest)."""
    t = np.atleast_1d(np.asarray(t_tt_cy, dtype=float))
    turn = 2.0 * np.pi
    el = (485866.733 + (715922.633 + (31.310 + 0.064 * t) * t) * t) * ARCSEC_RAD + np.mod(1325.0 * t, 1.0) * turn
    elp = (1287099.804 + (1292581.224 + (-0.577 - 0.012 * t) * t) * t) * ARCSEC_RAD + np.mod(99.0 * t, 1.0) * turn
    f = (335778.877 + (295263.137 + (-13.257 + 0.011 * t) * t) * t) * ARCSEC_RAD + np.mod(1342.0 * t, 1.0) * turn
    d = (1072261.307 + (1105601.328 + (-6.891 + 0.019 * t) * t) * t) * ARCSEC_RAD + np.mod(1236.0 * t, 1.0) * turn
    om = (450160.280 + (-482890.539 + (7.455 + 0.008 * t) * t) * t) * ARCSEC_RAD + np.mod(-5.0 * t, 1.0) * turn
    args = np.stack([el, elp, f, d, om], axis=-1) @ terms[:, :5].T
    dpsi = np.sum((terms[:, 5] + terms[:, 6] * t[:, None]) * np.sin(args), axis=-1)
    deps = np.sum((terms[:, 7] + terms[:, 8] * t[:, None]) * np.cos(args), axis=-1)
    return dpsi * 1e-4 * ARCSEC_RAD, deps * 1e-4 * ARCSEC_RAD


def nutation_matrix(t_tt_cy) -> np.ndarray:
    """Nutation N (n, 3, 3): r_true_of_date = N r_mean_of_date (IAU 1980, truncated)."""
    eps = mean_obliquity_iau1980(t_tt_cy)
    dpsi, deps = nutation_iau1980(t_tt_cy)
    return _rot(1, -(eps + deps)) @ _rot(3, -dpsi) @ _rot(1, eps)


def teme_to_j2000(t_tt_cy) -> np.ndarray:
    """Rotation (n, 3, 3) with r_J2000 = R r_TEME: R = P^T N^T R3(-EqE), EqE = dpsi cos(eps_mean)."""
    eps = mean_obliquity_iau1980(t_tt_cy)
    dpsi, _ = nutation_iau1980(t_tt_cy)
    p = precession_iau1976(t_tt_cy)
    n = nutation_matrix(t_tt_cy)
    return np.swapaxes(p, 1, 2) @ np.swapaxes(n, 1, 2) @ _rot(3, -dpsi * np.cos(eps))


# --------------------------------------------------------------------------------------------
# GPS states
# --------------------------------------------------------------------------------------------

def propagate_teme(records: list[TleRecord], jd_utc: np.ndarray, fr_utc: np.ndarray) -> np.ndarray:
    """SGP4 positions (gps, time, 3) in TEME, km; ``ValueError`` naming a satellite SGP4 fails on."""
    sats = SatrecArray([Satrec.twoline2rv(r.line1, r.line2) for r in records])
    err, r_km, _ = sats.sgp4(np.asarray(jd_utc, dtype=float), np.asarray(fr_utc, dtype=float))
    if np.any(err != 0):
        k, j = np.argwhere(err != 0)[0]
        raise ValueError(f"SGP4 error code {err[k, j]} for {records[k].name} at UTC JD {jd_utc[j] + fr_utc[j]:.6f}")
    return np.asarray(r_km)


_STATE_CACHE: dict[str, xr.Dataset] = {}
_STATE_CACHE_SIZE = 8


def gps_states_mci(profile: dict, t_tdb_s, *, tle_path: str | Path | None = None,
                   sgp4_offset_s: float = 0.0) -> xr.Dataset:
    """GPS positions at TDB epochs: Dataset (gps, time, xyz) with ``r_mci_km``, ``r_eci_km``, ``r_teme_km``.

    SGP4 (TEME, UTC) -> J2000 (:func:`teme_to_j2000`) -> Moon-centred by adding the Earth's
    Moon-centred J2000 position (SPICE). Also holds ``rot_teme_to_j2000`` (time, i, j). Coords:
    ``prn``, ``name``, ``designator`` on ``gps``; ``time`` in TDB s. The default TLE set is dated
    November 2025 while the paper's epoch is May 2025: SGP4 then propagates about 6.5 months
    backwards. ``sgp4_offset_s`` evaluates SGP4 at t + offset while the Earth and the frame rotation
    stay at t: a GPS phase (along-track) error, to test how much the back-propagation matters.
    Results are cached per (file, exclusions, epochs, offset): compute once, reuse across designs.
    """
    ensure_kernels(profile)
    t = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    cfg = profile["gps"]
    path = Path(tle_path) if tle_path is not None else data_path(cfg["tle_file"])
    selection = {k: str(cfg.get(k)) for k in ("exclude_prn", "exclude_launched_after", "exclude_launches_from",
                                               "launch_dates")}
    key = hashlib.sha256(b"".join([
        path.read_bytes(), repr(sorted(selection.items())).encode(), profile["epoch"]["start_tdb"].encode(),
        t.tobytes(), repr(float(sgp4_offset_s)).encode()])).hexdigest()
    if key in _STATE_CACHE:
        return _STATE_CACHE[key]
    if len(_STATE_CACHE) >= _STATE_CACHE_SIZE:
        _STATE_CACHE.clear()
    records, _ = gps_catalogue(profile, path)
    jd, fr = utc_julian_dates(t + float(sgp4_offset_s))
    r_teme = propagate_teme(records, jd, fr)
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
        coords={"gps": np.arange(len(records)), "time": t, "xyz": ["x", "y", "z"],
                "prn": ("gps", np.array([-1 if r.prn is None else r.prn for r in records])),
                "name": ("gps", [r.name for r in records]),
                "designator": ("gps", [r.designator for r in records])},
        attrs={"frame": "J2000 (r_mci_km Moon-centred, r_eci_km Earth-centred); r_teme_km TEME",
               "time_scale": "TDB seconds past J2000", "tle_file": str(path),
               "propagator": "SGP4 (sgp4 package), UTC from SPICE deltet",
               "teme_to_j2000": "IAU-1976 precession, IAU-1980 nutation (13 terms), EqE 1982",
               "sgp4_offset_s": float(sgp4_offset_s)},
    )
    _STATE_CACHE[key] = ds
    return ds


# --------------------------------------------------------------------------------------------
# Link kernels (pure numpy, broadcasting over any leading axes)
# --------------------------------------------------------------------------------------------

def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1)
    return v / norm[..., None], norm


def _angle_deg(a_hat: np.ndarray, b_hat: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(a_hat * b_hat, axis=-1), -1.0, 1.0)))


def lunar_occultation(r_lnss_mci_km: np.ndarray, r_gps_mci_km: np.ndarray, r_moon_km: float) -> np.ndarray:
    """True where the Moon blocks the LNSS -> GPS line of sight (eq. 15-18).

    theta_moon = acos(-u . z_hat) (u: unit LNSS -> GPS, z_hat: unit Moon -> LNSS) is compared with
    the Moon's angular radius alpha_moon = asin(R_moon / |r_LNSS|): blocked if theta_moon < alpha_moon.
    """
    u_hat, _ = _unit(r_gps_mci_km - r_lnss_mci_km)
    z_hat, r_lnss = _unit(r_lnss_mci_km)
    theta = _angle_deg(-u_hat, z_hat)
    alpha = np.degrees(np.arcsin(np.clip(r_moon_km / r_lnss, -1.0, 1.0)))
    return theta < alpha


def off_boresight_deg(r_gps_eci_km: np.ndarray, r_lnss_eci_km: np.ndarray) -> np.ndarray:
    """Off-boresight angle theta_off (deg, eq. 19-20): boresight -r_GPS (Earth-centred) vs GPS -> LNSS."""
    b_hat, _ = _unit(-r_gps_eci_km)
    u_hat, _ = _unit(r_lnss_eci_km - r_gps_eci_km)
    return _angle_deg(b_hat, u_hat)


def earth_occultation(theta_off_deg: np.ndarray, r_gps_eci_km: np.ndarray, r_earth_km: float,
                      margin_deg: float) -> np.ndarray:
    """True where theta_off < alpha_earth + margin (eq. 21): behind the Earth or its atmosphere."""
    alpha = np.degrees(np.arcsin(r_earth_km / np.linalg.norm(r_gps_eci_km, axis=-1)))
    return theta_off_deg < alpha + margin_deg


def ray_hits_ellipsoid(p0_km: np.ndarray, p1_km: np.ndarray, a_km: float = WGS84_A_KM,
                       b_km: float = WGS84_A_KM * (1.0 - 1.0 / WGS84_INV_FLATTENING)) -> np.ndarray:
    """True where the segment p0 -> p1 meets the ellipsoid x^2/a^2 + y^2/a^2 + z^2/b^2 = 1 (axes along z).

    Both ends are in the ellipsoid's own frame (Earth-centred, z along the pole). Scaling by
    (1/a, 1/a, 1/b) turns the ellipsoid into the unit sphere; the segment meets it if its closest
    point to the origin is inside.
    """
    scale = np.array([1.0 / a_km, 1.0 / a_km, 1.0 / b_km])
    q0 = np.asarray(p0_km) * scale
    d = np.asarray(p1_km) * scale - q0
    s = np.clip(-np.sum(q0 * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
    closest = q0 + s[..., None] * d
    return np.sum(closest * closest, axis=-1) < 1.0


def free_space_loss_db(distance_km: np.ndarray, frequency_hz: float) -> np.ndarray:
    """Free-space loss 20 log10(4 pi d / lambda) (eq. 23), lambda = c / f."""
    wavelength_m = C_M_S / frequency_hz
    return 20.0 * np.log10(4.0 * np.pi * np.asarray(distance_km) * 1e3 / wavelength_m)


def cn0_dbhz(gain_tx_dbi: np.ndarray, distance_km: np.ndarray, *, p_tx_dbw: float, losses_db: float,
             g_rx_dbi: float, frequency_hz: float, noise_temperature_k: float) -> np.ndarray:
    """C/N0 (dB-Hz, eq. 22-24): P_tx - L_tx + G_tx + G_rx - FSL - 10 log10(k T)."""
    if not noise_temperature_k > 0.0:
        raise ValueError(f"noise temperature must be positive (K); got {noise_temperature_k!r}")
    eirp = p_tx_dbw - losses_db + np.asarray(gain_tx_dbi)
    return eirp + g_rx_dbi - free_space_loss_db(distance_km, frequency_hz) \
        - 10.0 * np.log10(BOLTZMANN_J_K * noise_temperature_k)


def _position_normal_matrix(los_hat, visible, clock_column: bool):
    """(M, n_visible, satellites needed): M (..., 3, 3) is the matrix whose inverse is the position block of
    (G^T G)^-1 (see :func:`pdop_kernel`)."""
    w = np.asarray(visible, dtype=float)
    los = np.asarray(los_hat, dtype=float)
    n_vis = w.sum(axis=-1)
    if clock_column:
        mean = np.sum(w[..., None] * los, axis=-2) / np.maximum(n_vis, 1.0)[..., None]
        los = los - mean[..., None, :]
    m = np.einsum("...k,...ki,...kj->...ij", w, los, los)
    return m, n_vis, MIN_VISIBLE if clock_column else MIN_VISIBLE - 1


def pdop_kernel(los_hat: np.ndarray, visible: np.ndarray, clock_column: bool = True) -> np.ndarray:
    """PDOP (eq. 5-7) from unit lines of sight (..., n, 3) and a visibility mask (..., n).

    With the clock column, the position block of (G^T G)^-1 is S^-1 with
    S = sum_k (l_k - l_mean)(l_k - l_mean)^T over the visible satellites (the Schur complement of
    the clock, written centred for precision with nearly parallel lines of sight); without it,
    A^-1 with A = sum_k l_k l_k^T. PDOP = sqrt(trace) via the adjugate; NaN with fewer than 4
    visible (3 without clock column), inf for a singular geometry. Eq. 6's pseudo-inverse equals
    the inverse whenever G has full rank.
    """
    m, n_vis, need = _position_normal_matrix(los_hat, visible, clock_column)
    det = np.linalg.det(m)
    cof = (m[..., 1, 1] * m[..., 2, 2] - m[..., 1, 2] ** 2 + m[..., 0, 0] * m[..., 2, 2] - m[..., 0, 2] ** 2
           + m[..., 0, 0] * m[..., 1, 1] - m[..., 0, 1] ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        pdop = np.sqrt(np.where(det > 0.0, cof / det, np.inf))
    return np.where(n_vis >= need, pdop, np.nan)


def pdop_along_axis(los_hat: np.ndarray, visible: np.ndarray, axis_hat: np.ndarray,
                    clock_column: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Split PDOP into the error along ``axis_hat`` (..., 3) and across it: (sigma_along, sigma_across).

    sigma_along^2 = a^T Q a and sigma_across^2 = PDOP^2 - sigma_along^2 with Q the position block of
    (G^T G)^-1 (see :func:`pdop_kernel`); NaN where PDOP is undefined or the geometry singular.
    Taking ``axis_hat`` toward the Earth shows the range / clock degeneracy of nearly parallel
    lines of sight: with the clock column almost all of the PDOP lies along it.
    """
    m, n_vis, need = _position_normal_matrix(los_hat, visible, clock_column)
    ok = (n_vis >= need) & (np.linalg.det(m) > 0.0)
    q = np.full(m.shape, np.nan)
    q[ok] = np.linalg.inv(m[ok])
    a = np.broadcast_to(np.asarray(axis_hat, dtype=float), m.shape[:-1])
    along2 = np.einsum("...i,...ij,...j->...", a, q, a)
    total2 = np.trace(q, axis1=-2, axis2=-1)
    return np.sqrt(along2), np.sqrt(np.clip(total2 - along2, 0.0, None))


def filtered_mean(values, method: str = "percentile95") -> tuple[float, int]:
    """Mean of the finite samples after the filter; returns (mean, samples kept).

    ``percentile95`` (default; the paper's "2-sigma (95th percentile) filter"): samples above the
    95th percentile (linear interpolation, numpy default) are dropped. ``sigma2``: samples with
    |p - mean| > 2 sigma are dropped (eq. 12 with 2 instead of 3). ``none``: plain mean.
    """
    if method not in PDOP_FILTERS:
        raise ValueError(f"unknown PDOP filter {method!r}; allowed: {', '.join(PDOP_FILTERS)}")
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), 0
    if method == "percentile95":
        v = v[v <= np.percentile(v, 95.0)]
    elif method == "sigma2":
        v = v[np.abs(v - v.mean()) <= 2.0 * v.std()]
    return float(v.mean()), int(v.size)


# --------------------------------------------------------------------------------------------
# Transmit gain pattern
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class GainPattern:
    """Transmit gain (dBi) tabulated against off-boresight angle (deg); linear interpolation, NaN outside."""

    off_boresight_deg: np.ndarray
    gain_dbi: np.ndarray
    source: str

    def __call__(self, theta_deg) -> np.ndarray:
        theta = np.asarray(theta_deg, dtype=float)
        gain = np.interp(theta, self.off_boresight_deg, self.gain_dbi)
        inside = (theta >= self.off_boresight_deg[0]) & (theta <= self.off_boresight_deg[-1])
        return np.where(inside, gain, np.nan)

    def with_sidelobes(self, from_deg: float, offset_db: float) -> "GainPattern":
        """The pattern with ``offset_db`` added beyond ``from_deg`` (-inf: main lobe only)."""
        if offset_db == 0.0:
            return self
        gain = np.where(self.off_boresight_deg > from_deg, self.gain_dbi + offset_db, self.gain_dbi)
        return GainPattern(self.off_boresight_deg, gain, f"{self.source}, sidelobes beyond {from_deg} deg "
                                                         f"{offset_db:+g} dB")


def load_gain_pattern(path: str | Path, column: str) -> GainPattern:
    """Gain column ``column`` of a CSV (comment lines '#', column ``off_boresight_deg``)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"gain pattern file not found: {path}")
    table = pd.read_csv(path, comment="#")
    if "off_boresight_deg" not in table.columns:
        raise ValueError(f"{path}: needs a column 'off_boresight_deg'; found {', '.join(table.columns)}")
    if column not in table.columns:
        allowed = [c for c in table.columns if c != "off_boresight_deg"]
        raise ValueError(f"{path}: unknown gain column {column!r}; allowed: {', '.join(allowed)}")
    theta = table["off_boresight_deg"].to_numpy(float)
    if np.any(np.diff(theta) <= 0.0):
        raise ValueError(f"{path}: off_boresight_deg must increase strictly")
    return GainPattern(theta, table[column].to_numpy(float), f"{path.name}:{column}")


def gain_from_profile(profile: dict) -> GainPattern:
    """The profile's transmit pattern: ``gps.gain_file`` / ``gps.gain_column`` with the sidelobe offset."""
    cfg = profile["gps"]
    pattern = load_gain_pattern(data_path(cfg["gain_file"]), cfg["gain_column"])
    return pattern.with_sidelobes(float(cfg["sidelobe_from_deg"]), float(cfg["sidelobe_offset_db"]))


# --------------------------------------------------------------------------------------------
# Orchestration
# --------------------------------------------------------------------------------------------

def _lnss_positions(lnss, times: np.ndarray) -> np.ndarray:
    """(sat, time, 3) Moon-centred J2000 km from a propagation Dataset or an array on ``times``."""
    if isinstance(lnss, xr.Dataset):
        if not np.allclose(lnss["time"].values, times, rtol=0.0, atol=1e-3):
            raise ValueError("LNSS and GPS epochs differ: compute gps_states_mci on the propagation's time coord")
        return lnss["r_mci_km"].transpose("sat", "time", "xyz").values
    r = np.asarray(lnss, dtype=float)
    if r.ndim == 2:
        r = r[None]
    if r.ndim != 3 or r.shape[1:] != (times.size, 3):
        raise ValueError(f"LNSS positions must have shape (sat, {times.size}, 3); got {r.shape}")
    return r


def gps_link(profile: dict, gps: xr.Dataset, lnss, *, sats="first", **overrides) -> xr.Dataset:
    """GPS-LNSS visibility, C/N0 and PDOP (eq. 15-24, Section 2.2.4) on the GPS dataset's epochs.

    ``gps``: from :func:`gps_states_mci`; ``lnss``: a propagation Dataset (``r_mci_km`` (sat, time,
    xyz)) or an array (sat, time, 3) of Moon-centred J2000 km. ``sats``: "first" (the paper's
    choice), "all", or a list of satellite indices. ``overrides``: any ``[gps]`` key (e.g.
    ``noise_temperature_k=150``, ``beam_mask_deg=60``, ``clock_column=False``) or ``gain``: a
    :class:`GainPattern`.

    A link is visible when the Moon does not block it (eq. 17-18), theta_off is inside the beam
    mask, the Earth (eq. 21, with the margin) and the WGS-84 ellipsoid do not block it, and
    C/N0 >= the threshold. The ellipsoid test is done in TEME (z along the true pole of date; polar
    motion, ~10 m, neglected). Dataset dims (sat, time, gps): ``theta_off_deg``, ``range_km``,
    ``gain_dbi``, ``cn0_dbhz``, the blocking masks and ``visible``; (sat, time): ``n_visible``,
    ``pdop`` (NaN below 4 visible).
    """
    cfg = {**profile["gps"], **{k: v for k, v in overrides.items() if k != "gain"}}
    unknown = set(overrides) - set(profile["gps"]) - {"gain"}
    if unknown:
        raise ValueError(f"unknown GPS link setting(s) {sorted(unknown)}; allowed: {sorted(profile['gps'])} or 'gain'")
    gain = overrides.get("gain") or (gain_from_profile({"gps": cfg}) if overrides else gain_from_profile(profile))
    times = gps["time"].values
    r_all = _lnss_positions(lnss, times)
    if isinstance(sats, str):
        if sats not in ("first", "all"):
            raise ValueError(f"sats must be 'first', 'all' or a list of indices; got {sats!r}")
        index = [0] if sats == "first" else list(range(r_all.shape[0]))
    else:
        index = [int(s) for s in sats]
        if any(s < 0 or s >= r_all.shape[0] for s in index):
            raise ValueError(f"satellite index out of range 0..{r_all.shape[0] - 1}: {index}")
    r_lnss = r_all[index][:, :, None, :]                                  # (sat, time, 1, 3)
    earth = gps["earth_mci_km"].values[None, :, None, :]
    r_gps_mci = gps["r_mci_km"].transpose("time", "gps", "xyz").values[None]   # (1, time, gps, 3)
    r_gps_eci = gps["r_eci_km"].transpose("time", "gps", "xyz").values[None]
    r_gps_teme = gps["r_teme_km"].transpose("time", "gps", "xyz").values[None]
    r_lnss_eci = r_lnss - earth
    rot = gps["rot_teme_to_j2000"].values                                  # (time, 3, 3)
    r_lnss_teme = np.einsum("tji,stgj->stgi", rot, r_lnss_eci)

    r_moon = float(profile["constants"]["r_moon_mean_km"])
    r_earth = float(profile["constants"]["r_earth_km"])
    moon_blocked = lunar_occultation(r_lnss, r_gps_mci, r_moon)
    theta = off_boresight_deg(r_gps_eci, r_lnss_eci)
    earth_blocked = earth_occultation(theta, r_gps_eci, r_earth, float(cfg["atmosphere_margin_deg"]))
    b_km = WGS84_A_KM * (1.0 - 1.0 / WGS84_INV_FLATTENING)
    ellipsoid_blocked = ray_hits_ellipsoid(r_gps_teme, r_lnss_teme,
                                           WGS84_A_KM, b_km) if cfg["ellipsoid_test"] else np.zeros_like(theta, bool)
    outside_beam = theta > float(cfg["beam_mask_deg"])
    los = r_gps_mci - r_lnss
    range_km = np.linalg.norm(los, axis=-1)
    g_tx = gain(theta)
    cn0 = cn0_dbhz(g_tx, range_km, p_tx_dbw=float(cfg["p_tx_dbw"]),
                   losses_db=float(cfg["l_tx_db"]) + float(cfg["l_pol_db"]), g_rx_dbi=float(cfg["g_rx_dbi"]),
                   frequency_hz=float(cfg["frequency_mhz"]) * 1e6,
                   noise_temperature_k=float(cfg["noise_temperature_k"]))
    strong = np.nan_to_num(cn0, nan=-np.inf) >= float(cfg["cn0_threshold_dbhz"])
    visible = ~moon_blocked & ~earth_blocked & ~ellipsoid_blocked & ~outside_beam & strong
    pdop = pdop_kernel(los / range_km[..., None], visible, bool(cfg["clock_column"]))

    dims = ("sat", "time", "gps")
    ds = xr.Dataset(
        {
            "theta_off_deg": (dims, theta), "range_km": (dims, range_km), "gain_dbi": (dims, g_tx),
            "cn0_dbhz": (dims, cn0), "moon_blocked": (dims, moon_blocked), "earth_blocked": (dims, earth_blocked),
            "ellipsoid_blocked": (dims, ellipsoid_blocked), "outside_beam": (dims, outside_beam),
            "above_threshold": (dims, strong), "visible": (dims, visible),
            "n_visible": (("sat", "time"), visible.sum(axis=-1)), "pdop": (("sat", "time"), pdop),
        },
        coords={"sat": index, "time": times, "gps": gps["gps"].values, "prn": ("gps", gps["prn"].values),
                "name": ("gps", gps["name"].values)},
        attrs={"gain_pattern": gain.source, "noise_temperature_k": float(cfg["noise_temperature_k"]),
               "beam_mask_deg": float(cfg["beam_mask_deg"]), "clock_column": int(bool(cfg["clock_column"])),
               "cn0_threshold_dbhz": float(cfg["cn0_threshold_dbhz"]), "pdop_filter": cfg["pdop_filter"],
               "frame": "Moon-centred J2000", "time_scale": "TDB seconds past J2000"},
    )
    ds["pdop"].attrs["long_name"] = "GPS-LNSS PDOP (eq. 5-7), NaN with fewer than 4 visible"
    ds["cn0_dbhz"].attrs["long_name"] = "C/N0 at the LNSS receiver (eq. 24), dB-Hz"
    return ds


def gps_link_summary(ds: xr.Dataset, pdop_filter: str | None = None) -> dict[str, float]:
    """Means over every (sat, time) sample of :func:`gps_link`'s result.

    ``gps_visible_mean``: visible GPS satellites averaged over all epochs, zeros included;
    ``gps_pdop_mean``: filtered mean PDOP (:func:`filtered_mean`, default the dataset's filter)
    over the epochs with >= 4 visible; also the unfiltered mean and median, the fraction of epochs
    with a PDOP and the number of samples the filter kept.
    """
    method = pdop_filter or ds.attrs["pdop_filter"]
    pdop = ds["pdop"].values
    mean, kept = filtered_mean(pdop, method)
    finite = pdop[np.isfinite(pdop)]
    return {
        "gps_visible_mean": float(ds["n_visible"].mean()),
        "gps_pdop_mean": mean,
        "gps_pdop_unfiltered_mean": float(finite.mean()) if finite.size else float("nan"),
        "gps_pdop_median": float(np.median(finite)) if finite.size else float("nan"),
        "gps_pdop_available_fraction": float(np.isfinite(pdop).mean()),
        "gps_pdop_samples_kept": kept,
    }


def gps_link_sensitivity(profile: dict, gps: xr.Dataset, lnss, variants: dict[str, dict], *,
                         sats="first") -> pd.DataFrame:
    """Summary (:func:`gps_link_summary`) of :func:`gps_link` for each named set of ``[gps]`` overrides.

    ``variants`` maps a label to overrides (``{}`` = the profile's settings); a ``pdop_filter`` key
    changes only the summary's filter. Returns one row per variant.
    """
    rows = []
    for label, over in variants.items():
        over = dict(over)
        method = over.pop("pdop_filter", None)
        ds = gps_link(profile, gps, lnss, sats=sats, **over)
        rows.append({"variant": label, **gps_link_summary(ds, method)})
    return pd.DataFrame(rows).set_index("variant")


def link_budget_table(profile: dict, theta_off_deg, distance_km: float, **overrides) -> pd.DataFrame:
    """Table 1 / eq. 22-24 budget terms against off-boresight angle at one GPS-LNSS distance.

    Columns: gain_dbi, eirp_dbw, fsl_db, g_rx_dbi, ktn_dbw_hz (10 log10 k T), cn0_dbhz and
    receivable (C/N0 >= threshold). ``overrides``: ``[gps]`` keys as in :func:`gps_link`.
    """
    unknown = set(overrides) - set(profile["gps"])
    if unknown:
        raise ValueError(f"unknown GPS link setting(s) {sorted(unknown)}; allowed: {sorted(profile['gps'])}")
    cfg = {**profile["gps"], **overrides}
    theta = np.atleast_1d(np.asarray(theta_off_deg, dtype=float))
    gain = gain_from_profile({"gps": cfg})(theta)
    losses = float(cfg["l_tx_db"]) + float(cfg["l_pol_db"])
    freq = float(cfg["frequency_mhz"]) * 1e6
    cn0 = cn0_dbhz(gain, distance_km, p_tx_dbw=float(cfg["p_tx_dbw"]), losses_db=losses,
                   g_rx_dbi=float(cfg["g_rx_dbi"]), frequency_hz=freq,
                   noise_temperature_k=float(cfg["noise_temperature_k"]))
    return pd.DataFrame({
        "off_boresight_deg": theta, "gain_dbi": gain, "eirp_dbw": float(cfg["p_tx_dbw"]) - losses + gain,
        "fsl_db": free_space_loss_db(np.full(theta.shape, float(distance_km)), freq),
        "g_rx_dbi": float(cfg["g_rx_dbi"]),
        "ktn_dbw_hz": 10.0 * np.log10(BOLTZMANN_J_K * float(cfg["noise_temperature_k"])),
        "cn0_dbhz": cn0, "receivable": np.nan_to_num(cn0, nan=-np.inf) >= float(cfg["cn0_threshold_dbhz"]),
    }).set_index("off_boresight_deg")


# --------------------------------------------------------------------------------------------
# Analysis: tables and diagnostics of the GPS-LNSS link (paper Table 1, Table 4, Figure 7)
# --------------------------------------------------------------------------------------------

PAPER_TABLE_4 = {key: _PAPER[key] for key in ("gps_visible_mean", "gps_pdop_mean")}
GAIN_COLUMNS = ("improved_panel_dbi", "legacy_iir_dbi", "iirm_dbavg_dbi", "iirm_min_dbi", "iirm_max_dbi")
GPS_ORBIT_RADIUS_KM = 26560.0          # nominal, for the off-boresight schematic
MEAN_EARTH_MOON_KM = 384400.0          # mean Earth-Moon distance of the link-budget tables
LINK_STATUS = ("Moon blocks", "Earth (+margin) blocks", "outside beam", "C/N0 < 15 dB-Hz", "visible")


def catalogue_table(catalogue: pd.DataFrame, start_tdb: str) -> pd.DataFrame:
    """:func:`gps_catalogue`'s table with ``days_back_from_tle`` (TLE epoch - simulation start date, days:
    how far SGP4 runs backwards) and the dates as ISO text."""
    start = pd.Timestamp(start_tdb[:10])
    out = catalogue.copy()
    out["days_back_from_tle"] = [(pd.Timestamp(e) - start).total_seconds() / 86400.0 for e in out["tle_epoch_utc"]]
    return out.astype({"launch_date": str, "tle_epoch_utc": str})


def off_boresight_limits(profile: dict, distance_km: float = MEAN_EARTH_MOON_KM,
                         r_gps_km: float = GPS_ORBIT_RADIUS_KM, step_deg: float = 0.1) -> dict[str, float]:
    """Angles (deg) that split the GPS transmit cone for a receiver at ``distance_km`` (eq. 19-24).

    ``earth_limb_deg`` asin(R_earth / r_GPS), ``limb_with_margin_deg`` (+ the atmospheric margin,
    eq. 21), ``sidelobe_from_deg``, ``last_receivable_deg`` (largest angle inside the beam mask with
    C/N0 >= threshold on a ``step_deg`` grid over 0-90 deg) and ``beam_mask_deg``; also the radii
    ``r_gps_km`` and ``r_earth_km``.
    """
    cfg = profile["gps"]
    r_earth = float(profile["constants"]["r_earth_km"])
    alpha = np.degrees(np.arcsin(r_earth / r_gps_km))
    fine = np.arange(0.0, 90.01, step_deg)
    receivable = link_budget_table(profile, fine, distance_km)["receivable"].values
    inside = (fine <= cfg["beam_mask_deg"]) & receivable
    if not inside.any():
        raise ValueError(f"no off-boresight angle inside the {cfg['beam_mask_deg']} deg beam mask reaches "
                         f"{cfg['cn0_threshold_dbhz']} dB-Hz at {distance_km} km")
    return {"earth_limb_deg": float(alpha), "limb_with_margin_deg": float(alpha + float(cfg["atmosphere_margin_deg"])),
            "sidelobe_from_deg": float(cfg["sidelobe_from_deg"]), "last_receivable_deg": float(fine[inside].max()),
            "beam_mask_deg": float(cfg["beam_mask_deg"]), "r_gps_km": float(r_gps_km), "r_earth_km": r_earth}


def cn0_curves(profile: dict, theta_off_deg, distance_km: float, variants: dict[str, dict]) -> pd.DataFrame:
    """C/N0 (dB-Hz, eq. 22-24) against off-boresight angle (index) for each named set of ``[gps]`` overrides."""
    theta = np.atleast_1d(np.asarray(theta_off_deg, dtype=float))
    curves = {label: link_budget_table(profile, theta, distance_km, **over)["cn0_dbhz"].values
              for label, over in variants.items()}
    return pd.DataFrame(curves, index=pd.Index(theta, name="off_boresight_deg"))


def earth_plane_projection(r_gps_mci_km: np.ndarray, earth_mci_km: np.ndarray,
                           r_lnss_mci_km: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GPS positions seen from an LNSS satellite, projected on the plane through the Earth's centre
    perpendicular to the LNSS -> Earth direction: (x_km, y_km) (time, gps) and that direction (time, 3).

    Inputs Moon-centred J2000 km: ``r_gps_mci_km`` (time, gps, 3), ``earth_mci_km`` and
    ``r_lnss_mci_km`` (time, 3). x is along e_hat x z_J2000, y completes the right-handed pair.
    """
    to_earth = np.asarray(earth_mci_km, dtype=float) - np.asarray(r_lnss_mci_km, dtype=float)
    e_hat = to_earth / np.linalg.norm(to_earth, axis=-1, keepdims=True)
    u1 = np.cross(e_hat, [0.0, 0.0, 1.0])
    u1 /= np.linalg.norm(u1, axis=-1, keepdims=True)
    u2 = np.cross(e_hat, u1)
    rel = np.asarray(r_gps_mci_km, dtype=float) - np.asarray(earth_mci_km, dtype=float)[:, None, :]
    return np.einsum("tgi,ti->tg", rel, u1), np.einsum("tgi,ti->tg", rel, u2), e_hat


def link_status(link_one: xr.Dataset) -> np.ndarray:
    """Label (:data:`LINK_STATUS`) of every (time, gps) link of one satellite of :func:`gps_link`: the first
    test that fails (Moon, Earth or ellipsoid, beam, C/N0), else ``visible``."""
    return np.select([link_one["moon_blocked"].values,
                      (link_one["earth_blocked"] | link_one["ellipsoid_blocked"]).values,
                      link_one["outside_beam"].values, ~link_one["above_threshold"].values],
                     list(LINK_STATUS[:4]), LINK_STATUS[4])


def link_test_counts(link_one: xr.Dataset) -> pd.Series:
    """How many (gps, epoch) pairs of one satellite each test removes, and how many stay visible."""
    visible = link_one["visible"].values
    return pd.Series({
        "all (gps, epoch) pairs": visible.size,
        "Moon blocks": int(link_one["moon_blocked"].sum()),
        "Earth + margin blocks (eq. 21)": int(link_one["earth_blocked"].sum()),
        "WGS-84 ray test blocks (beyond eq. 21)": int((link_one["ellipsoid_blocked"] & ~link_one["earth_blocked"]).sum()),
        "outside beam mask": int(link_one["outside_beam"].sum()),
        "C/N0 below threshold (geometry ok)": int((~link_one["above_threshold"] & ~link_one["moon_blocked"]
                                                   & ~link_one["earth_blocked"] & ~link_one["outside_beam"]).sum()),
        "visible": int(visible.sum()),
    })


def visible_share_by_prn(link_one: xr.Dataset) -> pd.Series:
    """Share of epochs at which each GPS satellite (index: PRN, sorted) is visible to one LNSS satellite."""
    return pd.Series(link_one["visible"].values.mean(axis=0), index=link_one["prn"].values).sort_index()


def main_lobe_share(link_one: xr.Dataset, sidelobe_from_deg: float) -> float:
    """Share of the visible links of one satellite with theta_off below ``sidelobe_from_deg`` (main-lobe edge)."""
    theta = link_one["theta_off_deg"].values[link_one["visible"].values]
    return float(np.mean(theta < sidelobe_from_deg))


def paper_comparison_table(summary: dict, paper: dict | None = None) -> pd.DataFrame:
    """Mean visible GPS and filtered mean PDOP (:func:`gps_link_summary`) beside Table 4, with their ratio."""
    paper = PAPER_TABLE_4 if paper is None else paper
    table = pd.DataFrame({"this work": [summary["gps_visible_mean"], summary["gps_pdop_mean"]],
                          "paper (Table 4)": [paper["gps_visible_mean"], paper["gps_pdop_mean"]]},
                         index=["mean visible GPS", "mean PDOP (95th-percentile filter)"])
    table["ratio"] = table["this work"] / table["paper (Table 4)"]
    return table


def decomposition_table(pdop, along, across, pdop_no_clock) -> pd.DataFrame:
    """Median, 95th-percentile-filtered mean and unfiltered mean of the PDOP (eq. 5-7), its parts along
    and across the Earth direction (:func:`pdop_along_axis`) and the PDOP without the clock column."""
    series = [np.asarray(v, dtype=float) for v in (pdop, along, across, pdop_no_clock)]
    return pd.DataFrame({
        "median": [np.nanmedian(v) for v in series],
        "95th-percentile-filtered mean": [filtered_mean(v)[0] for v in series],
        "unfiltered mean": [np.nanmean(v) for v in series],
    }, index=["PDOP (eq. 5-7, clock column)", "  error along the Earth direction", "  error across it",
              "PDOP without clock column"])


def pdop_split(profile: dict, gps: xr.Dataset, lnss: xr.Dataset, link: xr.Dataset | None = None) -> dict[str, np.ndarray]:
    """PDOP of the first LNSS satellite of a propagation at every epoch (``pdop``), its parts ``along`` and
    ``across`` the LNSS -> Earth direction (:func:`pdop_along_axis`) and ``pdop_no_clock`` (eq. 5-7 without
    the clock column); ``link``: its :func:`gps_link` (computed when not given)."""
    link = gps_link(profile, gps, lnss) if link is None else link
    first = link.isel(sat=0)
    r_lnss = lnss["r_mci_km"].transpose("sat", "time", "xyz").values[0]
    to_earth = gps["earth_mci_km"].values - r_lnss
    e_hat = to_earth / np.linalg.norm(to_earth, axis=-1, keepdims=True)
    los = gps["r_mci_km"].transpose("time", "gps", "xyz").values - r_lnss[:, None, :]
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    along, across = pdop_along_axis(los, first["visible"].values, e_hat)
    no_clock = gps_link(profile, gps, lnss, clock_column=False)
    return {"pdop": first["pdop"].values, "along": along, "across": across,
            "pdop_no_clock": no_clock["pdop"].values[0]}


def pdop_decomposition(profile: dict, gps: xr.Dataset, lnss: xr.Dataset, link: xr.Dataset | None = None) -> pd.DataFrame:
    """:func:`decomposition_table` of :func:`pdop_split`: why the GPS-LNSS PDOP is so large."""
    return decomposition_table(**pdop_split(profile, gps, lnss, link))


def sensitivity_variants(profile: dict) -> dict[str, dict]:
    """The one-at-a-time ``[gps]`` variants of the sensitivity study (labels -> overrides): noise temperature,
    gain column, sidelobe level, beam mask, atmospheric margin, ellipsoid test, clock column and filter."""
    default_column = profile["gps"]["gain_column"]
    variants: dict[str, dict] = {"default": {}}
    variants.update({f"T = {t:.0f} K": {"noise_temperature_k": t} for t in (100.0, 150.0, 230.0, 270.0, 300.0, 350.0, 400.0)})
    variants.update({f"gain {c}": {"gain_column": c} for c in GAIN_COLUMNS if c != default_column})
    variants.update({f"sidelobes {o:+g} dB": {"sidelobe_offset_db": o} for o in (-6.0, -3.0, -1.0, 1.0, 3.0, 6.0)})
    variants["main lobe only"] = {"sidelobe_offset_db": -np.inf}
    variants.update({f"beam mask {b:.0f} deg": {"beam_mask_deg": b} for b in (30.0, 40.0, 50.0, 60.0, 80.0, 90.0)})
    variants["no atmospheric margin"] = {"atmosphere_margin_deg": 0.0}
    variants["no ellipsoid test"] = {"ellipsoid_test": False}
    variants["no clock column"] = {"clock_column": False}
    variants["filter: 2-sigma clip"] = {"pdop_filter": "sigma2"}
    variants["filter: none"] = {"pdop_filter": "none"}
    return variants


def sensitivity_table(profile: dict, gps: xr.Dataset, lnss: xr.Dataset, elements_deg, *,
                      phase_shifts_days=(-30.0, -7.0, 7.0, 30.0), paper: dict | None = None) -> pd.DataFrame:
    """Summary of the first satellite's link for every :func:`sensitivity_variants` entry, then for a
    Keplerian orbit, the elements referred to the J2000 equator, and GPS phases shifted by running SGP4
    at t + shift; column ``pdop_ratio_to_paper`` divides the mean PDOP by Table 4's.

    ``lnss``: the propagation of ``elements_deg`` (nsat, 6) with ``profile``; ``gps`` on its epochs.
    """
    from .config import deep_merge
    from .constellation import two_body_positions_mci
    from .propagator import propagate_elements

    paper = PAPER_TABLE_4 if paper is None else paper
    el = np.asarray(elements_deg, dtype=float)
    times = lnss["time"].values
    sens = gps_link_sensitivity(profile, gps, lnss, sensitivity_variants(profile))
    extra = {"Keplerian ELFO orbit": gps_link_summary(gps_link(profile, gps, two_body_positions_mci(profile, el[:1], times)))}
    p_j2000 = deep_merge(profile, {"frames": {"element_frame": "j2000"}})
    extra["elements in J2000 equator"] = gps_link_summary(gps_link(p_j2000, gps, propagate_elements(p_j2000, el[:1])))
    for shift_days in phase_shifts_days:
        shifted = gps_states_mci(profile, times, sgp4_offset_s=shift_days * 86400.0)
        extra[f"GPS phase: SGP4 at t {shift_days:+.0f} d"] = gps_link_summary(gps_link(profile, shifted, lnss))
    sens = pd.concat([sens, pd.DataFrame(extra).T])
    sens["pdop_ratio_to_paper"] = sens["gps_pdop_mean"] / paper["gps_pdop_mean"]
    return sens


def per_satellite_summary(link_all: xr.Dataset) -> pd.DataFrame:
    """:func:`gps_link_summary` of each LNSS satellite of a ``sats="all"`` :func:`gps_link` (index: satellite,
    an explicit integer index so that tables keep it)."""
    sats = [int(s) for s in link_all["sat"].values]
    table = pd.DataFrame({s: gps_link_summary(link_all.sel(sat=[s])) for s in sats}).T
    table.index = pd.Index(sats, dtype="int64", name="satellite")
    return table


def pdop_at_visible_count(sens: pd.DataFrame, n_visible: float, prefix: str = "T = ") -> float:
    """Mean PDOP at ``n_visible`` mean visible GPS satellites, log-linearly interpolated along the sweep of
    :func:`sensitivity_table` rows whose label starts with ``prefix`` (default: the noise temperature) plus
    ``default``."""
    rows = [k for k in sens.index if k.startswith(prefix)] + ["default"]
    sweep = sens.loc[rows].sort_values("gps_visible_mean")
    return float(np.exp(np.interp(n_visible, sweep["gps_visible_mean"], np.log(sweep["gps_pdop_mean"]))))


def sensitivity_findings(sens: pd.DataFrame, decomposition: pd.DataFrame, main_share: float,
                         paper: dict | None = None) -> list[str]:
    """Markdown bullet lines with the key numbers of a run: visibility and PDOP against Table 4, main-lobe
    share, PDOP decomposition, the gain-column, noise-temperature and filter sensitivities, and the PDOP
    that the noise-temperature sweep gives at the paper's visible count."""
    paper = PAPER_TABLE_4 if paper is None else paper
    d = sens.loc["default"]
    s = sens["gps_pdop_mean"]
    v = sens["gps_visible_mean"]
    at_paper = pdop_at_visible_count(sens, paper["gps_visible_mean"])
    return [
        f"- mean visible GPS: **{d['gps_visible_mean']:.2f}** (paper {paper['gps_visible_mean']}); mean PDOP "
        f"(95th-percentile filter): **{d['gps_pdop_mean']:.0f}** (paper {paper['gps_pdop_mean']:.0f}, ratio "
        f"{d['gps_pdop_mean'] / paper['gps_pdop_mean']:.2f}); "
        f"epochs with a PDOP: {100 * d['gps_pdop_available_fraction']:.1f}%",
        f"- visible links in the main-lobe edge: {100 * main_share:.1f}%, in sidelobes: {100 * (1 - main_share):.1f}%",
        f"- PDOP error along the Earth direction (median) {decomposition.iloc[1]['median']:.0f}, across it "
        f"{decomposition.iloc[2]['median']:.1f}; without clock column the mean PDOP is {s['no clock column']:.1f}",
        f"- legacy IIR column: {v['gain legacy_iir_dbi']:.2f} visible, PDOP {s['gain legacy_iir_dbi']:.0f} (prototype ~650)",
        f"- T = 100 / 300 / 400 K: visible {v['T = 100 K']:.2f} / {v['T = 300 K']:.2f} / {v['T = 400 K']:.2f}, PDOP "
        f"{s['T = 100 K']:.0f} / {s['T = 300 K']:.0f} / {s['T = 400 K']:.0f}",
        f"- filters: 95th percentile {d['gps_pdop_mean']:.0f}, 2-sigma clip {s['filter: 2-sigma clip']:.0f}, "
        f"none {s['filter: none']:.0f}",
        f"- along the noise-temperature sweep, {paper['gps_visible_mean']} visible satellites go with a mean PDOP of "
        f"about {at_paper:.0f}: the paper's {paper['gps_pdop_mean']:.0f} is {paper['gps_pdop_mean'] / at_paper:.1f} times "
        "that. Since the along-Earth error scales as 1 / (N^(1/2) x spread of rho^2), the paper's PDOP would need the "
        f"visible lines of sight about {np.sqrt(paper['gps_pdop_mean'] / at_paper):.1f} times less spread in angle at "
        "the same count",
    ]
