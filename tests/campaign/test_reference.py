"""Shipped reference results: the committed exports are the current profiles', and the export
round-trips, stays under the size limit, carries CF attributes, marks partial runs and refuses run folders
that fail their checks."""

import json

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import export_results, final_population, load_checkpoint, run_campaign
from lnss_lib.campaign import reference as ref
from lnss_lib.campaign.publication import run_differences
from lnss_lib.campaign.settings import CampaignPlan, campaign_hash, evaluation_hash
from lnss_lib.config import available_profiles, profile_hash
from lnss_lib.keys import DESIGN_KEYS
from lnss_lib.settings import load_settings
from lnss_lib.studies.campaign import designs_shown

CF_GLOBALS = ("title", "institution", "source", "history", "references", "Conventions")
PROFILE = (
    "ci_synthetic"  # a profile whose own evaluator is the synthetic one: its runs are its campaign
)


@pytest.fixture(scope="module", autouse=True)
def synthetic_profile(tmp_path_factory):
    """Profile :data:`PROFILE` (ci with the synthetic evaluator), loadable by name in this module's processes."""
    from lnss_lib.config import use_profile_file

    path = tmp_path_factory.mktemp("profiles") / f"{PROFILE}.toml"
    path.write_text('[profile]\ninherits = "ci"\n\n[campaign]\nevaluator = "synthetic"\n')
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("LNSS_PROFILE_FILES", "{}")
        use_profile_file(path)
        yield path


def _reseal(path, run):
    """Write ``run`` into ``path`` under a fresh checksum (an edit that passes the checksum: the checks behind it)."""
    from lnss_lib.campaign.rundir import run_checksum

    path.write_text(json.dumps({**run, "checksum": run_checksum(run)}))


SHIPPED = sorted(
    path.name
    for path in ref.REFERENCE_DIR.iterdir()
    if path.is_dir() and path.name in available_profiles()
)  # campaign exports are named after their profile; a study's shipped results beside them are not


def test_both_paper_campaigns_are_shipped():
    assert {"paper", "paper_dv_physical"} <= set(SHIPPED)


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_results_are_the_current_profiles(name):
    """A change of physics or of the campaign's settings cannot leave stale shipped results behind: every export's
    (the paper's two campaigns, and each study shipped beside them) stored settings have the campaign hash and the
    evaluation hash of the profile as it stands (a section its evaluations never read may have changed since), and
    its recorded profile hash is that of the settings it stored."""
    shipped = ref.load_reference(name)
    assert shipped is not None, f"no shipped results in {ref.REFERENCE_DIR / name}"
    settings = load_settings(name)
    stored_hash = profile_hash(shipped.profile)
    for ds in (shipped.evaluations, shipped.front, shipped.history, shipped.population):
        assert ds.attrs["profile_hash"] == stored_hash
        assert ds.attrs["profile"] == name and ds.attrs["Conventions"] == "CF-1.8"
    assert campaign_hash(shipped.profile) == campaign_hash(settings), (
        f"{name}: re-run and re-export the campaign"
    )
    assert evaluation_hash(shipped.profile) == evaluation_hash(settings)
    assert run_differences(shipped.profile, settings) == []
    assert all(path.stat().st_size < ref.MAX_FILE_BYTES for path in shipped.folder.iterdir())
    assert f"hash `{stored_hash}`" in shipped.readme


@pytest.fixture(scope="module")
def partial_run(tmp_path_factory):
    """A synthetic ci campaign stopped after 2 of its generations (resumable, not finished)."""
    run_dir = tmp_path_factory.mktemp("partial") / "run"
    run_campaign(PROFILE, workers=0, run_dir=run_dir, progress=False, max_generations=2)
    return run_dir


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("finished") / "run"
    run_campaign(PROFILE, workers=0, run_dir=run_dir, progress=False)
    return run_dir


def test_export_round_trip_with_cf_attributes(finished_run, tmp_path):
    folder = ref.export_reference(finished_run, tmp_path, export_commit="abc1234")
    assert folder == tmp_path / PROFILE and sorted(p.name for p in folder.iterdir()) == sorted(
        (*ref.REFERENCE_FILES, ref.README_FILE)
    )
    shipped = ref.load_reference(PROFILE, tmp_path)
    evaluations, front, history = export_results(finished_run)
    xr.testing.assert_allclose(shipped.front.drop_attrs(), front.drop_vars("error").drop_attrs())
    xr.testing.assert_allclose(shipped.history.drop_attrs(), history.drop_attrs())
    x, _ = final_population(finished_run)
    designs = CampaignPlan.of(load_settings(PROFILE)).grid.descale(x.astype(float))
    np.testing.assert_allclose(
        np.column_stack([shipped.population[k].values for k in DESIGN_KEYS]), designs
    )
    feasible = evaluations["feasible"].values
    assert shipped.evaluations.sizes["design"] == (
        feasible.sum() if feasible.any() else shipped.evaluations.attrs["n_selected"]
    )
    assert shipped.evaluations.attrs["n_designs_evaluated"] == evaluations.sizes["design"]
    assert (
        designs_shown(evaluations)
        == f"every unique design the run evaluated ({evaluations.sizes['design']})"
    )
    assert designs_shown(shipped.evaluations).startswith(
        f"{shipped.evaluations.sizes['design']} of the {evaluations.sizes['design']} unique designs the run evaluated"
    )
    assert shipped.finished and shipped.history.attrs["partial"] == 0
    for ds in (shipped.evaluations, shipped.front, shipped.history, shipped.population):
        assert all(ds.attrs.get(key) for key in CF_GLOBALS) and ds.attrs["Conventions"] == "CF-1.8"
        for name in list(ds.data_vars) + list(ds.coords):
            assert ds[name].attrs.get("long_name"), name
            assert ds[name].dtype.kind in "US" or ds[name].attrs.get("units"), name
    assert shipped.front["dv_total_kms_per_year"].attrs["units"] == "km s-1 yr-1"
    assert shipped.front["sma_km"].attrs["units"] == "km"
    assert shipped.history["wall_s"].attrs["units"] == "s"
    for text in (
        "abc1234",
        "| complete | yes |",
        "| seed |",
        "numpy",
        "generations completed",
        "machine",
    ):
        assert text in shipped.readme, text
    assert (
        shipped.front.attrs["run_commit"]
        == json.loads((finished_run / "run.json").read_text())["commit"]
        != ""
    )
    assert (
        json.loads(shipped.history.attrs["worker_time"])["n_evaluations"]
        == evaluations.sizes["design"]
    )


def test_partial_run_is_marked_partial(partial_run, tmp_path):
    shipped = ref.load_reference(PROFILE, ref.export_reference(partial_run, tmp_path).parent)
    assert not shipped.finished and shipped.history.sizes["generation"] == 2
    for ds in (shipped.evaluations, shipped.front, shipped.history, shipped.population):
        assert ds.attrs["partial"] == 1 and ds.attrs["finished"] == 0
    assert "PARTIAL: 2 of" in shipped.readme and "| complete | no |" in shipped.readme


def test_thinning_keeps_the_front_and_fits_the_limit():
    from lnss_lib.studies.pareto import synthetic_campaign

    evaluations = synthetic_campaign(20000, seed=3)
    evaluations["error"] = ("design", np.full(20000, ""))
    front = evaluations.isel(design=np.flatnonzero(evaluations.feasible.values)[::97])
    encode = ref.netcdf_bytes
    whole, data = ref.thin_to_fit(evaluations, front, encode, ref.MAX_FILE_BYTES)
    assert (
        whole.attrs["n_kept"]
        == whole.attrs["n_selected"]
        == whole.sizes["design"]
        == evaluations.feasible.sum()
    )
    assert (
        whole.attrs["thinning"].startswith("none")
        and whole.attrs["selection"] == "the feasible designs"
    )
    limit = 0.5 * len(data)
    thin, thin_data = ref.thin_to_fit(evaluations, front, encode, limit)
    assert (
        len(thin_data) < limit
        and thin.attrs["n_kept"] < thin.attrs["n_selected"] == whole.sizes["design"]
    )
    assert (
        "uniform sample" in thin.attrs["thinning"]
        and thin.attrs["n_kept"] > 0.3 * whole.sizes["design"]
    )
    kept = {tuple(row) for row in np.column_stack([thin[k].values for k in DESIGN_KEYS])}
    assert 0 < front.sizes["design"] < thin.sizes["design"]
    assert all(
        tuple(row) in kept for row in np.column_stack([front[k].values for k in DESIGN_KEYS])
    )


def _copy(run_dir, tmp_path, name):
    import shutil

    return shutil.copytree(run_dir, tmp_path / name)


def _edited_and_resealed(run_dir, copy_dir, root, edit):
    """A copy of ``run_dir`` whose run.json ``edit`` changed: refused for the edit, then re-sealed (its checksum
    computed again, as a forger would) so that the checks behind the checksum are reached."""
    import shutil

    from lnss_lib.errors import ConfigError

    shutil.copytree(run_dir, copy_dir)
    run = json.loads((copy_dir / "run.json").read_text())
    edit(run)
    (copy_dir / "run.json").write_text(json.dumps(run))
    with pytest.raises(ConfigError, match="edited after the run started"):
        ref.export_reference(copy_dir, root)
    _reseal(copy_dir / "run.json", run)
    return copy_dir


def test_export_refuses_a_damaged_or_forged_run_folder(finished_run, tmp_path):
    from lnss_lib.campaign.rundir import CheckpointError
    from lnss_lib.errors import ConfigError

    root = tmp_path / "reference"
    good = ref.export_reference(finished_run, root)
    before = {p.name: p.read_bytes() for p in good.iterdir()}
    damaged = _copy(finished_run, tmp_path, "damaged")
    data = bytearray((damaged / "checkpoint.pkl").read_bytes())
    data[len(data) // 2] ^= 0xFF
    (damaged / "checkpoint.pkl").write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="truncated or corrupt"):
        ref.export_reference(damaged, root)
    edited = _edited_and_resealed(
        finished_run,
        tmp_path / "edited",
        root,
        lambda run: run["profile"]["campaign"].update(seed=99),
    )
    with pytest.raises(ConfigError, match="differ from those the run started with"):
        ref.export_reference(edited, root)
    forged = _copy(finished_run, tmp_path, "forged")
    run = json.loads((forged / "run.json").read_text())
    run["evaluation_hash"] = "0123456789abcdef"
    _reseal(forged / "run.json", run)
    with pytest.raises(ConfigError, match="not that of its settings"):
        ref.export_reference(forged, root)
    foreign = _copy(finished_run, tmp_path, "foreign")
    lines = (foreign / "evaluations.jsonl").read_text().split("\n")
    lines[0] = json.dumps({"evaluation_hash": "0123456789abcdef", "format": 2})
    (foreign / "evaluations.jsonl").write_text("\n".join(lines))
    with pytest.raises(ConfigError, match="a journal of other physics"):
        ref.export_reference(foreign, root)
    with pytest.raises(ConfigError, match="is not a folder"):
        ref.export_reference(tmp_path / "nothing", root)
    assert {
        p.name: p.read_bytes() for p in good.iterdir()
    } == before  # the previous export is untouched
    assert sorted(p.name for p in root.iterdir()) == [PROFILE]  # and no staging folder is left


# a profile whose evaluations run the life estimate (the synthetic stand-in's metrics)
OPERATIONAL = "ci_operational_synthetic"


@pytest.fixture(scope="module")
def operational_run(tmp_path_factory, synthetic_profile):
    """A synthetic campaign of :data:`OPERATIONAL` (ci_operational with the synthetic evaluator)
    stopped after 2 generations."""
    from lnss_lib.config import use_profile_file

    path = synthetic_profile.parent / f"{OPERATIONAL}.toml"
    path.write_text(
        '[profile]\ninherits = "ci_operational"\n\n[campaign]\nevaluator = "synthetic"\n'
    )
    use_profile_file(path)
    run_dir = tmp_path_factory.mktemp("operational") / "run"
    run_campaign(OPERATIONAL, workers=0, run_dir=run_dir, progress=False, max_generations=2)
    return run_dir


def _recorded_before_the_life_estimate(run_dir, copy_dir):
    """A copy of ``run_dir`` as a run begun before the life estimate's ``[design_life]`` settings
    entered the evaluation hash records itself: run.json and journal under the hash without them."""
    from lnss_lib.campaign.settings import recorded_evaluation_hashes

    run_dir = _copy(run_dir, copy_dir.parent, copy_dir.name)
    run = json.loads((run_dir / "run.json").read_text())
    now, before = recorded_evaluation_hashes(run["profile"])
    assert now == evaluation_hash(run["profile"]) and before != now
    _reseal(run_dir / "run.json", {**run, "evaluation_hash": before})
    lines = (run_dir / "evaluations.jsonl").read_text().split("\n")
    lines[0] = json.dumps({"evaluation_hash": before, "format": 2})
    (run_dir / "evaluations.jsonl").write_text("\n".join(lines))
    return run_dir, before


def test_a_run_recorded_before_the_life_estimate_entered_the_hash_stays_the_profiles(
    operational_run, tmp_path
):
    """A run begun before the life estimate's ``[design_life]`` settings entered the evaluation hash
    (its run.json and journal hold the hash without them) is exported and resumed under its recorded
    hash while its settings are the profile's; it is not the campaign of a profile whose estimate
    settings differ from those it stored."""
    old, before = _recorded_before_the_life_estimate(operational_run, tmp_path / "old")
    folder = ref.export_reference(old, tmp_path / "reference")
    with xr.open_dataset(folder / "front.nc") as front:
        assert front.attrs["evaluation_hash"] == before
    resumed = run_campaign(OPERATIONAL, resume=old, workers=0, progress=False, max_generations=1)
    assert len(load_checkpoint(resumed.run_dir)["history"]) == 3
    header = json.loads((old / "evaluations.jsonl").read_text().split("\n")[0])
    assert header["evaluation_hash"] == before
    stored = json.loads((old / "run.json").read_text())["profile"]
    assert run_differences(stored, load_settings(OPERATIONAL)) == []
    other = load_settings(OPERATIONAL, overrides={"design_life": {"target_fraction": 0.7}})
    assert any("evaluation settings differ" in reason for reason in run_differences(stored, other))


def test_export_command_line(finished_run, tmp_path, monkeypatch, capsys):
    from lnss_lib.__main__ import main

    monkeypatch.setattr(ref, "REFERENCE_DIR", tmp_path)
    assert main(["campaign", "--export-reference", str(finished_run)]) == 0
    out = capsys.readouterr().out
    assert f"reference results of profile '{PROFILE}' (complete)" in out and "evaluations.nc" in out
    assert ref.load_reference(PROFILE, tmp_path).finished
    assert main(["campaign", "--export-reference", str(tmp_path / "missing")]) == 2
    assert main(["campaign", "--export-reference", str(finished_run), "--profile", "ci"]) == 2
    damaged = _copy(finished_run, tmp_path, "damaged")
    (damaged / "checkpoint.pkl").write_bytes(b"LNSS campaign checkpoint\n{}\n")
    assert main(["campaign", "--export-reference", str(damaged)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 3
        and all(line.startswith("error: ") for line in err)
        and "Traceback" not in "".join(err)
    )


def test_export_never_replaces_complete_results_with_anything_else(
    finished_run, partial_run, tmp_path
):
    """Shipped results are replaced only by a run of their profile's own settings, complete when they are, and
    only where a previous export lies: a toy run with overrides, a renamed run, a partial run over a complete
    export and a folder that is not an export are refused and leave the folder as it was."""
    from lnss_lib.errors import ConfigError

    root = tmp_path / "reference"
    good = ref.export_reference(finished_run, root)
    before = {p.name: p.read_bytes() for p in good.iterdir()}
    toy = tmp_path / "toy"
    run_campaign(
        PROFILE, overrides={"campaign": {"generations": 1}}, workers=0, run_dir=toy, progress=False
    )
    with pytest.raises(
        ConfigError, match=f"is not a campaign of profile .{PROFILE}.*campaign.generations = 1"
    ):
        ref.export_reference(toy, root)
    renamed = _edited_and_resealed(
        finished_run,
        tmp_path / "renamed",
        root,
        lambda run: run["profile"]["profile"].update(name="ci"),
    )
    with pytest.raises(
        ConfigError, match="is not a campaign of profile 'ci'.*its evaluator is 'synthetic'"
    ):
        ref.export_reference(renamed, root)
    with pytest.raises(ConfigError, match="a partial run never replaces complete results"):
        ref.export_reference(partial_run, root)
    assert {p.name: p.read_bytes() for p in good.iterdir()} == before
    other = tmp_path / "other"
    (other / PROFILE).mkdir(parents=True)
    (other / PROFILE / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="is not a previous export"):
        ref.export_reference(finished_run, other)
    assert [p.name for p in (other / PROFILE).iterdir()] == ["notes.txt"]
    assert (
        ref.load_reference(
            PROFILE, ref.export_reference(partial_run, other.parent / "fresh").parent
        )
        is not None
    )


def test_forged_provenance_never_reaches_the_readme(finished_run, tmp_path):
    """run.json's provenance (commit, start time, versions) is under its checksum: an edit is refused, and a
    run.json without a checksum (an older run, or one whose checksum was cut) has its provenance printed as not
    verifiable, never as the run's."""
    from lnss_lib.errors import ConfigError

    forged = _copy(finished_run, tmp_path, "forged")
    run = json.loads((forged / "run.json").read_text())
    run.update(
        commit="0000000 all tests passed",
        created_utc="1969-07-20T20:17:40Z",
        versions={"numpy": "forged"},
    )
    (forged / "run.json").write_text(json.dumps(run))
    with pytest.raises(ConfigError, match="edited after the run started"):
        ref.export_reference(forged, tmp_path / "a")
    del run["checksum"]
    (forged / "run.json").write_text(json.dumps(run))
    readme = ref.load_reference(PROFILE, ref.export_reference(forged, tmp_path / "b").parent).readme
    assert "all tests passed" not in readme and "1969" not in readme and "forged" not in readme
    assert readme.count("not verifiable") == 3
