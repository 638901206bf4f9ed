"""Ephemerides, rotations and time through SPICE, and their tabulation for the force model.

Conventions: times are TDB seconds past J2000 (``t_tdb_s``, SPICE's ET); positions in km,
velocities in km/s; the integration frame is Moon-centred J2000 ("MCI", Horizons' ICRF).
Calendar strings are always read with an explicit time scale (``tdb_seconds("...", scale="TDB")``).

SPICE is called only here, and only to build tables: :class:`EphemerisTable` samples the third
bodies and the J2000 -> MOON_PA rotation once per run; :func:`hermite_cubic` interpolates them in
the compiled force model (notebook 01 shows that the interpolation error is far below the force
model's own error).
"""

from __future__ import annotations

import contextlib
import hashlib
from dataclasses import dataclass
from pathlib import Path

import numba as nb
import numpy as np
import spiceypy as spice
import spiceypy.utils.exceptions

from .config import SKYFIELD_DATA, data_path
from .constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from .dates import ISO_FORMAT, parse_iso_date
from .errors import ConfigError, EphemerisRangeError, SpiceError
from .settings import Dynamics, EphemerisSettings

__all__ = [
    "NAIF_BODY",
    "planetary_spk_path",
    "kernel_paths",
    "load_kernels",
    "ensure_kernels",
    "tdb_seconds",
    "kernel_span_tdb_s",
    "check_span",
    "tdb_iso",
    "spice_errors",
    "body_states_mci",
    "rotation_and_rate",
    "rotation",
    "hermite_basis",
    "hermite_sum",
    "hermite_apply",
    "hermite_cubic",
    "hermite_series",
    "EphemerisTable",
    "file_sha256",
]

NAIF_BODY = {"SUN": "SUN", "EARTH": "EARTH", "JUPITER": "JUPITER BARYCENTER", "MOON": "MOON"}
_LOADED: set[str] = set()
_ENSURED: set[EphemerisSettings] = (
    set()
)  # settings whose kernels are loaded (paths resolved and checked once)


def planetary_spk_path(spec: str = "skyfield-data:de421.bsp") -> Path:
    """Path of the planetary SPK; ``skyfield-data:NAME`` resolves inside that package."""
    if spec.startswith(SKYFIELD_DATA):
        import skyfield_data

        # The package's own path helper warns about its unrelated Earth-orientation file: avoid it.
        return (
            Path(skyfield_data.__file__).resolve().parent
            / "data"
            / spec.removeprefix(SKYFIELD_DATA)
        )
    return data_path(spec, "ephemeris.planetary_spk")


def kernel_paths(ephemeris: EphemerisSettings) -> list[Path]:
    """Every kernel the ephemeris settings name, in load order (planetary SPK first)."""
    return [planetary_spk_path(ephemeris.planetary_spk)] + [
        data_path(k, "ephemeris.kernels") for k in ephemeris.kernels
    ]


@contextlib.contextmanager
def spice_errors(asked: str, kernels=None):
    """SPICE errors inside the block as one :class:`SpiceError` naming what was ``asked``, the kernel file(s)
    (default: every loaded kernel) and SPICE's error code, never SPICE's banner or a line of a file."""
    try:
        yield
    except spice.utils.exceptions.SpiceyError as error:
        files = tuple(map(str, sorted(_LOADED) if kernels is None else kernels))
        code = error.short or type(error).__name__
        raise SpiceError(
            f"SPICE could not {asked}: {code} (kernel file(s): {', '.join(files) or 'none loaded'}; "
            f"see params/data/README.md)",
            asked=asked,
            kernels=files,
            code=code,
        ) from error


def load_kernels(paths: list[Path]) -> None:
    """Furnish SPICE kernels once per process (safe to call again, e.g. in worker processes).

    Raises ``FileNotFoundError`` naming a missing kernel and :class:`SpiceError` naming one SPICE cannot read.
    """
    for path in map(Path, paths):
        key = str(path.resolve())
        if key in _LOADED:
            continue
        if not path.is_file():
            raise FileNotFoundError(
                f"SPICE kernel not found: {path}. The kernels ship in params/data/kernels "
                "(see params/data/README.md); de421.bsp comes from the skyfield-data package."
            )
        with spice_errors("load the kernel", [key]):
            spice.furnsh(key)
        try:
            _kernel_coverage(key)  # a damaged binary kernel is refused here, not at first use
        except SpiceError:
            spice.unload(key)
            raise
        _LOADED.add(key)


def ensure_kernels(ephemeris: EphemerisSettings) -> None:
    """Load the kernels the ephemeris settings name (idempotent; the paths are resolved and checked on the first
    call for these settings only: a campaign calls this once per design)."""
    if ephemeris in _ENSURED:
        return
    load_kernels(kernel_paths(ephemeris))
    _ENSURED.add(ephemeris)


def tdb_seconds(calendar: str, scale: str = "TDB") -> float:
    """Seconds past J2000 TDB for an ISO 8601 calendar string (:func:`~lnss_lib.dates.parse_iso_date`, strict: no
    zone, no day-month order) read in ``scale`` ("TDB" or "UTC").

    ``str2et`` reads a bare date as UTC; the scale is therefore always appended explicitly.
    """
    scale = scale.upper()
    if scale not in ("TDB", "UTC"):
        raise ValueError(f"unknown time scale {scale!r}; allowed: 'TDB', 'UTC'")
    if not _LOADED:
        raise RuntimeError(
            "SPICE kernels are not loaded: call ensure_kernels(settings.ephemeris) first"
        )
    parse_iso_date(calendar, f"epoch ({scale})")
    try:
        return float(spice.str2et(f"{calendar.replace('T', ' ')} {scale}"))
    except spice.utils.exceptions.SpiceyError:
        raise ConfigError(
            f"epoch {calendar!r} is not an ISO calendar date; expected {ISO_FORMAT} ({scale}), "
            f"e.g. 2025-05-01T00:00:00"
        ) from None


def _kernel_coverage(key: str) -> tuple[float, float]:
    """(start, end) TDB s that every body of one SPK or binary PCK covers; (-inf, inf) for other kernels."""
    start, end = -np.inf, np.inf
    suffix = Path(key).suffix.lower()
    if suffix not in (".bsp", ".bpc"):
        return start, end
    with spice_errors("read the time span the kernel covers", [key]):
        if suffix == ".bsp":
            ids, cover = list(spice.spkobj(key)), spice.spkcov
        else:
            ids, cover = spice.cell_int(1000), spice.pckcov
            spice.pckfrm(key, ids)
        for body in ids:
            window = cover(key, int(body))
            count = spice.wncard(window)
            if count:
                start = max(start, spice.wnfetd(window, 0)[0])
                end = min(end, spice.wnfetd(window, count - 1)[1])
    return float(start), float(end)


def kernel_span_tdb_s() -> tuple[float, float]:
    """(start, end) TDB s of the time span every loaded SPK and binary PCK covers (their intersection)."""
    key_set = frozenset(_LOADED)
    if key_set not in _SPANS:
        spans = [_kernel_coverage(key) for key in _LOADED]
        _SPANS[key_set] = (
            max((s for s, _ in spans), default=-np.inf),
            min((e for _, e in spans), default=np.inf),
        )
    return _SPANS[key_set]


_SPANS: dict[frozenset, tuple[float, float]] = {}


def check_span(t_start_tdb_s: float, t_end_tdb_s: float) -> None:
    """EphemerisRangeError (naming the span) unless [start, end] lies inside the loaded kernels' span."""
    start, end = kernel_span_tdb_s()
    if (
        not (np.isfinite(t_start_tdb_s) and np.isfinite(t_end_tdb_s))
        or t_start_tdb_s < start
        or t_end_tdb_s > end
    ):
        raise EphemerisRangeError(
            f"epochs {tdb_iso(t_start_tdb_s) if np.isfinite(t_start_tdb_s) else t_start_tdb_s} to "
            f"{tdb_iso(t_end_tdb_s) if np.isfinite(t_end_tdb_s) else t_end_tdb_s} TDB are outside the span of the "
            f"loaded ephemeris and lunar frame kernels, {tdb_iso(start)[:10]} to {tdb_iso(end)[:10]} TDB",
            start_tdb_s=start,
            end_tdb_s=end,
            requested_tdb_s=(t_start_tdb_s, t_end_tdb_s),
        )


def tdb_iso(t_tdb_s: float) -> str:
    """ISO calendar string (TDB) of a TDB epoch; past year 9999 (which SPICE writes as ``****``) the Julian year."""
    with spice_errors(f"write the epoch {t_tdb_s!r} s TDB as a calendar date"):
        text = spice.timout(t_tdb_s, "YYYY-MM-DDTHR:MN:SC.### ::TDB")
    if "*" in text:
        return f"Julian year {2000.0 + t_tdb_s / (DAYS_PER_JULIAN_YEAR * SECONDS_PER_DAY):.1f}"
    return text


def body_states_mci(body: str, t_tdb_s: np.ndarray) -> np.ndarray:
    """Moon-centred J2000 states (km, km/s) of ``body`` at TDB epochs; shape (n, 6)."""
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    with spice_errors(
        f"give the state of {body} relative to the Moon (J2000) at {_span_text(times)}"
    ):
        states, _ = spice.spkezr(NAIF_BODY.get(body, body), times.tolist(), "J2000", "NONE", "MOON")
    return np.asarray(states, dtype=float).reshape(len(times), 6)


def rotation_and_rate(
    frame_from: str, frame_to: str, t_tdb_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (n, 3, 3) with x_to = R x_from, and its time derivative dR/dt (1/s)."""
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    rot = np.empty((len(times), 3, 3))
    rate = np.empty((len(times), 3, 3))
    with spice_errors(
        f"give the rotation {frame_from} -> {frame_to} and its rate at {_span_text(times)}"
    ):
        for k, et in enumerate(times):
            xform = np.asarray(spice.sxform(frame_from, frame_to, et))
            rot[k] = xform[:3, :3]
            rate[k] = xform[3:, :3]
    return rot, rate


def rotation(frame_from: str, frame_to: str, t_tdb_s: np.ndarray) -> np.ndarray:
    """Rotation matrices R (n, 3, 3) with x_to = R x_from at TDB epochs."""
    times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
    with spice_errors(f"give the rotation {frame_from} -> {frame_to} at {_span_text(times)}"):
        return np.stack([np.asarray(spice.pxform(frame_from, frame_to, et)) for et in times])


def _span_text(times: np.ndarray) -> str:
    """ "t0 .. t1 s TDB" of an array of epochs, for messages."""
    return (
        f"{times[0]:.1f} s TDB"
        if times.size == 1
        else f"{times.min():.1f} .. {times.max():.1f} s TDB"
    )


@nb.njit(cache=True, fastmath=False)
def hermite_basis(n: int, t0: float, dt: float, t: float) -> tuple:
    """Interval k of a uniform grid of ``n`` nodes (t0, dt) holding ``t`` (clamped to the grid) and the cubic
    Hermite weights (h00, h10, h01, h11) at ``t``: the part of :func:`hermite_cubic` that depends on ``t`` only,
    shared by every table on the same grid."""
    s = (t - t0) / dt
    k = int(np.floor(s))
    if k < 0:
        k = 0
    elif k > n - 2:
        k = n - 2
    u = s - k
    u2 = u * u
    u3 = u2 * u
    return (
        k,
        2.0 * u3 - 3.0 * u2 + 1.0,
        (u3 - 2.0 * u2 + u) * dt,
        -2.0 * u3 + 3.0 * u2,
        (u3 - u2) * dt,
    )


@nb.njit(cache=True, fastmath=False)
def hermite_sum(basis: tuple, v0: float, r0: float, v1: float, r1: float) -> float:
    """One entry's cubic Hermite value at :func:`hermite_basis`'s weights, from its values ``v0``, ``v1`` and rates
    ``r0``, ``r1`` at the interval's two nodes."""
    _, h00, h10, h01, h11 = basis
    return h00 * v0 + h10 * r0 + h01 * v1 + h11 * r1


@nb.njit(cache=True, fastmath=False)
def hermite_apply(values: np.ndarray, rates: np.ndarray, basis: tuple, out: np.ndarray) -> None:
    """Interpolate one table (values and rates at nodes) with :func:`hermite_basis`'s interval and weights."""
    k = basis[0]
    for j in range(values.shape[1]):
        out[j] = hermite_sum(basis, values[k, j], rates[k, j], values[k + 1, j], rates[k + 1, j])


@nb.njit(cache=True, fastmath=False)
def hermite_cubic(
    values: np.ndarray, rates: np.ndarray, t0: float, dt: float, t: float, out: np.ndarray
) -> None:
    """Cubic Hermite interpolation on a uniform grid (values and rates at nodes) into ``out``."""
    hermite_apply(values, rates, hermite_basis(values.shape[0], t0, dt, t), out)


@nb.njit(cache=True, fastmath=False)
def hermite_series(
    values: np.ndarray, rates: np.ndarray, t0: float, dt: float, times: np.ndarray
) -> np.ndarray:
    """:func:`hermite_cubic` at each of ``times`` (n,): the interpolated table, (n, values.shape[1])."""
    out = np.empty((times.shape[0], values.shape[1]))
    for i in range(times.shape[0]):
        hermite_cubic(values, rates, t0, dt, times[i], out[i])
    return out


@dataclass(frozen=True)
class EphemerisTable:
    """Tabulated Moon-centred J2000 geometry on a uniform TDB grid, for the compiled force model.

    ``bodies`` (n, nb, 6): states of ``body_names`` relative to the Moon (km, km/s);
    ``rot_pa`` and ``rot_pa_rate`` (n, 9): J2000 -> MOON_PA rotation, row-major, and its rate.
    """

    t0_tdb_s: float
    step_s: float
    body_names: tuple[str, ...]
    bodies: np.ndarray
    rot_pa: np.ndarray
    rot_pa_rate: np.ndarray

    @classmethod
    def build(
        cls,
        dynamics: Dynamics,
        t_start_tdb_s: float,
        t_end_tdb_s: float,
        body_names: tuple[str, ...] = ("SUN", "EARTH", "JUPITER"),
    ) -> EphemerisTable:
        """Sample SPICE over [t_start, t_end] (with two nodes of margin each side), every
        ``ephemeris.table_step_s``, with the rotation to ``frames.gravity``."""
        ensure_kernels(dynamics.ephemeris)
        step = dynamics.ephemeris.table_step_s
        t_lo, t_hi = min(t_start_tdb_s, t_end_tdb_s), max(t_start_tdb_s, t_end_tdb_s)
        n = int(np.ceil((t_hi - t_lo) / step)) + 5
        times = t_lo - 2 * step + step * np.arange(n)
        check_span(float(times[0]), float(times[-1]))
        bodies = np.stack([body_states_mci(b, times) for b in body_names], axis=1)
        rot, rate = rotation_and_rate("J2000", dynamics.frames.gravity, times)
        return cls(
            float(times[0]),
            step,
            tuple(body_names),
            bodies,
            rot.reshape(n, 9).copy(),
            rate.reshape(n, 9).copy(),
        )

    @property
    def t_end_tdb_s(self) -> float:
        return self.t0_tdb_s + self.step_s * (self.bodies.shape[0] - 1)

    def body_position(self, name: str, t_tdb_s: float) -> np.ndarray:
        """Interpolated Moon-centred J2000 position (km) of a tabulated body."""
        k = self.body_names.index(name)
        out = np.empty(3)
        hermite_cubic(
            self.bodies[:, k, :3], self.bodies[:, k, 3:], self.t0_tdb_s, self.step_s, t_tdb_s, out
        )
        return out

    def rotation_pa(self, t_tdb_s: float) -> np.ndarray:
        """Interpolated J2000 -> MOON_PA rotation (3, 3)."""
        out = np.empty(9)
        hermite_cubic(self.rot_pa, self.rot_pa_rate, self.t0_tdb_s, self.step_s, t_tdb_s, out)
        return out.reshape(3, 3)

    def rotations_pa(self, t_tdb_s) -> np.ndarray:
        """Interpolated J2000 -> MOON_PA rotations (n, 3, 3) at TDB epochs (n,) inside the table; raises
        ``ValueError`` naming the table's span for an epoch outside it."""
        times = np.atleast_1d(np.asarray(t_tdb_s, dtype=float))
        if not np.all((times >= self.t0_tdb_s) & (times <= self.t_end_tdb_s)):
            raise ValueError(
                f"epochs {_span_text(times)} are outside the ephemeris table, "
                f"{self.t0_tdb_s:.1f} .. {self.t_end_tdb_s:.1f} s TDB"
            )
        values = hermite_series(self.rot_pa, self.rot_pa_rate, self.t0_tdb_s, self.step_s, times)
        return values.reshape(-1, 3, 3)


def file_sha256(path: Path) -> str:
    """SHA-256 hex digest of a file."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
