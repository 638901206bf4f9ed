"""Two-line element sets: reading, checks and selection of the GPS satellites (paper Section 2.2).

Every element line is validated before ``sgp4`` parses it (length and column layout, line number,
modulo-10 checksum by ``sgp4.io.compute_checksum``, satellite number of line 1 vs line 2); a bad
line raises ``ValueError`` naming the file, the line number and what is wrong. Name and PRN come
from the title lines. Satellites can be dropped by PRN, by launch (international designator
``YYYY-NNN``) or by launch date (default: launched after the simulation epoch, so GPS BIII-8 /
PRN 21, launched 2025-05-30, is out at 2025-05-01). A TLE carries no launch date: it is taken from
``gps.launch_dates`` when listed there, else estimated as TLE epoch - revolution number / mean
motion (within a few weeks for GPS), and in any case bounded by the launch year of the designator.
"""

from __future__ import annotations

import datetime as dt
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from sgp4.api import Satrec
from sgp4.io import compute_checksum

from .config import data_path

if TYPE_CHECKING:
    from .settings import GpsSettings

__all__ = [
    "TleRecord",
    "read_tle",
    "launch_date",
    "select_satellites",
    "gps_catalogue",
    "SELECTION_COLUMNS",
]

SELECTION_COLUMNS = (
    "name",
    "prn",
    "designator",
    "launch_date",
    "launch_date_source",
    "tle_epoch_utc",
    "included",
    "reason",
)


@dataclass(frozen=True)
class TleRecord:
    """One satellite of a TLE file: title, identifiers and the two validated element lines."""

    name: str
    prn: int | None
    satnum: int
    designator: str  # international designator "YYYY-NNNP" (e.g. "2025-116A")
    launch_year: int
    launch_number: int
    epoch_utc: dt.datetime
    rev_number: int  # revolution number at epoch (line 2, columns 64-68)
    mean_motion_rev_day: float
    line1: str
    line2: str
    file_line: int  # 1-based line number of line 1 in its file


_BLANKS = {1: (1, 8, 17, 32, 43, 52, 61, 63), 2: (1, 7, 16, 25, 33, 42, 51)}


_FIELDS = {
    1: {
        "satellite number": (2, 7),
        "epoch year": (18, 20),
        "epoch day": (20, 32),
        "element set number": (64, 68),
    },
    2: {
        "satellite number": (2, 7),
        "inclination": (8, 16),
        "RAAN": (17, 25),
        "eccentricity": (26, 33),
        "argument of perigee": (34, 42),
        "mean anomaly": (43, 51),
        "mean motion": (52, 63),
        "revolution number": (63, 68),
    },
}


def _check_element_line(line: str, expected: int, path: Path, line_no: int) -> None:
    """Raise ``ValueError`` naming file and line if ``line`` is not a well-formed TLE line ``expected``."""
    where = f"{path}: line {line_no}"
    if len(line) != 69:
        raise ValueError(
            f"{where}: TLE line {expected} must be 69 characters long, got {len(line)}"
        )
    if line[0] != str(expected):
        raise ValueError(
            f"{where}: expected TLE line number {expected} in column 1, got {line[0]!r}"
        )
    for col in _BLANKS[expected]:
        if line[col] != " ":
            raise ValueError(
                f"{where}: TLE line {expected} column {col + 1} must be blank, got {line[col]!r} "
                "(column layout of the standard two-line format)"
            )
    for field, (lo, hi) in _FIELDS[expected].items():
        text = line[lo:hi].strip()
        try:
            float(text.replace(" ", ""))
        except ValueError:
            raise ValueError(
                f"{where}: TLE line {expected} columns {lo + 1}-{hi} ({field}) are not a number: {line[lo:hi]!r}"
            ) from None
    if not line[68].isdigit():
        raise ValueError(
            f"{where}: TLE line {expected} column 69 must be the checksum digit, got {line[68]!r}"
        )
    if compute_checksum(line) != int(line[68]):
        raise ValueError(
            f"{where}: bad checksum on TLE line {expected}: column 69 says {line[68]} but the "
            f"modulo-10 sum of columns 1-68 is {compute_checksum(line)}"
        )


def _designator(line1: str, path: Path, line_no: int) -> tuple[str, int, int]:
    """("YYYY-NNNP", launch year, launch number) from line 1 columns 10-17; ("", 0, 0) when blank."""
    raw = line1[9:17]
    if not raw.strip():
        return "", 0, 0
    match = re.fullmatch(r"(\d{2})(\d{3})([A-Z ]{1,3})", raw.rstrip().ljust(6))
    if not match:
        raise ValueError(
            f"{path}: line {line_no}: international designator {raw!r} is not YYNNNP (columns 10-17)"
        )
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
                f"differs from {line2[2:7].strip()} on line 2"
            )
        designator, year, number = _designator(line, path, k + 1)
        sat = Satrec.twoline2rv(line, line2)
        epoch = dt.datetime(
            2000 + sat.epochyr if sat.epochyr < 57 else 1900 + sat.epochyr, 1, 1
        ) + dt.timedelta(days=sat.epochdays - 1.0)
        name = title or f"NORAD {int(line[2:7])}"
        prn_match = re.search(r"PRN\s*0*(\d+)", name)
        records.append(
            TleRecord(
                name=name,
                prn=int(prn_match.group(1)) if prn_match else None,
                satnum=int(line[2:7]),
                designator=designator,
                launch_year=year,
                launch_number=number,
                epoch_utc=epoch,
                rev_number=int(line2[63:68].strip() or 0),
                mean_motion_rev_day=float(line2[52:63]),
                line1=line,
                line2=line2,
                file_line=k + 1,
            )
        )
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
    listed = (launch_dates or {}).get(record.designator) or (launch_dates or {}).get(
        record.designator[:8]
    )
    if record.designator and listed:
        try:
            return dt.date.fromisoformat(str(listed)), "table"
        except ValueError:
            raise ValueError(
                f"gps.launch_dates: launch date of {record.designator} must be an ISO date "
                f"YYYY-MM-DD; got {listed!r}"
            ) from None
    estimate = (
        record.epoch_utc - dt.timedelta(days=record.rev_number / record.mean_motion_rev_day)
    ).date()
    if not record.launch_year:
        return estimate, "estimate"
    first, last = dt.date(record.launch_year, 1, 1), dt.date(record.launch_year, 12, 31)
    return min(max(estimate, first), last), "estimate"


def _parse_launch(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d{4})-(\d{3})", text.strip())
    if not match:
        raise ValueError(
            f"launch cut-off must be an international designator 'YYYY-NNN'; got {text!r}"
        )
    return int(match.group(1)), int(match.group(2))


def select_satellites(
    records: list[TleRecord],
    *,
    exclude_prn=(),
    launched_after: dt.date | None = None,
    launches_from: str | None = None,
    launch_dates: dict | None = None,
) -> tuple[list[TleRecord], list[dict]]:
    """Satellites kept after the exclusions, and one row (:data:`SELECTION_COLUMNS`) per satellite with the
    reason if dropped.

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
        rows.append(
            {
                "name": rec.name,
                "prn": rec.prn,
                "designator": rec.designator,
                "launch_date": date,
                "launch_date_source": source,
                "tle_epoch_utc": rec.epoch_utc,
                "included": not reason,
                "reason": reason,
            }
        )
    if not kept:
        raise ValueError(
            "every GPS satellite was excluded: check gps.exclude_prn and the launch cut-offs"
        )
    return kept, rows


def gps_catalogue(
    gps: GpsSettings, start_tdb: str, tle_path: str | Path | None = None
) -> tuple[list[TleRecord], list[dict]]:
    """Read the ``[gps]`` TLE file (or a user's) and apply the ``[gps]`` exclusions; ``start_tdb`` (the study
    epoch, ``epoch.start_tdb``) is the launch cut-off of ``exclude_launched_after = "epoch"``."""
    path = Path(tle_path) if tle_path is not None else data_path(gps.tle_file)
    after = gps.exclude_launched_after
    if after == "epoch":
        cutoff = dt.date.fromisoformat(start_tdb[:10])
    elif after == "none":
        cutoff = None
    else:
        cutoff = dt.date.fromisoformat(after)  # an ISO date: checked at load (config.FORMS)
    return select_satellites(
        read_tle(path),
        exclude_prn=gps.exclude_prn,
        launched_after=cutoff,
        launches_from=gps.exclude_launches_from or None,
        launch_dates=gps.launch_dates,
    )
