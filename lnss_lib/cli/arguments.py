"""What the commands share: ``--profile``/``--profile-file``, ``--set``, the ``--out`` path, and a
flag's value checked against a range before any work (a bad value is one line naming the flag and
what is allowed)."""

from __future__ import annotations

import argparse
import errno
import math
import os
from pathlib import Path

from ..config import available_profiles, parse_sets
from ..constants import INTEGER_SETTING_MAX
from ..errors import ConfigError
from ..setting_rule import allowed_range_text, in_range

SET_HELP = (
    "override a profile value (TOML literal: true/false, numbers, quoted strings and dates), e.g. "
    "gravity.degree=8; repeatable; checked like the profile"
)


def require(flag: str, value, spec: tuple, integer: bool = False, why: str = ""):
    """``value`` if finite (an integer with ``integer``) and inside ``spec`` (a range of lnss_lib.sections), else ConfigError
    (with the reason ``why``)."""
    if value is None:
        return None
    if not math.isfinite(value) or (integer and value != int(value)) or not in_range(value, spec):
        kind = "an integer" if integer else "a finite number"
        raise ConfigError(
            f"{flag} {value!r} is not allowed; allowed: {kind} in {allowed_range_text(spec)}"
            + (f" ({why})" if why else ""),
            key=flag,
        )
    return value


def integer(text: str) -> int:
    """An integer flag's value: an integer that outputs can store (magnitude at most 2**63 - 1), for argparse."""
    value = int(
        text
    )  # ValueError (also for more than 4300 digits): argparse says "invalid integer value"
    if abs(value) > INTEGER_SETTING_MAX:
        raise argparse.ArgumentTypeError(
            f"an integer of about {len(text.strip().lstrip('+-'))} digits is too large; "
            f"allowed: at most 2**63 - 1 in magnitude"
        )
    return value


def profile_overrides(args: argparse.Namespace) -> dict | None:
    """``--set SECTION.KEY=VALUE`` items as a nested overrides dict (checked by load_settings), or None."""
    return parse_sets(getattr(args, "set", None)) or None


def check_output(path: str | None) -> Path | None:
    """The ``--out`` path, checked before any work: a .csv or .nc file in an existing, writable folder."""
    if path is None:
        return None
    out = Path(path)
    if out.suffix not in (".csv", ".nc") or out.is_dir():
        raise ConfigError(f"--out {path}: need a file name ending in .csv or .nc", key="--out")
    if not out.parent.is_dir():
        raise ConfigError(f"--out {path}: folder {out.parent} does not exist", key="--out")
    if not os.access(out.parent, os.W_OK):
        raise PermissionError(errno.EACCES, "folder is not writable", str(out.parent))
    return out


def add_profile(command: argparse.ArgumentParser, default: str | None) -> None:
    """``--profile NAME`` (a file of params/) or ``--profile-file PATH`` (outputs in outputs/<stem>/)."""
    group = command.add_mutually_exclusive_group()
    group.add_argument(
        "--profile",
        default=default,
        help=f"profile name: {', '.join(available_profiles())} "
        f"(params/NAME.toml; default {default or 'quick'})",
    )
    group.add_argument(
        "--profile-file",
        metavar="PATH",
        help="a profile TOML file outside params/ (it may inherit "
        "from params/ profiles); its name is the file's stem, outputs go to outputs/<stem>/",
    )


def add_set(parser: argparse.ArgumentParser) -> None:
    """``--set SECTION.KEY=VALUE``, repeatable (:func:`profile_overrides` reads it)."""
    parser.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=SET_HELP)


def refuse_flags(args: argparse.Namespace, flags: tuple[str, ...], why: str, key: str) -> None:
    """ConfigError ``why: drop FLAGS`` naming those of ``flags`` the command line gave (an option that runs
    something else than the command's other options configure); a flag's value is ``args``'s attribute of
    its name (``--run-dir``: ``run_dir``, ``FILE``: ``file``)."""
    given = [f for f in flags if getattr(args, f.lstrip("-").replace("-", "_").lower()) is not None]
    if given:
        raise ConfigError(f"{why}: drop {', '.join(given)}", key=key)
