"""The GPS transmit gain pattern (paper Table 1, eq. 22): gain in dBi tabulated against the
off-boresight angle, read from a CSV of ``params/data/`` once a process, with the ``[gps]`` sidelobe
offset applied beyond a given angle."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .config import data_path
from .errors import ConfigError

if TYPE_CHECKING:
    from .settings import GpsSettings


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

    def with_sidelobes(self, from_deg: float, offset_db: float) -> GainPattern:
        """The pattern with ``offset_db`` added beyond ``from_deg`` (-inf: main lobe only)."""
        if offset_db == 0.0:
            return self
        gain = np.where(self.off_boresight_deg > from_deg, self.gain_dbi + offset_db, self.gain_dbi)
        return GainPattern(
            self.off_boresight_deg,
            gain,
            f"{self.source}, sidelobes beyond {from_deg} deg {offset_db:+g} dB",
        )


def load_gain_pattern(path: str | Path, column: str) -> GainPattern:
    """Gain column ``column`` of a CSV (comment lines '#', column ``off_boresight_deg``)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"gain pattern file not found: {path}")
    with open(path, newline="") as handle:
        numbered = [
            (k, line)
            for k, line in enumerate(handle, start=1)
            if line.strip() and not line.startswith("#")
        ]
    rows = list(zip((k for k, _ in numbered), csv.reader(line for _, line in numbered)))
    if len(rows) < 3:
        raise ConfigError(
            f"{path}: a gain pattern needs a header line and at least two rows", key="gps.gain_file"
        )
    header = [c.strip() for c in rows[0][1]]
    values = []
    for line_no, row in rows[1:]:
        try:
            numbers = [float(c) for c in row]
        except ValueError:
            raise ConfigError(
                f"{path}: line {line_no}: need {len(header)} numbers separated by commas",
                key="gps.gain_file",
            ) from None
        if len(numbers) != len(header) or not all(np.isfinite(numbers)):
            raise ConfigError(
                f"{path}: line {line_no}: need {len(header)} finite numbers; got {len(numbers)} value(s)"
                f"{'' if all(np.isfinite(numbers)) else ', not all finite'}",
                key="gps.gain_file",
            )
        values.append(numbers)
    table = {name: np.array([row[k] for row in values]) for k, name in enumerate(header)}
    if "off_boresight_deg" not in table:
        raise ValueError(f"{path}: line 1 (the header) needs a column 'off_boresight_deg'")
    if column not in table:
        allowed = [c for c in header if c != "off_boresight_deg"]
        raise ValueError(f"{path}: unknown gain column {column!r}; allowed: {', '.join(allowed)}")
    theta = table["off_boresight_deg"]
    if np.any(np.diff(theta) <= 0.0):
        raise ValueError(f"{path}: off_boresight_deg must increase strictly")
    return GainPattern(theta, table[column], f"{path.name}:{column}")


def gain_for_settings(gps: GpsSettings) -> GainPattern:
    """The ``[gps]`` transmit pattern: ``gain_file`` / ``gain_column`` with the sidelobe offset (read once a
    process)."""
    return _cached_gain(
        str(data_path(gps.gain_file)),
        gps.gain_column,
        float(gps.sidelobe_from_deg),
        float(gps.sidelobe_offset_db),
    )


@lru_cache(maxsize=16)
def _cached_gain(path: str, column: str, from_deg: float, offset_db: float) -> GainPattern:
    """:func:`gain_for_settings` read once per process (the file is not re-read for every design)."""
    return load_gain_pattern(path, column).with_sidelobes(from_deg, offset_db)
