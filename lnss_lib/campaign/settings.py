"""The campaign plan (``[campaign]`` of ``params/*.toml``, Table 5) derived once from checked settings, and
the evaluation hash.

:mod:`lnss_lib.config` checks every campaign rule at load (ranges, objectives and bounds that name metrics,
constraints ``{min|max}``, the grid); :meth:`CampaignPlan.of` only derives what the engine runs by (the
grid, the objectives, the constraint list, the hypervolume references) from ``settings.campaign``.
:func:`evaluation_hash` covers every parameter that can change the evaluation of a scaled design, so
a run's journal is never re-used under other physics.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import typing
from collections.abc import Mapping
from dataclasses import dataclass, fields

from ..config import profile_hash
from ..keys import (
    METRIC_KEYS,
    VERDICT_KEYS,
    bound_text,
    format_value,
    label,
    runs_screen,
    wants_life_estimate,
)
from ..legacy_keys import legacy_spelling
from ..profile_rules import CAMPAIGN_OFF as OFF
from ..profile_rules import lookup
from ..sections import EVALUATORS, NOTEBOOK_MODES, DesignLifeSettings
from ..setting_rule import rule_of
from ..settings import CampaignSettings, Settings, profile_data
from .fitness import constraint_matrix
from .grid import DesignGrid

__all__ = [
    "CampaignPlan",
    "campaign_constraints",
    "evaluation_profile",
    "evaluation_hash",
    "recorded_evaluation_hashes",
    "campaign_hash",
    "reads_screen",
    "reads_life_estimate",
    "LIFE_ESTIMATE_KEYS",
    "bounds_verdict",
    "run_differences",
    "EVALUATORS",
    "CAMPAIGN_ONLY_KEYS",
    "NOTEBOOK_MODES",
    "OFF",
]

CAMPAIGN_ONLY_KEYS = (
    "population",
    "generations",
    "crossover_prob",
    "crossover_eta",
    "mutation_eta",
    "mutation_prob_var",
    "seed",
    "ftol",
    "ftol_period",
    "objectives",
    "constraints",
    "nan_objective",
    "nan_violation",
    "hypervolume",
    "max_resubmits",
    "numba_threads_per_worker",
    "synthetic_delay_s",
    "max_errors",
    "companion_profile",
    "notebook_mode",
)


NON_EVALUATION_SECTIONS = (
    "notebooks",
    "benchmark",
    "life_evaluation",
    "life_navigation",
    "robustness",
    "design_life",
    "front_validation",
)  # never read by a 10-day evaluation
SCREEN_SECTION = (
    "stability"  # read by a 10-day evaluation only when an extra metric needs the screen
)


def _life_estimate_keys(section=DesignLifeSettings, prefix: str = "design_life") -> tuple[str, ...]:
    keys, hints = [], typing.get_type_hints(section)
    for item in dataclasses.fields(section):
        if dataclasses.is_dataclass(hints[item.name]):
            keys += _life_estimate_keys(hints[item.name], f"{prefix}.{item.name}")
        elif rule_of(item).life_estimate:
            keys.append(f"{prefix}.{item.name}")
    return tuple(keys)


LIFE_ESTIMATE_KEYS = _life_estimate_keys()
"""The ``[design_life]`` settings the campaign's life estimate reads (its fields declared with
``setting(life_estimate=True)``): the box and the service controller's tolerances, windows and
spacing it prices by. A 10-day evaluation reads them only through the estimate
(:func:`reads_life_estimate`)."""


def campaign_constraints(campaign: CampaignSettings) -> tuple[tuple[str, str, float], ...]:
    """``(metric, "min" | "max", limit)`` of ``[campaign.constraints]`` (Table 3), entries set to "off" left out."""
    return tuple(
        (metric, kind, float(limit))
        for metric, spec in campaign.constraints.items()
        if spec != OFF
        for kind, limit in spec.items()
    )


@dataclass(frozen=True)
class CampaignPlan(CampaignSettings):
    """What the campaign engine runs by: the checked ``[campaign]`` section (no checks here: :mod:`lnss_lib.config`
    made them at load) with its tables read for the engine: the grid of eq. 43-44, the constraints as
    ``(metric, "min" | "max", limit)`` and the hypervolume references as ``(metric, reference)``, entries set to
    "off" left out, and the metrics an evaluation returns beyond :data:`~lnss_lib.keys.METRIC_KEYS`."""

    constraints: tuple[tuple[str, str, float], ...]
    hypervolume: tuple[tuple[str, float], ...]
    grid: DesignGrid
    extra_metrics: tuple[str, ...]  # [evaluator] extra_metrics

    @classmethod
    def of(cls, settings: Settings) -> CampaignPlan:
        """The plan of checked settings (``settings.campaign`` and ``settings.evaluator.extra_metrics``)."""
        campaign = settings.campaign
        section = {item.name: getattr(campaign, item.name) for item in fields(CampaignSettings)}
        return cls(
            **{
                **section,
                "overrides": copy.deepcopy(dict(campaign.overrides)),
                "constraints": campaign_constraints(campaign),
                "hypervolume": tuple(
                    (metric, float(ref))
                    for metric, ref in campaign.hypervolume.items()
                    if ref != OFF
                ),
            },
            grid=DesignGrid.from_variables(campaign.variables, campaign.n_sat),
            extra_metrics=tuple(settings.evaluator.extra_metrics),
        )


def evaluation_profile(settings: Settings) -> Settings:
    """The settings an evaluation runs under: ``settings`` with ``campaign.overrides`` merged in."""
    return settings.with_overrides(settings.campaign.overrides)


def bounds_verdict(campaign: CampaignSettings, result: dict, labelled: bool = False) -> dict:
    """:data:`~lnss_lib.keys.VERDICT_KEYS` of one evaluation under ``[campaign.constraints]`` (Table 3):
    ``meets_bounds`` and ``violated_bounds``, each violated bound as text with the value and the bound. A metric
    that is undefined (NaN or None: an impact, fewer than four satellites in view) violates its bound, as in the
    campaign (:func:`~lnss_lib.campaign.fitness.constraint_matrix`). ``labelled``: bounds in words with units
    (:func:`~lnss_lib.keys.bound_text`, for people) instead of keys (for programs)."""
    constraints = campaign_constraints(campaign)
    value = {
        m: math.nan if result.get(m) is None else float(result[m])
        for m in (METRIC_KEYS[0], *(c[0] for c in constraints))
    }
    g = constraint_matrix({m: [v] for m, v in value.items()}, constraints, math.inf)[0]
    if labelled:
        violated = [
            f"{label(m)} {format_value(m, value[m])}, {'above' if kind == 'max' else 'below'} its bound {limit:g}"
            if math.isfinite(value[m])
            else f"{label(m)} undefined (bound: {bound_text(m, kind, limit)})"
            for (m, kind, limit), gi in zip(constraints, g)
            if gi > 0.0
        ]
    else:
        violated = [
            f"{m} = {value[m]:.6g} {'>' if kind == 'max' else '<'} {kind} {limit:g}"
            if math.isfinite(value[m])
            else f"{m} undefined ({kind} {limit:g})"
            for (m, kind, limit), gi in zip(constraints, g)
            if gi > 0.0
        ]
    return dict(zip(VERDICT_KEYS, (not violated, violated)))


def _evaluated(profile: Mapping, section: str) -> dict:
    """``profile``'s ``section`` as its evaluations read it (``campaign.overrides`` merged in)."""
    overrides = profile.get("campaign", {}).get("overrides", {})
    return {**profile.get(section, {}), **overrides.get(section, {})}


def reads_life_estimate(profile: Mapping) -> bool:
    """Whether a 10-day evaluation under ``profile`` (plain data, ``campaign.overrides`` included)
    runs the life estimate (:data:`LIFE_ESTIMATE_KEYS`): the evaluator's own rule,
    :func:`lnss_lib.keys.wants_life_estimate` under ``[sk_estimate] model = "life"``."""
    wanted = tuple(_evaluated(profile, "evaluator").get("extra_metrics", ()))
    return wants_life_estimate(wanted) and _evaluated(profile, "sk_estimate").get("model") == "life"


def reads_screen(profile: Mapping) -> bool:
    """Whether a 10-day evaluation under ``profile`` (plain data, ``campaign.overrides`` included)
    runs the stability screen (``[stability]``): the evaluator's own rule,
    :func:`lnss_lib.keys.runs_screen`."""
    wanted = tuple(_evaluated(profile, "evaluator").get("extra_metrics", ()))
    return runs_screen(wanted, _evaluated(profile, "sk_estimate").get("model"))


def evaluation_hash(settings: Settings | Mapping) -> str:
    """Hash of every parameter that can change an evaluation of a scaled design.

    :func:`~lnss_lib.config.profile_hash` of the profile without the campaign-only keys
    (``CAMPAIGN_ONLY_KEYS``: population, objectives, constraints, seed, ...), without the sections
    that a 10-day evaluation never reads (``NON_EVALUATION_SECTIONS``: notebooks, design life),
    without ``[stability]`` unless the evaluation runs the screen (:func:`reads_screen`) and with
    the ``[design_life]`` settings of :data:`LIFE_ESTIMATE_KEYS` where it runs the life estimate
    (:func:`reads_life_estimate`); the grid (``campaign.variables``), ``campaign.overrides`` and
    ``campaign.evaluator`` stay in. ``settings``: checked settings, or the profile dict a run folder
    stored (compared as it is, not validated again).
    """
    return _evaluation_hash(settings, life_estimate=True)


def recorded_evaluation_hashes(settings: Settings | Mapping) -> tuple[str, ...]:
    """The evaluation hashes a run of ``settings`` may have recorded: :func:`evaluation_hash` and,
    where its evaluations run the life estimate, the hash without the estimate's ``[design_life]``
    settings, which runs begun before those entered the hash recorded (their ``run.json`` checksum
    keeps the stored settings as they were; whether they are a profile's campaign
    :func:`run_differences` tells in today's terms)."""
    return tuple(dict.fromkeys((evaluation_hash(settings), _evaluation_hash(settings, False))))


def _evaluation_hash(settings: Settings | Mapping, life_estimate: bool) -> str:
    content = _campaign_content(settings, life_estimate)
    for key in CAMPAIGN_ONLY_KEYS:
        content.get("campaign", {}).pop(key, None)
    return profile_hash(content)


def _campaign_content(settings: Settings | Mapping, life_estimate: bool = True) -> dict:
    """The profile data a campaign's results depend on: every section but those its evaluations
    never read, and of ``[design_life]`` the settings of :data:`LIFE_ESTIMATE_KEYS` where they run
    the life estimate (unless ``life_estimate`` is False: the content before those entered)."""
    profile = legacy_spelling(
        profile_data(settings)
    )  # the keys of the fingerprint, while every section is here
    unread = NON_EVALUATION_SECTIONS + (() if reads_screen(profile) else (SCREEN_SECTION,))
    content = {k: v for k, v in profile.items() if k not in unread}
    if life_estimate and reads_life_estimate(profile):
        for key in LIFE_ESTIMATE_KEYS:
            *path, name = key.split(".")
            table = content
            for part in path:
                table = table.setdefault(part, {})
            table[name] = lookup(profile, key)
    return content


def _differing_keys(run: dict, theirs: dict, prefix: str = "") -> list[str]:
    """``key = run value (profile: value)`` for every dotted key whose values differ."""
    lines = []
    for key in sorted(set(run) | set(theirs), key=str):
        name = f"{prefix}{key}"
        mine, other = run.get(key, "<absent>"), theirs.get(key, "<absent>")
        if isinstance(mine, Mapping) and isinstance(other, Mapping):
            lines += _differing_keys(mine, other, f"{name}.")
        elif mine != other and name not in ("profile.name", "profile.description"):
            lines.append(f"{name} = {mine!r} (profile: {other!r})")
    return lines


def campaign_hash(settings: Settings | Mapping) -> str:
    """Hash of every setting a campaign's results depend on: :func:`evaluation_hash`'s settings and the
    campaign-only keys (population, seed, objectives, ...), so that a change to a section its evaluations never
    read (notebooks, the design life, an unread ``[stability]``) leaves a run the profile's campaign."""
    return profile_hash(_campaign_content(settings))


def run_differences(
    run: Settings | Mapping, settings: Settings | Mapping, limit: int = 6
) -> list[str]:
    """Why a run (its settings, or the profile dict its ``run.json`` stored) is not the campaign of ``settings``: []
    when their :func:`campaign_hash` agree, else the evaluator, the evaluation settings and up to ``limit`` differing
    keys, in that order (nothing is validated: a stored dict is compared as it is)."""
    run_hash, hash_ = campaign_hash(run), campaign_hash(settings)
    if run_hash == hash_:
        return []
    run_profile, profile = (
        legacy_spelling(profile_data(p)) for p in (run, settings)
    )  # keys of one spelling
    reasons = []
    run_evaluator, evaluator = (
        p.get("campaign", {}).get("evaluator") for p in (run_profile, profile)
    )
    if run_evaluator != evaluator:
        reasons.append(f"its evaluator is {run_evaluator!r}, the profile's {evaluator!r}")
    run_eval_hash, eval_hash = evaluation_hash(run_profile), evaluation_hash(profile)
    if run_eval_hash != eval_hash:
        reasons.append(
            f"its evaluation settings differ (evaluation hash {run_eval_hash}, the profile's {eval_hash})"
        )
    keys = _differing_keys(run_profile, profile)
    reasons.append(
        f"campaign hash {run_hash}, the profile's {hash_}"
        + (
            f": {'; '.join(keys[:limit])}"
            + (f"; and {len(keys) - limit} more" if len(keys) > limit else "")
            if keys
            else ""
        )
    )
    return reasons
