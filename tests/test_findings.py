"""The answer that opens the findings page and the README (lnss_lib.findings.study_answer), and findings read
from the shipped results when the run has no campaign of its own."""

import types

import numpy as np
import plotly.graph_objects as go
import pytest
import xarray as xr

import lnss_lib.figures as figures
import lnss_lib.figures.export as export
import lnss_lib.outputs
import lnss_lib.pipeline as pipeline
from lnss_lib import findings
from lnss_lib.paper import SMALLEST_CONSTELLATION


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    monkeypatch.setattr(lnss_lib.outputs, "OUTPUTS_DIR", tmp_path)
    monkeypatch.setattr(
        export, "_png_bytes", lambda fig, width, height: None
    )  # HTML only: no renderer started
    return tmp_path


def _evaluations(n_sat, avail, dv, dv_bound, evaluated):
    n = len(n_sat)
    return xr.Dataset(
        {
            "n_sat": ("design", np.array(n_sat)),
            "pdop_mean_3sigma": ("design", np.full(n, 3.0)),
            "pdop_avail_pct": ("design", np.array(avail, float)),
            "hdop_avail_pct": ("design", np.array(avail, float)),
            "dv_total_kms_per_year": ("design", np.array(dv, float)),
            "sma_km": ("design", np.arange(n) * 100.0 + 5000.0),
            "ecc": ("design", np.full(n, 0.5)),
            "inc_deg": ("design", np.full(n, 60.0)),
            "aop_deg": ("design", np.full(n, 90.0)),
            "n_planes": ("design", np.full(n, 2)),
            "sats_per_plane": ("design", np.array(n_sat) // 2),
        },
        attrs={
            "constraints": f"pdop_mean_3sigma <= 10,pdop_avail_pct >= 70,dv_total_kms_per_year <= {dv_bound}",
            "n_designs_evaluated": evaluated,
        },
    )


@pytest.fixture
def shipped(monkeypatch):
    """Two shipped campaigns: Table 3's bound (none feasible) and the bound moved to 4.6 km/s/yr."""
    campaigns = {
        "paper": _evaluations([6, 8, 10], [95.0, 80.0, 99.0], [2.5, 1.2, 1.9], 1, evaluated=500),
        "paper_dv_physical": _evaluations(
            [6, 6, 6, 8, 4],
            [92.0, 95.0, 75.0, 99.0, 91.0],
            [2.4, 2.0, 1.1, 1.5, 5.0],
            4.6,
            evaluated=900,
        ),
    }
    monkeypatch.setattr(
        findings,
        "load_reference",
        lambda name: (
            types.SimpleNamespace(evaluations=campaigns[name]) if name in campaigns else None
        ),
    )
    return campaigns


def test_answer_from_the_shipped_campaigns(outputs, shipped):
    answer = findings.study_answer()
    # over the paper's availability, feasible under 4.6: the 6-satellite designs at 92 % and 95 %, the cheaper wins
    assert (
        "6 satellites (a 5100 km" in answer.workbook
        and "95.0 % PDOP and 95.0 % HDOP availability" in answer.workbook
    )
    assert (
        "none of the 500 designs" in answer.workbook
        and "the cheapest of the 3 meeting" in answer.workbook
    )
    assert (
        "costs 1.200 km/s/yr" in answer.workbook
        and "4 of 900 designs are feasible" in answer.workbook
    )
    ratio = 2.0 / SMALLEST_CONSTELLATION["dv_below_kms_per_year"]
    assert (
        "2.000 km/s/yr per satellite" in answer.differs_most
        and f"{ratio:.1f} times" in answer.differs_most
    )
    assert all(len(line) <= 100 for line in answer.markdown().splitlines())


def test_no_answer_without_both_campaigns(outputs, monkeypatch):
    monkeypatch.setattr(findings, "load_reference", lambda name: None)
    assert findings.study_answer() is None
    page = pipeline.write_index("t").read_text()
    assert 'id="answer"' not in page and 'id="findings"' in page


def test_index_and_findings_open_on_the_answer_and_headline_figure(outputs, shipped):
    figures.save_figure(go.Figure(go.Scatter(x=[0, 1], y=[1, 2])), "t", "07_fig8_hdop_pdop_deltav")
    (outputs / "t" / "figures" / "07_fig8_hdop_pdop_deltav.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    page = pipeline.write_index("t").read_text()
    assert page.index('id="answer"') < page.index('id="findings"') < page.index('id="nb-07"')
    assert '<img class="headline" src="figures/07_fig8_hdop_pdop_deltav.png"' in page
    markdown = (outputs / "t" / findings.FINDINGS_FILE).read_text()
    assert (
        markdown.index("**Question.**")
        < markdown.index("![07_fig8_hdop_pdop_deltav]")
        < markdown.index("| result |")
    )


def test_campaign_findings_read_the_shipped_results(outputs, shipped):
    rows = {
        f.topic: f
        for f in findings.campaign_findings(outputs / "paper", "paper", "paper_dv_physical")
    }
    assert (
        rows["Designs meeting Table 3 (paper-faithful, paper)"].workbook
        == "0 of 500 unique designs"
    )
    assert (
        rows["Designs meeting Table 3 (operational, paper_dv_physical)"].workbook
        == "4 of 900 unique designs"
    )
    smallest = rows[
        "Smallest constellation (operational, paper_dv_physical)"
    ].workbook  # the 4 is over the bound, the cheapest 6 (75 %) does not keep the service
    assert smallest.startswith("6 satellites, Delta-V total (km/s/yr) 2.000 (a 5100 km")


def test_design_life_rows_say_what_they_count(outputs):
    import pandas as pd

    table = pd.DataFrame(
        {
            "region": ["Table 4 ELFO"] * 3,
            "life_days": [365.0] * 3,
            "impact_day": [np.nan, np.nan, 161.0],
            "sk_dv_kms_per_year": [0.2, 1.4, 0.9],
            "sk_dv_max_kms_per_year": [0.3, 1.6, 1.1],
        }
    )
    lnss_lib.outputs.save_table(table, "t", "08_validation", caption="validation")
    (row,) = findings.design_life_findings(outputs / "t")
    assert row.topic == "Design life: Table 4 ELFO (3 designs flown in closed loop)"
    assert row.workbook == (
        "1 of 3 within 1 km/s/yr on every satellite, none lost; 2 of 3 keep every satellite "
        "over 365 days; the controller burned 0.200 to 1.400 km/s/yr per satellite"
    )
    assert "not the paper's eq. 45 Delta-V" in row.why and "lost on day 161" in row.why


def test_deltav_row_sets_the_papers_model_beside_the_closed_loop(outputs):
    import pandas as pd

    from lnss_lib.paper import TABLE_4

    assert findings.deltav_findings(outputs / "t") == []  # neither pair in the run: no row
    side = pd.DataFrame(
        {
            "status": ["kept", "kept", "failed"],
            "dv_total_kms_per_year": [2.1, 1.9, 3.0],
            "closed_loop_dv_kms_per_year": [0.0, 0.08, 0.5],
            "closed_loop_dv_max_kms_per_year": [0.0, 0.22, 0.9],
        }
    )
    lnss_lib.outputs.save_table(side, "t", findings.DELTAV_TABLE, caption="side by side")
    table4 = pd.DataFrame({"metric": list(TABLE_4), "this workbook": np.arange(len(TABLE_4)) + 0.5})
    lnss_lib.outputs.save_table(table4, "t", "05_table4", caption="Table 4")
    life = pd.DataFrame(
        {
            "region": ["frozen family", "standalone ELFO"],
            "element_frame": ["moon_op", "lunar_equator_of_epoch"],
            "sk_dv_kms_per_year": [0.3, 0.0],
        }
    )
    lnss_lib.outputs.save_table(life, "t", "08_validation", caption="validation")
    (row,) = findings.deltav_findings(outputs / "t")
    eq45_elfo = list(TABLE_4).index("dv_total_kms_per_year") + 0.5
    assert row.workbook == (
        "2 designs of the operational front flown: eq. 45 total 1.900 to 2.100, closed loop 0.000 to 0.080 "
        f"(worst satellite 0.000 to 0.220); the Table 4 ELFO: eq. 45 total {eq45_elfo:.3f}, closed loop 0.000 "
        "(lunar_equator_of_epoch)"
    )
    assert "two different quantities" in row.why
