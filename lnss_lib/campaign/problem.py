"""The pymoo problem over the scaled grid (eq. 43) and the NSGA-II of Table 5 with its termination."""

from __future__ import annotations

import numpy as np
from pymoo.core.problem import Problem

from ..keys import DESIGN_KEYS
from .fitness import constraint_matrix, objective_matrix
from .settings import CampaignPlan

__all__ = ["WalkerDesignProblem", "build_algorithm", "build_termination"]


class WalkerDesignProblem(Problem):
    """pymoo problem over the scaled grid (integers 0..``grid.n_levels``) of eq. 43.

    ``metrics_source(scaled (n, 6)) -> metric columns`` (a :class:`BatchEvaluator`) supplies the
    metrics; it is not pickled with the problem (attach it again after loading a checkpoint).
    """

    def __init__(self, plan: CampaignPlan, metrics_source=None):
        super().__init__(
            n_var=len(DESIGN_KEYS),
            n_obj=len(plan.objectives),
            n_ieq_constr=len(plan.constraints),
            xl=np.zeros(len(DESIGN_KEYS), dtype=int),
            xu=plan.grid.n_levels,
            vtype=int,
        )
        self.plan = plan
        self.metrics_source = metrics_source

    def _evaluate(self, x, out, *args, **kwargs):
        if self.metrics_source is None:
            raise ValueError(
                "WalkerDesignProblem has no metrics source: set problem.metrics_source first"
            )
        metrics = self.metrics_source(x)
        s = self.plan
        out["F"] = objective_matrix(metrics, s.objectives, s.nan_objective)
        if s.constraints:
            out["G"] = constraint_matrix(metrics, s.constraints, s.nan_violation)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["metrics_source"] = None
        return state

    def __setstate__(self, state):
        if "settings" in state:  # a checkpoint written when the plan was stored as ``settings``
            state["plan"] = state.pop("settings")
        self.__dict__.update(state)


def build_algorithm(plan: CampaignPlan):
    """NSGA-II of Table 5 on the integer grid: integer random sampling, SBX crossover applied with
    probability ``crossover_prob`` (Table 5's crossover fraction) and polynomial mutation, both
    rounded back to the grid; duplicates in a generation eliminated."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.operators.sampling.rnd import IntegerRandomSampling

    prob_var = plan.mutation_prob_var if plan.mutation_prob_var > 0.0 else None
    return NSGA2(
        pop_size=plan.population,
        sampling=IntegerRandomSampling(),
        crossover=SBX(
            prob=plan.crossover_prob,
            eta=plan.crossover_eta,
            vtype=float,
            repair=RoundingRepair(),
        ),
        mutation=PM(eta=plan.mutation_eta, prob_var=prob_var, vtype=float, repair=RoundingRepair()),
        eliminate_duplicates=True,
    )


def build_termination(plan: CampaignPlan):
    """``generations`` generations; with ``ftol`` > 0 also pymoo's objective-space tolerance (feasible
    designs, movement of ideal, nadir and front below ``ftol`` over ``ftol_period`` generations)."""
    from pymoo.termination.max_gen import MaximumGenerationTermination

    max_gen = MaximumGenerationTermination(plan.generations)
    if plan.ftol <= 0.0:
        return max_gen
    from pymoo.termination.collection import TerminationCollection
    from pymoo.termination.ftol import MultiObjectiveSpaceTermination
    from pymoo.termination.robust import RobustTermination

    tol = RobustTermination(
        MultiObjectiveSpaceTermination(plan.ftol, only_feas=True), period=plan.ftol_period
    )
    return TerminationCollection(max_gen, tol)
