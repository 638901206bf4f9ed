"""One rule for "the smallest constellation that keeps the service" (lnss_lib.campaign.fitness.smallest_constellation):
the answer that opens the findings and the README, the findings' smallest constellation, Table 6's first row,
Figure 16's caption and notebook 07's comparison with the paper name the same design."""

import numpy as np
import pytest

from lnss_lib import findings
from lnss_lib.campaign.fitness import deltav_constraint
from lnss_lib.campaign.reference import load_reference
from lnss_lib.keys import design_text
from lnss_lib.paper import SMALLEST_CONSTELLATION
from lnss_lib.studies.pareto import (
    TABLE6_RULES,
    analysis_front,
    figure16_title,
    pareto_front,
    smallest_constellation,
    synthetic_campaign,
    table6,
)

TARGET_PCT = SMALLEST_CONSTELLATION["availability_pct"]


def _table6_first(front, dv_metric: str, dv_bound: float):
    """Table 6's first row as notebook 07 draws it (the bound, else the bound removed) and Figure 16's caption."""
    selected = table6(
        front, availability_min_pct=TARGET_PCT, dv_max_kms_per_year=dv_bound, dv_metric=dv_metric
    )
    if selected.empty:
        selected = table6(
            front, availability_min_pct=TARGET_PCT, dv_max_kms_per_year=np.inf, dv_metric=dv_metric
        )
    first = selected.iloc[0]
    assert first["why selected"].startswith(TABLE6_RULES[0][0])
    return first, figure16_title(first)


def test_shipped_answer_table6_figure16_and_notebook_07_name_one_design():
    """Under ``paper`` the answer reads every evaluated design of ``paper_dv_physical``, Table 6 and Figure 16 its
    front: the same design all the same (the front holds the smallest)."""
    physical = load_reference("paper_dv_physical")
    dv_metric, dv_bound = deltav_constraint(physical.evaluations)
    first, caption = _table6_first(physical.front, dv_metric, dv_bound)
    named = design_text(first)
    assert named in findings.study_answer().workbook
    assert named in caption and caption.startswith(f"Figure 16: {int(first['n_sat'])} satellites")
    small = smallest_constellation(physical.front, dv_metric, TARGET_PCT)
    assert design_text(small) == named


@pytest.mark.parametrize("dv_bound", [1.0, 0.0], ids=["some feasible", "none feasible"])
def test_findings_row_names_table6s_first_design(tmp_path, monkeypatch, dv_bound):
    """The findings' "Smallest constellation" row and Table 6's first row of the same campaign; with nothing
    feasible both fall back to every bound but the Delta-V's."""
    ds = synthetic_campaign(300, seed=4)
    ds.attrs["constraints"] = ds.attrs["constraints"].replace(
        "dv_total_kms_per_year <= 1", f"dv_total_kms_per_year <= {dv_bound:g}"
    )
    monkeypatch.setattr(findings, "_campaign", lambda name: ds)
    (row,) = [
        f
        for f in findings.campaign_findings(tmp_path, "synthetic", None)
        if f.topic.startswith("Smallest")
    ]
    front, _ = analysis_front(ds, pareto_front(ds))
    first, caption = _table6_first(front, "dv_total_kms_per_year", dv_bound)
    assert row.workbook.startswith(f"{int(first['n_sat'])} satellites")
    assert design_text(first) in row.workbook and design_text(first) in caption
    assert ("no design meets every bound" in row.why) == (dv_bound == 0.0)
