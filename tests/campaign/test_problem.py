"""The pymoo problem over the grid and the termination of Table 5."""

import math
import pickle

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import WalkerDesignProblem, run_campaign
from lnss_lib.keys import METRIC_KEYS


def test_problem_evaluates_through_its_source_and_pickles_without_it(settings):
    calls = []

    def source(x):
        calls.append(np.array(x))
        n = len(x)
        values = {k: np.full(n, math.nan) for k in METRIC_KEYS}
        values["n_sat"] = np.array([4] * n)
        return values

    problem = WalkerDesignProblem(settings, source)
    out = problem.evaluate(
        np.array([[1, 2, 3, 4, 0, 1], [5, 6, 7, 8, 1, 2]]), return_as_dictionary=True
    )
    assert (
        out["F"].shape == (2, 9)
        and np.all(np.isfinite(out["F"]))
        and np.all(out["G"][:, :3] == 1e3)
    )
    assert len(calls) == 1 and calls[0].shape == (2, 6)
    clone = pickle.loads(pickle.dumps(problem))
    assert clone.metrics_source is None
    with pytest.raises(ValueError, match="no metrics source"):
        clone.evaluate(np.zeros((1, 6), dtype=int))


def test_tolerance_termination_stops_early(tmp_path):
    overrides = {
        "campaign": {"evaluator": "synthetic", "generations": 40, "ftol": 10.0, "ftol_period": 3}
    }
    result = run_campaign(
        "ci", overrides=overrides, workers=0, run_dir=tmp_path / "tol", progress=False
    )
    history = xr.open_dataset(result.run_dir / "history.nc", engine="h5netcdf")
    first_feasible = int(history.generation[history.n_feasible_pop > 0][0])
    assert result.generations < 40 and result.generations <= first_feasible + 4
    assert history.attrs["finished"] == 1
    fixed = run_campaign(
        "ci",
        overrides={"campaign": {"evaluator": "synthetic", "generations": 5}},
        workers=0,
        run_dir=tmp_path / "fixed",
        progress=False,
    )
    assert fixed.generations == 5


def test_runner_notifies_callbacks_in_order_and_resume_continues_history(tmp_path):
    from lnss_lib.campaign import Callback, load_checkpoint

    class Recorder(Callback):
        def __init__(self):
            self.events = []

        def on_session_start(self, state):
            self.events.append(("start", len(state.history)))

        def on_generation_start(self, state):
            self.events.append(("gen", state.generation, state.n_designs))

        def on_designs(self, state, n_done, n_total, n_hits):
            assert 0 <= n_done <= n_total and n_total + n_hits <= state.n_designs

        def on_generation_end(self, state):
            # runs after the default chain: the generation is in the history and checkpointed
            assert state.history[-1]["generation"] == state.generation and state.wall_s > 0
            assert load_checkpoint(state.run_dir)["generation"] == state.generation
            self.events.append(("end", state.generation))

        def on_session_end(self, state):
            self.events.append(("stop", len(state.history)))

    synthetic = {"campaign": {"evaluator": "synthetic", "generations": 3}}
    first = Recorder()
    run_campaign(
        "ci",
        overrides=synthetic,
        workers=0,
        run_dir=tmp_path / "run",
        progress=False,
        max_generations=2,
        callbacks=[first],
    )
    assert first.events == [
        ("start", 0),
        ("gen", 1, 6),
        ("end", 1),
        ("gen", 2, 6),
        ("end", 2),
        ("stop", 2),
    ]
    second = Recorder()
    result = run_campaign(resume=tmp_path / "run", workers=0, progress=False, callbacks=[second])
    assert (
        second.events == [("start", 2), ("gen", 3, 6), ("end", 3), ("stop", 3)]
        and result.generations == 3
    )


def test_resume_on_another_kernel_processor_warns_and_continues(tmp_path):
    """A run resumed where the kernels are compiled for another processor model than recorded in run.json goes on,
    with a RuntimeWarning naming both models; on the same model it resumes silently."""
    import json
    import re
    import warnings

    from lnss_lib import kernel_cpu
    from lnss_lib.campaign.rundir import run_checksum

    synthetic = {"campaign": {"evaluator": "synthetic", "generations": 3}}
    run_campaign(
        "ci",
        overrides=synthetic,
        workers=0,
        run_dir=tmp_path / "run",
        progress=False,
        max_generations=1,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run_campaign(resume=tmp_path / "run", workers=0, progress=False, max_generations=1)
    path = tmp_path / "run" / "run.json"
    run = json.loads(path.read_text())
    run["versions"]["kernel_cpu"] = "other-model"
    path.write_text(json.dumps({**run, "checksum": run_checksum(run)}))
    with pytest.warns(RuntimeWarning, match=f"other-model.*{re.escape(kernel_cpu())}"):
        result = run_campaign(resume=tmp_path / "run", workers=0, progress=False)
    assert result.generations == 3
