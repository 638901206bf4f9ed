"""NSGA-II search over Walker designs (paper Section 5: eq. 43-45, Tables 3 and 5; Section 6.2).

Layer 3 of the workbook: the campaign engine. :func:`run_campaign` (``python -m lnss_lib campaign``)
runs pymoo's NSGA-II through ask and tell in a run directory; a campaign killed at any moment and
resumed (``--resume``) ends with the same population as an uninterrupted one. Modules:

* :mod:`.settings` (:class:`CampaignSettings`, the evaluation hash) and :mod:`.grid` (eq. 43-44);
* :mod:`.fitness`: objective and constraint matrices, non-dominated mask, hypervolume (numpy only);
* :mod:`.tasks` (one evaluation) and :mod:`.backends` (serial, Dask) with :class:`BatchEvaluator`;
* :mod:`.journal`: ``evaluations.jsonl``, the persistent evaluation cache;
* :mod:`.problem`: the pymoo problem and algorithm; :mod:`.rundir`: run.json, checkpoints, NetCDF export;
* :mod:`.runner`: the generation loop, which notifies the observers of :mod:`.callbacks` (error guard,
  history, checkpoint, progress bars); :mod:`.timing`: worker-time shares.
"""

from .backends import BatchEvaluator, DaskBackend, SerialBackend, open_backend
from .callbacks import Callback, Checkpointer, ErrorGuard, HistoryRecorder, ProgressBars, RunState
from .fitness import (constraint_matrix, constraint_violation, hypervolume, metric_columns, non_dominated_mask,
                      objective_matrix)
from .grid import DesignGrid
from .journal import EvaluationCache, read_cache_records
from .problem import WalkerDesignProblem, build_algorithm, build_termination
from .rundir import RESULT_FILES, export_results, final_population, load_checkpoint, load_run, write_results
from .runner import CampaignResult, default_callbacks, run_campaign
from .settings import CampaignSettings, evaluation_hash, evaluation_profile
from .tasks import evaluate_task, synthetic_evaluation
from .timing import campaign_timing

__all__ = ["run_campaign", "CampaignResult", "Callback", "RunState", "ErrorGuard", "HistoryRecorder",
           "Checkpointer", "ProgressBars", "default_callbacks", "CampaignSettings", "DesignGrid", "evaluation_hash",
           "evaluation_profile", "objective_matrix", "constraint_matrix", "constraint_violation",
           "non_dominated_mask", "hypervolume", "metric_columns", "evaluate_task", "synthetic_evaluation",
           "EvaluationCache", "read_cache_records", "SerialBackend", "DaskBackend", "open_backend",
           "BatchEvaluator", "WalkerDesignProblem", "build_algorithm", "build_termination", "load_run",
           "load_checkpoint", "final_population", "export_results", "write_results", "RESULT_FILES",
           "campaign_timing"]
