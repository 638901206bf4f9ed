"""NSGA-II search over Walker designs (paper Section 5: eq. 43-45, Tables 3 and 5; Section 6.2).

Layer 3 of the workbook: the campaign engine. :func:`run_campaign` (``python -m lnss_lib campaign``)
runs pymoo's NSGA-II through ask and tell in a run directory; a campaign killed at any moment and
resumed (``--resume``) ends with the same population as an uninterrupted one. Modules:

* :mod:`.settings` (:class:`CampaignPlan`, derived from ``settings.campaign``; the evaluation hash) and :mod:`.grid` (eq. 43-44);
* :mod:`.fitness`: objective and constraint matrices, non-dominated mask, hypervolume (numpy; pymoo's HV indicator);
* :mod:`.tasks` (one evaluation) and :mod:`.backends` (serial, Dask) with :class:`BatchEvaluator`;
* :mod:`.journal`: ``evaluations.jsonl``, the persistent evaluation cache;
* :mod:`.problem`: the pymoo problem and algorithm; :mod:`.rundir`: run.json, checkpoints, NetCDF export;
* :mod:`.publication`: a run published as its profile's campaign (a pointer to an unchanging copy);
* :mod:`.reference`: a run exported as its profile's shipped results (``outputs/reference/<profile>/``);
* :mod:`.validation`: the front flown in closed loop over the design life after NSGA-II (``validated.nc``);
* :mod:`.study`: many campaigns side by side on one Dask cluster (``python -m lnss_lib study FILE``);
  :mod:`.replay`: recorded per-design costs as sleeping tasks on N workers (what a cluster would take);
* :mod:`.runner`: the generation loop, which notifies the observers of :mod:`.callbacks` (error guard,
  history, checkpoint, progress bars); :mod:`.timing`: worker-time shares.

Names are imported on first use (PEP 562): ``lnss_lib.campaign.fitness`` or the settings load
without pymoo or Dask.
"""

from __future__ import annotations

import importlib

__all__ = [
    "run_campaign",
    "validate_run",
    "validate_front",
    "select_designs",
    "CampaignResult",
    "CampaignPlan",
    "DesignGrid",
    "load_run",
    "load_checkpoint",
    "final_population",
    "export_results",
    "write_results",
    "RESULT_FILES",
    "evaluation_hash",
    "evaluation_profile",
    "Callback",
    "RunState",
    "ErrorGuard",
    "HistoryRecorder",
    "Checkpointer",
    "ProgressBars",
    "CellProgressBar",
    "default_callbacks",
    "objective_matrix",
    "constraint_matrix",
    "constraint_violation",
    "non_dominated_mask",
    "hypervolume_points",
    "front_of",
    "hypervolume_of_front",
    "metric_columns",
    "evaluate_task",
    "synthetic_evaluation",
    "EvaluationCache",
    "read_cache_records",
    "SerialBackend",
    "DaskBackend",
    "open_backend",
    "campaign_task",
    "BatchEvaluator",
    "WalkerDesignProblem",
    "build_algorithm",
    "build_termination",
    "campaign_timing",
    "concurrent_workers",
]

_MODULES = {
    "BatchEvaluator": "backends",
    "DaskBackend": "backends",
    "SerialBackend": "backends",
    "campaign_task": "backends",
    "open_backend": "backends",
    "Callback": "callbacks",
    "CellProgressBar": "callbacks",
    "Checkpointer": "callbacks",
    "ErrorGuard": "callbacks",
    "HistoryRecorder": "callbacks",
    "ProgressBars": "callbacks",
    "RunState": "callbacks",
    "constraint_matrix": "fitness",
    "constraint_violation": "fitness",
    "front_of": "fitness",
    "hypervolume_of_front": "fitness",
    "hypervolume_points": "fitness",
    "metric_columns": "fitness",
    "non_dominated_mask": "fitness",
    "objective_matrix": "fitness",
    "DesignGrid": "grid",
    "EvaluationCache": "journal",
    "read_cache_records": "journal",
    "WalkerDesignProblem": "problem",
    "build_algorithm": "problem",
    "build_termination": "problem",
    "RESULT_FILES": "rundir",
    "export_results": "rundir",
    "final_population": "rundir",
    "load_checkpoint": "rundir",
    "load_run": "rundir",
    "write_results": "rundir",
    "CampaignResult": "runner",
    "default_callbacks": "runner",
    "run_campaign": "runner",
    "validate_run": "runner",
    "select_designs": "validation",
    "validate_front": "validation",
    "CampaignPlan": "settings",
    "evaluation_hash": "settings",
    "evaluation_profile": "settings",
    "evaluate_task": "tasks",
    "synthetic_evaluation": "tasks",
    "campaign_timing": "timing",
    "concurrent_workers": "timing",
}


def __getattr__(name: str):
    if name in _MODULES:
        value = getattr(importlib.import_module(f".{_MODULES[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
