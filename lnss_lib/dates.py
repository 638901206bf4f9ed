"""Calendar dates as the workbook reads them: strict ISO 8601, never a guess.

:func:`parse_iso_date` is the one reader of calendar dates (``--epoch-tdb``, profile epochs, constellation
files); a time scale is given apart, so a zone is refused.
"""

from __future__ import annotations

import datetime as dt
import re

from .errors import ConfigError

ISO_DATE_FORMAT = "YYYY-MM-DD"
ISO_FORMAT = (
    "YYYY-MM-DDTHH:MM:SS (ISO 8601; seconds and a fraction .fff optional, a bare date YYYY-MM-DD is "
    "midnight; no zone such as Z or +05:00: the time scale is given apart)"
)
_ISO = re.compile(r"(\d{4})-(\d{2})-(\d{2})(?:T(\d{2}):(\d{2})(?::(\d{2})(?:\.(\d{1,9}))?)?)?")
_ZONE = re.compile(r"T.*(Z|[+-]\d{2}(:?\d{2})?)$")


def parse_iso_date(text, what: str = "date", *, date_only: bool = False) -> dt.datetime:
    """The one reader of calendar dates (``--epoch-tdb``, profile epochs, constellation files): ``text`` in the
    strict ISO 8601 form :data:`ISO_FORMAT` (:data:`ISO_DATE_FORMAT` with ``date_only``) as a naive datetime (the
    fraction beyond microseconds dropped). Anything else, a zone included (a time scale is never a zone), raises
    ConfigError naming ``what``, the text and the expected format: ``01-05-2025`` or ``1/5/2025`` are never read
    as some day."""
    expected = ISO_DATE_FORMAT if date_only else ISO_FORMAT
    match = _ISO.fullmatch(text) if isinstance(text, str) else None
    if match is None or (date_only and match.group(4) is not None):
        zone = isinstance(text, str) and not date_only and _ZONE.search(text) is not None
        raise ConfigError(
            f"{what} {text!r} is not "
            + (
                "a date with a zone, which is not allowed; expected "
                if zone
                else "an ISO 8601 date; expected "
            )
            + expected
        )
    fields = [int(value) if value else 0 for value in match.groups()[:6]]
    fraction = match.group(7) or ""
    try:
        return dt.datetime(*fields, int((fraction + "000000")[:6]))
    except ValueError as error:
        raise ConfigError(
            f"{what} {text!r} is no calendar date and time ({error}); expected {expected}"
        ) from None


def is_iso_date(text, date_only: bool = False) -> bool:
    try:
        parse_iso_date(text, date_only=date_only)
    except ConfigError:
        return False
    return True
