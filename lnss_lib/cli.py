"""The evaluate command's results (``python -m lnss_lib evaluate``): a design, a catalogue constellation or a
design life under a named profile, with exactly the command's JSON keys (NaN as None).

Top layer with ``__main__`` (tests/test_layers.py): the kernels (:mod:`lnss_lib.evaluator`,
:mod:`lnss_lib.catalogue`, :mod:`lnss_lib.design_life.evaluation`) compute, this module names the profile and shapes the
answer for the command line.
"""

from __future__ import annotations

import math

from .constants import SECONDS_PER_DAY
from .errors import ConfigError, InfeasibleDesignError
from .keys import RESULT_KEYS, format_value, gnss_metric_keys, label
from .settings import load_settings

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
    from .evaluator import check_design, context_for, evaluate_design

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
    from .catalogue import (
        EXTRA_RESULT_KEYS,
        evaluate_catalogue,
        file_epoch_profile,
        load_constellation,
        refuse_approximate,
    )
    from .evaluator import context_for

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
    from .constellation import WalkerDesign
    from .design_life.evaluation import (
        LIFE_KEYS,
        elements_deg_in_frame,
        evaluate_design_life,
        json_ready,
    )
    from .ephemeris import tdb_seconds
    from .evaluator import context_for
    from .propagator import elements_deg_to_states

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
        from .catalogue import constellation_states_mci, file_epoch_profile, load_constellation

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
