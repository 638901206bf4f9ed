"""``python -m lnss_lib bench NAME``: a benchmark of :mod:`lnss_lib.bench`, after the settings are checked."""

from __future__ import annotations

import argparse

from ..errors import ConfigError
from ..settings import load_settings
from .arguments import add_profile, add_set, profile_overrides

BENCHMARKS = (
    "propagator",
    "dop",
    "evaluate",
    "estimate",
    "navigation",
    "campaign",
    "integrator",
    "design-life",
    "stability",
    "gnss",
)


def run(args: argparse.Namespace) -> int:
    import importlib

    module = importlib.import_module(f"lnss_lib.bench.{args.name.replace('-', '_')}")
    for flag, given in (
        ("--scaling", args.scaling),
        ("--history", args.history is not None),
        ("--before-after", args.before_after),
    ):
        if given and args.name != "campaign":
            raise ConfigError(
                f"{flag} applies to 'bench campaign' only; got bench {args.name}", key=flag
            )
    overrides = profile_overrides(args)
    load_settings(
        args.profile, overrides=overrides
    )  # every setting checked before the benchmark starts
    extra = {"scaling_run": True} if args.scaling else {}
    if args.before_after:
        extra["before_after"] = True
    if args.history is not None:
        extra["history"] = args.history
    module.run(profile_name=args.profile, overrides=overrides, **extra)
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "name", choices=BENCHMARKS, metavar="NAME", help=f"one of {', '.join(BENCHMARKS)}"
    )
    add_profile(parser, "paper")
    parser.add_argument(
        "--scaling",
        action="store_true",
        help="campaign: local scaling and loopback-cluster overhead",
    )
    parser.add_argument(
        "--before-after",
        action="store_true",
        help="campaign: also the historical comparisons (the evaluation path and the force model "
        "before and after their speed work, run from their commits; the operational projection; with --history "
        "that run's pace and dispatch before and now): tens of minutes",
    )
    parser.add_argument(
        "--history",
        metavar="RUN_DIR",
        help="campaign: project 120 x 1000 with the designs this run "
        "folder evaluated per generation (its cache hits), printed as a range down from no hits",
    )
    add_set(parser)
