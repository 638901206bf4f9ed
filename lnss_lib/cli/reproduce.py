"""``python -m lnss_lib reproduce``: the notebooks run headless into ``outputs/<profile>/``."""

from __future__ import annotations

import argparse
import contextlib
import sys

from .arguments import add_profile, add_set, profile_overrides


def say_which_campaign(profile_name: str, overrides: dict | None, numbers: set[str]) -> None:
    """Print (stderr) where notebooks 06-07 take their campaigns from under a profile that loads them: a local
    run or the shipped reference results (the notebooks print the same)."""
    from ..studies.campaign import campaign_source
    from ..studies.pareto import physical_bound_campaign

    if not numbers & {"06", "07"}:
        return
    source = campaign_source(profile_name, overrides)
    if source:
        print(f"campaign of {profile_name}: {source}", file=sys.stderr)
    if "07" in numbers:
        with contextlib.suppress(FileNotFoundError):
            physical = physical_bound_campaign(profile_name)
            if physical is not None:
                print(f"notebook 07's figures: {physical.note}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from ..pipeline import notebook_paths, reproduce

    overrides = profile_overrides(args)
    say_which_campaign(
        args.profile, overrides, {book.stem[:2] for book in notebook_paths(args.only)}
    )
    return reproduce(args.profile, only=args.only, overrides=overrides)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_profile(parser, "quick")
    parser.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="notebook names or number prefixes (e.g. 01 02_dop_grid)",
    )
    add_set(parser)
