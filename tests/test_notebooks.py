"""What the notebooks produce under the `ci` profile: tables with values that must be physically sane,
figures, the campaigns and the index.

Each notebook runs once per test session, through nbval: `python -m pytest` collects every code cell of
notebooks/ as an item (`notebooks/NN_*.ipynb::Cell N`, lax mode: each cell runs without error, a cell
tagged NBVAL_CHECK_OUTPUT compares its output) before these tests, with LNSS_PROFILE=ci (conftest.py).
nbval runs them rather than papermill because nbval is the standard way a researcher tests notebooks
(`pytest --nbval-lax notebooks/`) and points at the failing cell, and because the files checked here are
written by the notebooks themselves, whichever runner executes them; papermill's own path (`reproduce`:
injected parameters, executed copies, manifest) is tested in tests/test_pipeline.py on a small notebook.
Run without the notebooks' items (``pytest tests/test_notebooks.py``), the ``notebook_runs`` fixture
executes them with ``reproduce`` instead. Every file read here must have been written in this session.
"""

import pandas as pd
import pytest

from lnss_lib.config import OUTPUTS_DIR
from lnss_lib.paper import TABLE_4
from lnss_lib.pipeline import notebook_paths, notebook_profile, write_index

PROFILE = notebook_profile()  # ci: conftest.py sets it for the session


@pytest.fixture(scope="module")
def executed(notebook_runs):
    assert notebook_runs.profile == PROFILE
    failed = {book.name: cells for book, cells in notebook_runs.failed.items() if cells}
    if failed:
        pytest.fail(
            f"notebooks failed ({', '.join(sorted(set(notebook_runs.runner.values())))}): {failed}"
        )
    write_index(PROFILE)
    return notebook_runs


def _fresh(path, runs):
    assert path.is_file(), path
    assert path.stat().st_mtime >= runs.started, f"{path} was not written in this test session"
    return path


def _table(name: str, runs) -> pd.DataFrame:
    return pd.read_csv(_fresh(OUTPUTS_DIR / PROFILE / "tables" / f"{name}.csv", runs))


def test_every_notebook_ran_under_the_ci_profile(executed):
    """Every notebook ran once; all but 06 (whose outputs are the campaign files) wrote a figure or table
    under outputs/ci/ in this session, so their kernels took the profile from the suite."""
    assert set(executed.runner) == set(notebook_paths())
    written = {
        path.stem[:2]
        for kind in ("figures", "tables")
        for path in (OUTPUTS_DIR / PROFILE / kind).glob("*")
        if path.stat().st_mtime >= executed.started
    }
    assert {book.stem[:2] for book in notebook_paths()} - {"06"} <= written


def test_propagator_notebook_meets_capstone_targets(executed):
    errors = _table("01_capstone_errors", executed).dropna(subset=["target (km)"])
    assert len(errors) == 3
    assert (errors["end error (km)"] <= errors["target (km)"]).all()


def test_dop_notebook_reproduces_the_paper_geometry(executed):
    table = _table("02_dop_elfo_vs_paper", executed)
    table = table.set_index(table.columns[0])
    ours = table["lunar_equator_of_epoch / moon_fixed"]
    assert (
        abs(ours["PDOP (3-sigma mean)"] / TABLE_4["pdop_mean_3sigma"] - 1) < 0.05
    )  # Table 4's PDOP within 5 %
    assert abs(ours["mean visible satellites"] / TABLE_4["mean_visible_sats"] - 1) < 0.05
    assert (
        table["j2000 / moon_fixed"]["PDOP (3-sigma mean)"] > 10
    )  # the literal J2000 reading breaks coverage


def test_figures_written(executed):
    figures = [
        f
        for f in (OUTPUTS_DIR / PROFILE / "figures").glob("*.html")
        if f.stat().st_mtime >= executed.started
    ]
    stems = {f.stem[:2] for f in figures}
    assert {b.stem[:2] for b in notebook_paths()} - {"06"} <= stems


def test_standalone_elfo_table4_dop_within_five_percent(executed):
    table = _table("05_table4", executed).set_index("metric")
    for metric in (
        "Satellite visibility",
        "PDOP (3-sigma mean)",
        "HDOP (3-sigma mean)",
        "PDOP availability (%)",
        "HDOP availability (%)",
    ):
        assert abs(table.loc[metric, "difference (%)"]) <= 5.0, metric
    assert table["why"].notna().all()


def test_gnss_tables_add_up(executed):
    """Notebook 03's GNSS table: a combination sees the sum of its systems' satellites, so adding a system never
    lowers the count; notebook 05's Table 4 rows carry the same numbers."""
    table = _table("03_gnss_by_system", executed).set_index("systems")
    systems = ["GPS", "Galileo", "BeiDou-3", "GLONASS"]
    assert table.loc["all four", "visible_mean"] == pytest.approx(
        table.loc[systems, "visible_mean"].sum(), rel=1e-9
    )
    assert (
        table.loc["GPS", "visible_mean"]
        <= table.loc["GPS + Galileo", "visible_mean"]
        <= table.loc["all four", "visible_mean"]
    )
    rows = _table("05_table4_gnss", executed).set_index("metric")
    assert rows.loc["Mean GNSS visibility (all four)", "this workbook"] == pytest.approx(
        table.loc["all four", "visible_mean"], rel=1e-9
    )


def test_campaign_and_pareto_outputs(executed):
    from lnss_lib.campaign.publication import load_published

    evaluations = load_published(
        _fresh(OUTPUTS_DIR / PROFILE / "campaign" / "published.json", executed).parent
    ).evaluations
    assert evaluations.sizes["design"] > 0 and "objectives" in evaluations.attrs
    table6 = _table("07_table6", executed)
    assert "why selected" in table6.columns
    assert _fresh(OUTPUTS_DIR / PROFILE / "index.html", executed).is_file()


def test_operational_companion_outputs(executed):
    """ci's companion campaign (ci_operational) ran beside it and notebooks 06-07 compare the two."""
    from lnss_lib.campaign.publication import load_published

    evaluations = load_published(
        _fresh(OUTPUTS_DIR / "ci_operational" / "campaign" / "published.json", executed).parent
    ).evaluations
    assert {"sk_dv_estimate_max_kms_per_year", "stable_screen"} <= set(evaluations.data_vars)
    side = _table("06_operational_comparison", executed).set_index("designs meeting")
    assert list(side.columns) == ["ci", "ci_operational"]
    assert side.loc["unique designs evaluated", "ci_operational"] == evaluations.sizes["design"]
    assert side.loc["all Table 3 bounds (feasible)", "ci_operational"] == int(
        evaluations.feasible.sum()
    )
    assert "sk_dv_estimate_max_kms_per_year" in _table("07_operational_table6", executed).columns


def test_validated_front_outputs(executed):
    """ci_operational's front was flown in closed loop (ci's short front may hold no feasible design)
    and published with the run; notebook 07 wrote the headline table, one row per size and the paper's claim."""
    from lnss_lib.campaign.publication import load_published
    from lnss_lib.settings import load_settings

    published = load_published(
        _fresh(OUTPUTS_DIR / "ci_operational" / "campaign" / "published.json", executed).parent
    )
    fv = load_settings("ci_operational").front_validation
    assert published.validated is not None and published.validated.attrs["complete"] == 1
    assert published.validated.sizes["design"] <= fv.max_designs + fv.headline_per_size * len(
        fv.headline_sizes
    )
    headline = _table("07_headline_validated", executed).set_index("row")
    assert list(headline.index) == [
        "smallest",
        *(f"{n} satellites" for n in fv.headline_sizes),
        "paper (abstract)",
    ]


def test_seed_question_outputs(executed):
    """Notebook 07 read the shipped seed study under the ci profile: one row per seed with its final hypervolume and
    milestones, and for every rule of Table 6 and the smallest feasible constellation an answer; with no study
    shipped it wrote no seed table (and said so)."""
    from lnss_lib.studies.seed_question import RULE_CRITERIA, SMALLEST_RULE, seed_study

    seeds = seed_study()
    path = OUTPUTS_DIR / PROFILE / "tables" / "07_seed_table.csv"
    if seeds is None:
        assert not path.is_file() or path.stat().st_mtime < executed.started
        return
    table = _table("07_seed_table", executed).set_index("campaign")
    assert list(table.index) == list(seeds.histories)
    assert (table["final hypervolume"] > 0).all()
    assert (table["generation at 99 %"] <= table["generations"]).all()
    changes = _table("07_seed_what_changes", executed).set_index("rule")
    assert list(changes.index) == [*RULE_CRITERIA, SMALLEST_RULE]
    assert (changes["seeds with a pick"] <= len(seeds.histories)).all()


def test_screen_validation_table(executed):
    """Notebook 08 screened random Table 3 designs and flew them with the full model (the screen's validation)."""
    from lnss_lib.keys import DESIGN_KEYS
    from lnss_lib.settings import load_settings
    from lnss_lib.studies.screen_validation import MISS_COLUMNS, agreement

    table = _table("08_screen_validation", executed)
    assert set(MISS_COLUMNS) <= set(table.columns)
    assert (
        table.groupby(list(DESIGN_KEYS)).ngroups
        == load_settings(PROFILE).life_evaluation.screen_validation_designs
    )
    assert 0.0 <= agreement(table)["agreement_pct"] <= 100.0
