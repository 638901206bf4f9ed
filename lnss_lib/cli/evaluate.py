"""``python -m lnss_lib evaluate``: a design, a catalogue constellation or a design life under a named
profile, with exactly the command's JSON keys (NaN as None), or labelled lines with units.

Top layer with ``__main__`` (tests/test_layers.py): the kernels (:mod:`lnss_lib.evaluator`,
:mod:`lnss_lib.catalogue`, :mod:`lnss_lib.design_life.evaluation`) compute, this module names the profile and shapes the
answer for the command line.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from ..constants import DAYS_PER_JULIAN_YEAR, SECONDS_PER_DAY
from ..errors import ConfigError, EphemerisRangeError, InfeasibleDesignError
from ..keys import RESULT_KEYS, format_value, gnss_metric_keys, label
from ..settings import load_settings
from .arguments import add_profile, add_set, integer, profile_overrides

__all__ = ["cli_result", "evaluate_cli", "evaluate_catalogue_cli", "design_life_cli", "human_lines"]


def cli_result(context, result: dict, extra_keys: tuple[str, ...] = ()) -> dict:
    """The evaluate CLI's keys of a result: :data:`RESULT_KEYS`, the profile's extra metrics (None when not
    evaluated), the GNSS link's combined and per-system keys when ``[gnss]`` names more than GPS
    (:func:`~lnss_lib.keys.gnss_metric_keys`), then ``extra_keys``; NaN becomes None (JSON null). ``context``: an
    :class:`lnss_lib.evaluator.EvaluationContext`."""
    gnss = tuple(
        k for k in gnss_metric_keys(context.gnss.systems) if k not in context.extra_metrics
    )
    keys = RESULT_KEYS + context.extra_metrics + gnss + extra_keys
    return {
        key: (
            None
            if isinstance(result.get(key), float) and math.isnan(result[key])
            else result.get(key)
        )
        for key in keys
    }


def evaluate_cli(
    profile_name: str,
    sma_km: float,
    ecc: float,
    aop_deg: float,
    inc_deg: float,
    n_planes: int,
    sats_per_plane: int,
    overrides: dict | None = None,
) -> dict:
    """:func:`lnss_lib.evaluator.evaluate_design` under a named profile (with ``overrides``) with exactly the CLI's
    JSON keys (:func:`cli_result`); the design is checked before any kernel loads."""
    from ..evaluator import check_design, context_for, evaluate_design

    check_design(sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)
    context = context_for(load_settings(profile_name, overrides=overrides))
    return cli_result(
        context, evaluate_design(context, sma_km, ecc, aop_deg, inc_deg, n_planes, sats_per_plane)
    )


def evaluate_catalogue_cli(
    profile_name: str, name_or_path: str, epoch: str = "study", overrides: dict | None = None
) -> dict:
    """:func:`lnss_lib.catalogue.evaluate_catalogue` under a named profile with the evaluate CLI's JSON keys plus
    the labels.

    The keys are those of :func:`cli_result` followed by ``name``, ``approximate``,
    ``element_frame``, ``epoch_used`` and ``epoch_source``; NaN becomes None (JSON null).
    """
    from ..catalogue import (
        EXTRA_RESULT_KEYS,
        evaluate_catalogue,
        file_epoch_profile,
        load_constellation,
        refuse_approximate,
    )
    from ..evaluator import context_for

    profile = load_settings(profile_name, overrides=overrides)
    c = load_constellation(name_or_path, profile.dynamics)
    refuse_approximate(c)
    if epoch == "file":
        profile = file_epoch_profile(profile, c)
    context = context_for(profile)
    return cli_result(context, evaluate_catalogue(context, c, epoch), EXTRA_RESULT_KEYS)


def design_life_cli(
    profile_name: str,
    life_days: float,
    *,
    walker: tuple | None = None,
    constellation: str | None = None,
    constellation_epoch: str = "study",
    overrides: dict | None = None,
) -> dict:
    """:data:`lnss_lib.design_life.evaluation.LIFE_KEYS` for the evaluate CLI: a Walker design ``(sma_km, ecc, aop_deg,
    inc_deg, n_planes, sats_per_plane)`` or a catalogue constellation (its states at the evaluation epoch, as
    elements in the profile's element frame, inserted as given: no insertion trim, so a designed per-satellite
    a such as Ely's phasing, which its authors found by propagating those very states, is flown as published).
    NaN becomes None. An invalid Walker design (the evaluation says why) gives every key None."""
    from ..constellation import WalkerDesign
    from ..design_life.evaluation import (
        LIFE_KEYS,
        elements_deg_in_frame,
        evaluate_design_life,
        json_ready,
    )
    from ..ephemeris import tdb_seconds
    from ..evaluator import context_for
    from ..propagator import elements_deg_to_states

    if not (isinstance(life_days, (int, float)) and math.isfinite(life_days) and life_days > 0):
        raise ValueError(f"--design-life-days must be a positive number of days; got {life_days!r}")
    profile = load_settings(profile_name, overrides=overrides)
    step_s = profile.life_evaluation.sample_step_s
    if not life_days * SECONDS_PER_DAY > step_s:
        raise ConfigError(
            f"--design-life-days {life_days!r} ({life_days * SECONDS_PER_DAY:g} s) is not longer than "
            f"life_evaluation.sample_step_s = {step_s!r} s; allowed: a life of more than one sampling step",
            key="--design-life-days",
        )
    if constellation is not None:
        from ..catalogue import constellation_states_mci, file_epoch_profile, load_constellation

        c = load_constellation(constellation, profile.dynamics)
        if constellation_epoch == "file":
            profile = file_epoch_profile(profile, c)
        profile = profile.with_overrides(
            {"design_life": {"initial_trim": False}}
        )  # the file's states as given
        states = constellation_states_mci(
            profile.dynamics, profile.epoch.start_tdb, c, constellation_epoch
        )
        elements = elements_deg_in_frame(profile.dynamics, states.states_mci, states.t_epoch_tdb_s)
    else:
        try:
            elements = WalkerDesign(*walker).elements_deg()
            elements_deg_to_states(
                profile.dynamics, elements, tdb_seconds(profile.epoch.start_tdb, "TDB")
            )
        except InfeasibleDesignError:
            return {key: None for key in LIFE_KEYS}
    result = evaluate_design_life(context_for(profile), elements, float(life_days))
    return json_ready({key: result[key] for key in LIFE_KEYS})


def human_lines(profile_name: str, what: str, result: dict) -> list[str]:
    """The evaluate command's result for people: the profile and what was evaluated (``what``: a design in words
    or a constellation's name), then one labelled row per value in its quantity's format. A design that was not
    evaluated (an impact, no closed orbit) gives the reason instead of a table of empty metrics; rows without a
    value are left out; the wall time is in seconds to one decimal."""
    lines = [f"profile {profile_name}, {what}"]
    if result.get("evaluated") is False:
        lines.append(f"not evaluated: {result.get('reason') or 'no reason given'}")
        return lines
    shown = {
        key: value
        for key, value in result.items()
        if value is not None and value != "" and key not in ("evaluated", "reason")
    }
    width = max(len(label(key)) for key in shown)
    for key, value in shown.items():
        if isinstance(value, list):
            value = "; ".join(value) or "none"
        elif key == "wall_s":
            value = f"{value:.1f}"
        lines.append(f"{label(key):<{width}}  {format_value(key, value)}")
    return lines


def run(args: argparse.Namespace) -> int:
    life = args.design_life_days
    if life is not None and not (np.isfinite(life) and life > 0):
        raise ValueError(f"--design-life-days must be a positive number of days; got {life!r}")
    if (
        life is not None
    ):  # a life past the kernels' span is refused before the 10-day evaluation runs
        from ..ephemeris import check_span, ensure_kernels, tdb_seconds

        profile = load_settings(args.profile, overrides=profile_overrides(args))
        ensure_kernels(profile.ephemeris)
        t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
        try:
            check_span(t0, t0 + life * SECONDS_PER_DAY)
        except EphemerisRangeError as error:
            allowed_days = (error.end_tdb_s - t0) / SECONDS_PER_DAY
            raise ConfigError(
                f"--design-life-days {life!r} ({life / DAYS_PER_JULIAN_YEAR:,.1f} years from "
                f"{profile.epoch.start_tdb}): {error}; allowed: 0 < days <= {math.floor(allowed_days):,} from "
                f"{profile.epoch.start_tdb}",
                key="--design-life-days",
            ) from None
    walker = {  # flag -> value, in the order of evaluate_cli's design arguments
        "--sma-km": args.sma_km,
        "--ecc": args.ecc,
        "--aop-deg": args.aop_deg,
        "--inc-deg": args.inc_deg,
        "--planes": args.planes,
        "--sats-per-plane": args.sats_per_plane,
    }
    if args.constellation is not None:
        given = [flag for flag, value in walker.items() if value is not None]
        if given:
            raise ConfigError(
                f"--constellation replaces the Walker arguments; drop {', '.join(given)}"
            )
        result = evaluate_catalogue_cli(
            args.profile,
            args.constellation,
            epoch=args.constellation_epoch,
            overrides=profile_overrides(args),
        )
    else:
        missing = [flag for flag, value in walker.items() if value is None]
        if missing:
            raise ConfigError(
                f"evaluate needs --constellation NAME_OR_PATH or all Walker arguments; "
                f"missing {', '.join(missing)}"
            )
        _check_walker(args)
        result = evaluate_cli(args.profile, *walker.values(), overrides=profile_overrides(args))
    from ..campaign.settings import bounds_verdict

    profile = load_settings(args.profile, overrides=profile_overrides(args))
    result.update(bounds_verdict(profile.campaign, result))
    if args.design_life_days is not None:
        result.update(
            design_life_cli(
                args.profile,
                args.design_life_days,
                constellation=args.constellation,
                constellation_epoch=args.constellation_epoch,
                walker=tuple(walker.values()),
                overrides=profile_overrides(args),
            )
        )
    if args.json:
        print(json.dumps(result))
    else:
        result["violated_bounds"] = bounds_verdict(profile.campaign, result, labelled=True)[
            "violated_bounds"
        ]
        what = (
            f"constellation {args.constellation}"
            if args.constellation
            else f"a {args.sma_km:g} km, e {args.ecc:g}, AOP {args.aop_deg:g} deg, i {args.inc_deg:g} deg, "
            f"{args.planes} planes x {args.sats_per_plane}"
        )
        print("\n".join(human_lines(args.profile, what, result)))
    return 0


def _check_walker(args: argparse.Namespace) -> None:
    """The Walker arguments checked (evaluator.check_design) with the message naming the flag."""
    from ..evaluator import check_design

    flags = {
        "sma_km": "--sma-km",
        "e": "--ecc",
        "inc_deg": "--inc-deg",
        "aop_deg": "--aop-deg",
        "n_planes": "--planes",
        "sats_per_plane": "--sats-per-plane",
    }
    try:
        check_design(
            args.sma_km, args.ecc, args.aop_deg, args.inc_deg, args.planes, args.sats_per_plane
        )
    except ConfigError as error:
        flag = flags.get(error.key, error.key)
        raise ConfigError(f"{flag}: {error}", key=flag) from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--constellation",
        metavar="NAME_OR_PATH",
        help="catalogue name (params/constellations/NAME.toml) or a TOML file in that format, "
        "instead of the Walker arguments",
    )
    parser.add_argument(
        "--constellation-epoch",
        choices=("study", "file"),
        default="study",
        help="read the constellation's elements at the study epoch (default) or at its file's epoch",
    )
    parser.add_argument("--sma-km", type=float, help="semi-major axis (km)")
    parser.add_argument("--ecc", type=float, help="eccentricity, [0, 1)")
    parser.add_argument("--aop-deg", type=float, help="argument of perilune (deg)")
    parser.add_argument(
        "--inc-deg", type=float, help="inclination to the element frame's equator (deg)"
    )
    parser.add_argument("--planes", type=integer, help="number of planes Np (RAAN by eq. 42)")
    parser.add_argument("--sats-per-plane", type=integer, help="satellites per plane Ns")
    add_profile(parser, "quick")
    parser.add_argument(
        "--design-life-days",
        type=float,
        metavar="D",
        help="also fly the design life of D days: closed-loop station keeping, natural drift, DOP "
        "over the life, the campaign-grade Delta-V estimate and the stability screen",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_set(parser)
