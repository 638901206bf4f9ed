"""Campaign settings (``[campaign]`` of ``params/*.toml``, Table 5) checked once, and the evaluation hash.

:func:`evaluation_hash` covers every parameter that can change the evaluation of a scaled design, so
a run's journal is never re-used under other physics.
"""

from __future__ import annotations

from collections.abc import Mapping

import copy
import math
from dataclasses import dataclass, field

from ..config import EVALUATORS, NOTEBOOK_MODES, profile_hash
from ..settings import Settings, profile_data, settings_from_profile
from ..keys import METRIC_KEYS, VERDICT_KEYS, bound_text, format_value, label
from .fitness import constraint_matrix
from .grid import DesignGrid

__all__ = ["CampaignSettings", "evaluation_profile", "evaluation_hash", "bounds_verdict", "EVALUATORS", "CAMPAIGN_ONLY_KEYS",
           "NOTEBOOK_MODES", "OFF"]

OFF = "off"                        # a constraint or hypervolume entry set to "off" drops an inherited one
CAMPAIGN_ONLY_KEYS = ("population", "generations", "crossover_prob", "crossover_eta", "mutation_eta",
                      "mutation_prob_var", "seed", "ftol", "ftol_period", "objectives", "constraints",
                      "nan_objective", "nan_violation", "hypervolume", "max_resubmits",
                      "numba_threads_per_worker", "synthetic_delay_s", "max_errors",
                      "companion_profile", "notebook_mode")


NON_EVALUATION_SECTIONS = ("notebooks", "benchmark", "life_evaluation", "design_life")   # never read by a 10-day evaluation


@dataclass(frozen=True)
class CampaignSettings:
    """``profile["campaign"]`` checked (see ``params/paper.toml``); ValueError names a bad entry."""

    grid: DesignGrid
    population: int
    generations: int
    crossover_prob: float
    crossover_eta: float
    mutation_eta: float
    mutation_prob_var: float
    seed: int
    ftol: float
    ftol_period: int
    objectives: tuple[str, ...]
    constraints: tuple[tuple[str, str, float], ...]
    nan_objective: float
    nan_violation: float
    hypervolume: tuple[tuple[str, float], ...]
    evaluator: str
    synthetic_delay_s: float
    max_resubmits: int
    numba_threads_per_worker: int
    max_errors: int = 0
    overrides: dict = field(default_factory=dict)
    companion_profile: str = ""
    notebook_mode: str = "run"
    extra_metrics: tuple[str, ...] = ()     # [evaluator] extra_metrics: columns beyond METRIC_KEYS

    @classmethod
    def from_profile(cls, profile: dict) -> "CampaignSettings":
        if "campaign" not in profile:
            raise ValueError(f"profile {profile.get('profile', {}).get('name')!r} has no [campaign] section")
        c = profile["campaign"]

        def number(key, kind=float, low=None, high=None):
            if key not in c:
                raise ValueError(f"campaign.{key} is missing")
            value = c[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or (kind is int and value != int(value)):
                raise ValueError(f"campaign.{key} must be a finite {kind.__name__}; got {value!r}")
            if (low is not None and value < low) or (high is not None and value > high):
                raise ValueError(f"campaign.{key} = {value!r} is outside [{low}, {high}]")
            return kind(value)

        extras = tuple(profile.get("evaluator", {}).get("extra_metrics", ()))   # checked at load (config)
        metric_keys = METRIC_KEYS + extras       # what the evaluator returns
        objectives = tuple(c.get("objectives", ()))
        bad = [o for o in objectives if not isinstance(o, str) or o.lstrip("-") not in metric_keys]
        if not objectives or bad or len({o.lstrip("-") for o in objectives}) != len(objectives):
            raise ValueError(f"campaign.objectives must be distinct metric names (optionally '-' = maximise) "
                             f"from {', '.join(metric_keys)} (extra metrics: list them in [evaluator] "
                             f"extra_metrics); bad: {bad or objectives!r}")
        constraints = []
        for metric, spec in c.get("constraints", {}).items():
            if spec == OFF:
                continue
            if metric not in metric_keys or not isinstance(spec, Mapping) or len(spec) != 1 \
                    or next(iter(spec)) not in ("min", "max"):
                raise ValueError(f"campaign.constraints.{metric}: need a metric of {', '.join(metric_keys)} "
                                 f"and exactly one of {{min = value}}, {{max = value}} or {OFF!r}; got {spec!r}")
            kind, limit = next(iter(spec.items()))
            if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not math.isfinite(limit):
                raise ValueError(f"campaign.constraints.{metric}.{kind} must be a finite number; got {limit!r}")
            constraints.append((metric, kind, float(limit)))
        hv = []
        for metric, ref in c.get("hypervolume", {}).items():
            if ref == OFF:
                continue
            if metric not in metric_keys or isinstance(ref, bool) or not isinstance(ref, (int, float)) \
                    or not math.isfinite(ref) or ref <= 0:
                raise ValueError(f"campaign.hypervolume.{metric}: need a metric of {', '.join(metric_keys)} "
                                 f"and a positive reference value (or {OFF!r}); got {ref!r}")
            hv.append((metric, float(ref)))
        evaluator = c.get("evaluator", "walker")
        if evaluator not in EVALUATORS:
            raise ValueError(f"campaign.evaluator {evaluator!r} unknown; allowed: {', '.join(EVALUATORS)}")
        overrides = c.get("overrides", {})
        if not isinstance(overrides, dict) or "campaign" in overrides:
            raise ValueError(f"campaign.overrides must be a table of profile sections other than campaign; "
                             f"got {overrides!r}")
        companion = c.get("companion_profile", "")
        if not isinstance(companion, str) or companion == profile.get("profile", {}).get("name"):
            raise ValueError(f"campaign.companion_profile must be a profile name other than this one, or \"\" "
                             f"(none); got {companion!r}")
        mode = c.get("notebook_mode", "run")
        if mode not in NOTEBOOK_MODES:
            raise ValueError(f"campaign.notebook_mode {mode!r} unknown; allowed: {', '.join(NOTEBOOK_MODES)}")
        return cls(
            grid=DesignGrid.from_settings(c.get("variables", {})),
            population=number("population", int, 2),
            generations=number("generations", int, 1),
            crossover_prob=number("crossover_prob", float, 0.0, 1.0),
            crossover_eta=number("crossover_eta", float, 0.0),
            mutation_eta=number("mutation_eta", float, 0.0),
            mutation_prob_var=number("mutation_prob_var", float, 0.0, 1.0),
            seed=number("seed", int, 0),
            ftol=number("ftol", float, 0.0),
            ftol_period=number("ftol_period", int, 1),
            objectives=objectives,
            constraints=tuple(constraints),
            nan_objective=number("nan_objective", float, 0.0),
            nan_violation=number("nan_violation", float, 0.0),
            hypervolume=tuple(hv),
            evaluator=evaluator,
            synthetic_delay_s=number("synthetic_delay_s", float, 0.0),
            max_resubmits=number("max_resubmits", int, 0),
            numba_threads_per_worker=number("numba_threads_per_worker", int, 0),
            max_errors=number("max_errors", int, 0) if "max_errors" in c else 0,
            overrides=overrides,
            companion_profile=companion,
            notebook_mode=mode,
            extra_metrics=extras,
        )


def evaluation_profile(profile: dict) -> Settings:
    """The settings an evaluation runs under: the profile with ``campaign.overrides`` merged in."""
    settings = CampaignSettings.from_profile(profile)
    return settings_from_profile(profile).with_overrides(settings.overrides)


def bounds_verdict(profile: dict, result: dict, labelled: bool = False) -> dict:
    """:data:`~lnss_lib.keys.VERDICT_KEYS` of one evaluation under the profile's ``[campaign.constraints]`` (Table 3):
    ``meets_bounds`` and ``violated_bounds``, each violated bound as text with the value and the bound. A metric
    that is undefined (NaN or None: an impact, fewer than four satellites in view) violates its bound, as in the
    campaign (:func:`~lnss_lib.campaign.fitness.constraint_matrix`). ``labelled``: bounds in words with units
    (:func:`~lnss_lib.keys.bound_text`, for people) instead of keys (for programs)."""
    constraints = CampaignSettings.from_profile(profile).constraints
    value = {m: math.nan if result.get(m) is None else float(result[m]) for m in (METRIC_KEYS[0], *(c[0] for c in constraints))}
    g = constraint_matrix({m: [v] for m, v in value.items()}, constraints, math.inf)[0]
    if labelled:
        violated = [f"{label(m)} {format_value(m, value[m]) if math.isfinite(value[m]) else 'undefined'}, "
                    f"not {bound_text(m, kind, limit)}" for (m, kind, limit), gi in zip(constraints, g) if gi > 0.0]
    else:
        violated = [f"{m} = {value[m]:.6g} {'>' if kind == 'max' else '<'} {kind} {limit:g}" if math.isfinite(value[m])
                    else f"{m} undefined ({kind} {limit:g})" for (m, kind, limit), gi in zip(constraints, g) if gi > 0.0]
    return dict(zip(VERDICT_KEYS, (not violated, violated)))


def evaluation_hash(profile: dict) -> str:
    """Hash of every parameter that can change an evaluation of a scaled design.

    :func:`~lnss_lib.config.profile_hash` of the profile without the campaign-only keys
    (``CAMPAIGN_ONLY_KEYS``: population, objectives, constraints, seed, ...) and without the sections
    that a 10-day evaluation never reads (``NON_EVALUATION_SECTIONS``: notebooks, design life); the grid
    (``campaign.variables``), ``campaign.overrides`` and ``campaign.evaluator`` stay in.
    """
    profile = profile_data(profile)
    CampaignSettings.from_profile(profile)
    content = {k: copy.deepcopy(v) for k, v in profile.items() if k not in NON_EVALUATION_SECTIONS}
    for key in CAMPAIGN_ONLY_KEYS:
        content["campaign"].pop(key, None)
    return profile_hash(content)
