"""Published lunar navigation constellations (``params/constellations/``) and user files in the same format.

A catalogue file (format in ``params/constellations/README.md``) gives Keplerian elements in a named
element frame, with an epoch and time scale (or ``"not given"``) and mean or true anomalies.
:func:`load_constellation` reads and checks one; :func:`constellation_states_mci` turns it into
Moon-centred J2000 states; :func:`evaluate_catalogue` measures it with the design evaluator (eq. 45).

Element frames of a file (``element_frame``) and the rotation used for each:

- ``moon_op``: Moon orbital-plane frame of Ely (2005) built at the epoch used
  (:func:`lnss_lib.frames.moon_op_to_j2000`).
- ``moon_j2000_eq`` (GMAT ``MoonMJ2000Eq``: Earth mean equator and equinox of J2000, IAU-1976/FK5)
  and ``moon_ci`` (LuPNT ``MOON_CI``: ICRF axes): both taken as SPICE ``J2000`` axes. The frame bias
  between FK5 J2000 and the ICRF is about 23 mas (1.1e-7 rad): 1 mm at 10 000 km, far below
  anything the workbook resolves.
- ``j2000`` and ``lunar_equator_of_epoch``: the workbook's own element frames
  (:func:`lnss_lib.frames.element_frame_to_j2000`), accepted in user files.

Which epoch (``epoch`` argument, recorded in ``CatalogueStates.epoch_source``):

- ``"study"`` (default): the elements are read at the study epoch (the profile's
  ``epoch.start_tdb``), in their frame built at that epoch. These are design geometries (frozen
  orbits specified relative to the Moon's orbit plane or equator), so the same geometry at the
  study epoch is the like-for-like comparison over the study's span and grid. For ``moon_ci`` /
  ``moon_j2000_eq`` files this keeps the inertial orientation the file gives, which is not the
  same geometry relative to the Moon at another epoch: the notebook says so beside the numbers.
- ``"file"``: the states at the file's own epoch (an error if the file gives none). To evaluate
  there, :func:`file_epoch_profile` moves the profile's epoch; propagating the file's elements over
  decades to the study epoch would neither be practical nor keep the design (station keeping is
  what keeps an ELFO frozen).

Approximate entries (``approximate = true``, the Moonlight description) publish no eccentricity,
inclination, node, perilune or phasing: they are listed with ``approximate = True`` and load, but
:func:`constellation_states_mci` and :func:`evaluate_catalogue` refuse them with a
:class:`~lnss_lib.errors.ConfigError` rather than invent a geometry.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .config import PARAMS_DIR, read_toml
from .constants import INTEGER_SETTING_MAX
from .dates import ISO_FORMAT, parse_iso_date
from .elements import mean_anomaly_from_true, validate_elements
from .ephemeris import ensure_kernels, tdb_iso, tdb_seconds
from .errors import ConfigError, InfeasibleDesignError, InvalidOrbitError
from .frames import element_frame_to_j2000
from .settings import Dynamics, Settings, load_settings

__all__ = [
    "CATALOGUE_DIR",
    "FILE_FRAMES",
    "CatalogueConstellation",
    "CatalogueStates",
    "list_catalogue",
    "load_constellation",
    "true_to_mean_anomaly_deg",
    "constellation_states_mci",
    "file_epoch_profile",
    "analyse_catalogue",
    "evaluate_catalogue",
    "refuse_approximate",
]

CATALOGUE_DIR = PARAMS_DIR / "constellations"
NOT_GIVEN = "not given"
FILE_FRAMES = {  # file's element_frame -> frames.element_frame_to_j2000 frame
    "moon_op": "moon_op",
    "moon_j2000_eq": "j2000",
    "moon_ci": "j2000",
    "j2000": "j2000",
    "lunar_equator_of_epoch": "lunar_equator_of_epoch",
}
TIME_SCALES = ("TDB", "UTC")
ANOMALIES = ("mean", "true")
EPOCH_CHOICES = ("study", "file")
TOP_KEYS_REQUIRED = ("name", "element_frame", "epoch", "anomaly", "approximate", "satellite")
TOP_KEYS_OPTIONAL = ("reference", "source", "time_scale", "notes", "published")
SAT_ELEMENT_KEYS = ("a_km", "e", "inc_deg", "raan_deg", "aop_deg", "anomaly_deg")
SAT_APPROX_KEYS = ("a_km", "orbital_period_h")
EXTRA_RESULT_KEYS = ("name", "approximate", "element_frame", "epoch_used", "epoch_source")


@dataclass(frozen=True)
class CatalogueConstellation:
    """One constellation file, checked. Angles in degrees, ``a_km`` in km.

    ``elements_deg`` (n, 6) ``[a_km, e, inc_deg, raan_deg, aop_deg, M_deg]`` in ``element_frame``,
    with the MEAN anomaly (converted from the file's true anomaly where ``anomaly == "true"``), or
    None for an approximate entry. ``epoch``/``time_scale`` are None where the file says
    "not given". ``approximate_a_km``: the rounded semi-major axes of an approximate entry.
    """

    key: str
    path: Path
    name: str
    reference: str
    source: str
    element_frame: str | None
    epoch: str | None
    time_scale: str | None
    anomaly: str | None
    approximate: bool
    satellite_names: tuple[str, ...]
    elements_deg: np.ndarray | None
    anomaly_as_written_deg: np.ndarray | None
    approximate_a_km: np.ndarray | None
    published: dict = field(default_factory=dict)
    notes: str = ""

    @property
    def n_sat(self) -> int:
        return len(self.satellite_names)


@dataclass(frozen=True)
class CatalogueStates:
    """Moon-centred J2000 states (n, 6) km, km/s of a constellation at ``t_epoch_tdb_s``.

    ``epoch_used``: that epoch as a TDB calendar string; ``epoch_source``: ``"file"`` or
    ``"study epoch (file gives none)"`` / ``"study epoch (file gives <epoch> <scale>)"``;
    ``rot_to_j2000``: the element-frame rotation used (x_j2000 = R x_frame).
    """

    states_mci: np.ndarray
    t_epoch_tdb_s: float
    epoch_used: str
    epoch_source: str
    element_frame: str
    rot_to_j2000: np.ndarray


def _fail(path: Path, key: str, message: str) -> ConfigError:
    return ConfigError(f"{path}: key {key!r}: {message}", key=key, source=str(path))


def _string(path: Path, data: dict, key: str, label: str | None = None) -> str:
    value = data[key]
    if not isinstance(value, str):
        raise _fail(path, label or key, f"must be a string; got {value!r} ({type(value).__name__})")
    return value


def _number(path: Path, value, label: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(path, label, f"must be a number; got {value!r} ({type(value).__name__})")
    if (
        isinstance(value, int) and abs(value) > INTEGER_SETTING_MAX
    ):  # float() of it raised OverflowError
        raise _fail(
            path, label, f"must be a finite number; got an integer of {value.bit_length()} bits"
        )
    if not math.isfinite(float(value)):
        raise _fail(path, label, f"must be finite; got {value!r}")
    return float(value)


def _check_keys(path: Path, table: dict, required, optional, where: str) -> None:
    for key in required:
        if key not in table:
            raise _fail(path, f"{where}{key}", "missing (required)")
    unknown = sorted(set(table) - set(required) - set(optional))
    if unknown:
        allowed = ", ".join(list(required) + list(optional))
        raise _fail(path, f"{where}{unknown[0]}", f"unknown key; allowed: {allowed}")


def true_to_mean_anomaly_deg(true_anomaly_deg, e) -> np.ndarray:
    """Mean anomaly (deg, [0, 360)) of elliptic orbits from the true anomaly (deg) and eccentricity.

    E = 2 atan2(sqrt(1 - e) sin(nu / 2), sqrt(1 + e) cos(nu / 2)), M = E - e sin E (Kepler).
    """
    nu = np.radians(np.asarray(true_anomaly_deg, dtype=float))
    ecc = np.asarray(e, dtype=float)
    if np.any(~np.isfinite(ecc) | (ecc < 0.0) | (ecc >= 1.0)):
        raise ValueError(f"eccentricity must be in [0, 1); got {ecc!r}")
    return np.mod(np.degrees(mean_anomaly_from_true(nu, ecc)), 360.0)


def _resolve(name_or_path: str | Path) -> Path:
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise FileNotFoundError(f"constellation file not found: {path}")
        return path
    candidate = CATALOGUE_DIR / f"{name_or_path}.toml"
    if not candidate.is_file():
        names = ", ".join(p.stem for p in sorted(CATALOGUE_DIR.glob("*.toml")))
        raise ValueError(
            f"unknown constellation {str(name_or_path)!r}: neither a file nor a catalogue name; "
            f"catalogue: {names}"
        )
    return candidate


def _parse_satellites(path: Path, sats, approximate: bool, floor_km: float):
    if not isinstance(sats, list) or not sats or not all(isinstance(s, dict) for s in sats):
        raise _fail(path, "satellite", "must be one or more [[satellite]] tables")
    names, rows = [], []
    keys = SAT_APPROX_KEYS if approximate else SAT_ELEMENT_KEYS
    for k, sat in enumerate(sats):
        where = f"satellite[{k}]."
        required = ("a_km",) if approximate else SAT_ELEMENT_KEYS
        _check_keys(path, sat, required, ("name",) + tuple(set(keys) - set(required)), where)
        name = _string(path, sat, "name", where + "name") if "name" in sat else f"sat{k + 1}"
        if name in names:
            raise _fail(path, where + "name", f"duplicate satellite name {name!r}")
        values = {key: _number(path, sat[key], where + key) for key in keys if key in sat}
        e = values.get("e", 0.0)
        if not 0.0 <= e < 1.0:
            raise _fail(path, where + "e", f"must be in [0, 1) (closed orbits); got {e!r}")
        if not approximate and not 0.0 <= values["inc_deg"] <= 180.0:
            raise _fail(
                path, where + "inc_deg", f"must be in [0, 180] deg; got {values['inc_deg']!r}"
            )
        try:  # the check of every element set (flags, profiles, explorer): above the surface, inside the Hill sphere
            validate_elements(values["a_km"], e, 0.0 if approximate else floor_km)
        except InvalidOrbitError as error:
            raise _fail(path, where + "a_km", str(error)) from None
        names.append(name)
        rows.append([values.get(key, math.nan) for key in keys])
    return tuple(names), np.array(rows, dtype=float)


def load_constellation(
    name_or_path: str | Path, dynamics: Dynamics | None = None
) -> CatalogueConstellation:
    """A checked :class:`CatalogueConstellation` from a catalogue name (file stem) or a TOML path.

    Raises :class:`~lnss_lib.errors.ConfigError` naming the file and the bad key for a malformed
    file (missing or unknown key, wrong type, non-finite value, e outside [0, 1), unknown frame,
    anomaly type or time scale, unreadable epoch, perilune below the surface). ``dynamics`` supplies
    the surface (``constants.r_moon_mean_km`` + ``impact.min_altitude_km``; default: the paper's).
    """
    path = _resolve(name_or_path)
    data = read_toml(path)
    floor_km = (dynamics if dynamics is not None else load_settings("paper").dynamics).r_impact_km
    _check_keys(path, data, TOP_KEYS_REQUIRED, TOP_KEYS_OPTIONAL, "")
    approximate = data["approximate"]
    if not isinstance(approximate, bool):
        raise _fail(path, "approximate", f"must be true or false; got {approximate!r}")
    text = {key: _string(path, data, key) for key in ("name", "element_frame", "epoch", "anomaly")}
    text.update(
        {
            key: _string(path, data, key)
            for key in ("reference", "source", "notes", "time_scale")
            if key in data
        }
    )
    frame, anomaly = text["element_frame"], text["anomaly"]
    if not (frame in FILE_FRAMES or (approximate and frame == NOT_GIVEN)):
        raise _fail(
            path, "element_frame", f"unknown frame {frame!r}; allowed: {', '.join(FILE_FRAMES)}"
        )
    if not (anomaly in ANOMALIES or (approximate and anomaly == NOT_GIVEN)):
        raise _fail(path, "anomaly", f"must be one of {', '.join(ANOMALIES)}; got {anomaly!r}")
    epoch, scale = text["epoch"], text.get("time_scale", NOT_GIVEN)
    if epoch != NOT_GIVEN:
        try:
            parse_iso_date(epoch)
        except ConfigError:
            raise _fail(
                path, "epoch", f"must be {ISO_FORMAT} or {NOT_GIVEN!r}; got {epoch!r}"
            ) from None
        if scale not in TIME_SCALES:
            raise _fail(
                path,
                "time_scale",
                f"must be one of {', '.join(TIME_SCALES)} when an epoch is given; got {scale!r}",
            )
    elif scale not in TIME_SCALES + (NOT_GIVEN,):
        raise _fail(
            path,
            "time_scale",
            f"must be one of {', '.join(TIME_SCALES + (NOT_GIVEN,))}; got {scale!r}",
        )
    published = data.get("published", {})
    if not isinstance(published, dict):
        raise _fail(path, "published", "must be a table")
    names, rows = _parse_satellites(path, data["satellite"], approximate, floor_km)
    elements = written = approx_a = None
    if approximate:
        approx_a = rows[:, 0]
    else:
        elements = rows.copy()
        written = rows[:, 5].copy()
        if anomaly == "true":
            elements[:, 5] = true_to_mean_anomaly_deg(rows[:, 5], rows[:, 1])
        elements[:, 3:] = np.mod(elements[:, 3:], 360.0)
    return CatalogueConstellation(
        key=path.stem,
        path=path,
        name=text["name"],
        reference=text.get("reference", ""),
        source=text.get("source", ""),
        element_frame=None if frame == NOT_GIVEN else frame,
        epoch=None if epoch == NOT_GIVEN else epoch,
        time_scale=None if epoch == NOT_GIVEN else scale,
        anomaly=None if anomaly == NOT_GIVEN else anomaly,
        approximate=approximate,
        satellite_names=names,
        elements_deg=elements,
        anomaly_as_written_deg=written,
        approximate_a_km=approx_a,
        published=published,
        notes=text.get("notes", ""),
    )


def list_catalogue(dynamics: Dynamics | None = None) -> list[dict]:
    """One row per catalogue file: key, n_sat, element_frame, epoch, time_scale, anomaly, approximate, name
    (``dynamics``: the surface, as :func:`load_constellation`)."""
    rows = []
    for path in sorted(CATALOGUE_DIR.glob("*.toml")):
        c = load_constellation(path, dynamics)
        rows.append(
            {
                "key": c.key,
                "n_sat": c.n_sat,
                "element_frame": c.element_frame,
                "epoch": c.epoch,
                "time_scale": c.time_scale,
                "anomaly": c.anomaly,
                "approximate": c.approximate,
                "name": c.name,
            }
        )
    return rows


def refuse_approximate(c: CatalogueConstellation) -> None:
    """ConfigError for an approximate entry (no geometry to evaluate)."""
    if c.approximate:
        raise ConfigError(
            f"{c.path}: {c.key!r} is an approximate entry (approximate = true): its sources give no eccentricity, "
            "inclination, node, perilune or phasing, so it has no geometry to evaluate. Write a user file with "
            "assumed elements (and say they are assumed) to study it.",
            key="approximate",
            source=str(c.path),
        )


def _file_epoch_tdb_s(c: CatalogueConstellation) -> float:
    if c.epoch is None:
        raise ConfigError(
            f"{c.path}: the file gives no epoch; use epoch='study'", key="epoch", source=str(c.path)
        )
    return tdb_seconds(c.epoch, c.time_scale)


def _states_at(
    dynamics: Dynamics, c: CatalogueConstellation, t0_tdb_s: float, source: str
) -> CatalogueStates:
    from .propagator import elements_deg_to_states

    frame = FILE_FRAMES[c.element_frame]
    framed = dataclasses.replace(
        dynamics, frames=dataclasses.replace(dynamics.frames, element_frame=frame)
    )
    states = elements_deg_to_states(framed, c.elements_deg, t0_tdb_s)
    rot = element_frame_to_j2000(framed, t0_tdb_s, frame)
    return CatalogueStates(states, float(t0_tdb_s), tdb_iso(t0_tdb_s), source, c.element_frame, rot)


def _epoch_source(c: CatalogueConstellation, epoch: str) -> str:
    if epoch == "file":
        return "file"
    return f"study epoch (file gives {'none' if c.epoch is None else f'{c.epoch} {c.time_scale}'})"


def constellation_states_mci(
    dynamics: Dynamics, start_tdb: str, c: CatalogueConstellation, epoch: str = "study"
) -> CatalogueStates:
    """Moon-centred J2000 states of a constellation at the study epoch or the file's epoch.

    ``epoch``: ``"study"`` (elements read at the study epoch ``start_tdb`` (TDB) in their frame built
    then) or ``"file"`` (at the file's epoch); see the module docstring for why ``"study"`` is the
    default. Uses :func:`lnss_lib.propagator.elements_deg_to_states` with the file's frame, so a
    file in the profile's own frame gives exactly the states of the same elements_deg array.
    """
    if epoch not in EPOCH_CHOICES:
        raise ValueError(f"epoch must be one of {', '.join(EPOCH_CHOICES)}; got {epoch!r}")
    refuse_approximate(c)
    ensure_kernels(dynamics.ephemeris)
    t0 = _file_epoch_tdb_s(c) if epoch == "file" else tdb_seconds(start_tdb, "TDB")
    return _states_at(dynamics, c, t0, _epoch_source(c, epoch))


def file_epoch_profile(settings: Settings, c: CatalogueConstellation) -> Settings:
    """``settings`` with the study epoch moved to the file's epoch (TDB, to the millisecond), for ``epoch="file"``.

    The GPS constellation is still the profile's TLE set propagated by SGP4 to that epoch: its
    metrics mean little far from the TLE epoch (see params/data/README.md).
    """
    ensure_kernels(settings.ephemeris)
    return settings.with_overrides({"epoch": {"start_tdb": tdb_iso(_file_epoch_tdb_s(c))}})


def analyse_catalogue(
    context, c: CatalogueConstellation, epoch: str = "study", *, datasets: bool = True
) -> dict:
    """:func:`lnss_lib.evaluator.analyse_constellation` for a catalogue constellation, for study notebooks.

    Returns the evaluator's ``{"propagation", "dop", "deltav", "gps_link", "metrics"}`` plus ``"states"``
    (the :class:`CatalogueStates` it started from). ``context`` and ``epoch`` as in
    :func:`evaluate_catalogue`; raises :class:`~lnss_lib.errors.ImpactError` for an orbit that hits
    the Moon and :class:`~lnss_lib.errors.ConfigError` for an approximate entry. Without ``datasets``
    the campaign's metrics-only path (what ``evaluate`` prints, to the last bit).
    """
    from .evaluator import analyse_states

    if epoch not in EPOCH_CHOICES:
        raise ValueError(f"epoch must be one of {', '.join(EPOCH_CHOICES)}; got {epoch!r}")
    refuse_approximate(c)
    if epoch == "file" and abs(_file_epoch_tdb_s(c) - context.t0_tdb_s) > 1e-3:
        raise ValueError(
            f"{c.key}: the evaluation context starts at {tdb_iso(context.t0_tdb_s)} TDB, not at the "
            f"file's epoch {c.epoch} {c.time_scale}: build it from file_epoch_profile(profile, constellation)"
        )
    states = _states_at(context.dynamics, c, context.t0_tdb_s, _epoch_source(c, epoch))
    return {
        **analyse_states(context, c.elements_deg, states.states_mci, datasets=datasets),
        "states": states,
    }


def evaluate_catalogue(context, c: CatalogueConstellation, epoch: str = "study") -> dict:
    """Eq. 45 metrics of a catalogue constellation with the design evaluator, plus its labels.

    ``context``: :func:`lnss_lib.evaluator.context_for` of the profile; with ``epoch="file"`` the
    context's epoch must be the file's (build it from :func:`file_epoch_profile`). Returns the
    evaluator's metrics (``RESULT_KEYS``, ``reason``, ``impact``, ``timing_s``) and ``name``,
    ``approximate``, ``element_frame``, ``epoch_used``, ``epoch_source``. The states are built at the
    context's epoch (for ``"file"``, the file's epoch to the millisecond). An impact comes back
    flagged (``evaluated`` False, NaN metrics) as in :func:`lnss_lib.evaluator.evaluate_constellation`;
    an approximate entry raises :class:`~lnss_lib.errors.ConfigError`.
    """
    import time

    from .evaluator import _infeasible

    start = time.perf_counter()
    try:
        result = analyse_catalogue(context, c, epoch, datasets=False)["metrics"]
    except (
        InfeasibleDesignError
    ) as error:  # only a physically impossible design; any other error propagates
        result = _infeasible(c.n_sat, str(error), context.deltav.model, start)
    result.update(
        name=c.key,
        approximate=c.approximate,
        element_frame=c.element_frame,
        epoch_used=tdb_iso(context.t0_tdb_s),
        epoch_source=_epoch_source(c, epoch),
    )
    return result
