"""A study's shipped results: a finished study of two ci campaigns exported and read back (each campaign's history
and front as the campaign gives them, small, with the study's provenance), and every study folder that is not its
study file's finished study refused with nothing written."""

import json
import shutil

import numpy as np
import pytest
import xarray as xr

from lnss_lib.campaign import export_results
from lnss_lib.campaign import study_reference as sref
from lnss_lib.campaign.costs import COSTS_FILE, read_costs
from lnss_lib.campaign.fitness import front_of, hypervolume_of_front, hypervolume_points
from lnss_lib.campaign.reference import MAX_FILE_BYTES
from lnss_lib.campaign.settings import campaign_hash, evaluation_hash
from lnss_lib.campaign.study import load_study, run_study
from lnss_lib.config import PARAMS_DIR, REFERENCE_DIR, profile_hash
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings

STUDY = "ci_pair"  # params/studies/ci_pair.toml: two seeds of ci on the synthetic evaluator
STUDY_PATH = PARAMS_DIR / "studies" / f"{STUDY}.toml"


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study") / "pair"
    run_study(STUDY_PATH, run_dir=folder, workers=0, progress=False)
    return folder


@pytest.fixture(scope="module")
def unfinished(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study") / "pair"
    run_study(STUDY_PATH, run_dir=folder, workers=0, progress=False, max_generations=1)
    return folder


def _copy(folder, tmp_path, name):
    copy = tmp_path / name
    shutil.copytree(folder, copy)
    return copy


SHIPPED_STUDIES = sorted(
    path.stem for path in sref.STUDIES_DIR.glob("*.toml") if (REFERENCE_DIR / path.stem).is_dir()
)


def assert_current_study(name, root=None, studies_dir=sref.STUDIES_DIR):
    """The export of study ``name`` in ``root`` is its study file's as it stands: every campaign of the file, each
    finished, its stored settings with the campaign hash and the evaluation hash of the settings the study gives it
    now, its recorded profile hash that of the settings it stored (in the README too), every file small."""
    shipped = sref.load_study_reference(name, root)
    assert shipped is not None, f"no shipped results of study {name}"
    study = load_study(studies_dir / f"{name}.toml")
    assert sorted(shipped.histories) == sorted(c.name for c in study.campaigns)
    for campaign in study.campaigns:
        settings = load_settings(campaign.profile, overrides=campaign.overrides or None)
        history, front = shipped.histories[campaign.name], shipped.fronts[campaign.name]
        stored = json.loads(history.attrs["parameters"])
        assert campaign_hash(stored) == campaign_hash(settings), (
            f"{name}/{campaign.name}: re-run the study and export it again"
        )
        assert evaluation_hash(stored) == evaluation_hash(settings)
        for ds in (history, front):
            assert ds.attrs["profile_hash"] == profile_hash(stored) and ds.attrs["finished"] == 1
        assert history.sizes["generation"] == settings.campaign.generations
        assert f"(`{profile_hash(stored)}`)" in shipped.readme
    assert all(p.stat().st_size < MAX_FILE_BYTES for p in shipped.folder.rglob("*") if p.is_file())


@pytest.mark.parametrize("name", SHIPPED_STUDIES)
def test_shipped_studies_are_their_study_files(name):
    """A change of physics or of a study file cannot leave a study's stale shipped results behind."""
    assert_current_study(name)


def test_export_round_trip(finished, tmp_path):
    folder = sref.export_study_reference(finished, tmp_path, export_commit="abc1234")
    assert folder == tmp_path / STUDY
    assert_current_study(STUDY, tmp_path)
    shipped = sref.load_study_reference(STUDY, tmp_path)
    assert list(shipped.histories) == list(shipped.fronts) == ["seed1", "seed2"]
    for name in shipped.histories:
        _, front, history = export_results(finished / name)
        xr.testing.assert_equal(shipped.histories[name].drop_attrs(), history.drop_attrs())
        xr.testing.assert_equal(
            shipped.fronts[name].drop_attrs(), front.drop_vars("error").drop_attrs()
        )
        for ds in (shipped.histories[name], shipped.fronts[name]):
            assert ds.attrs["Conventions"] == "CF-1.8" and ds.attrs["finished"] == 1
            assert ds.attrs["study"] == STUDY and ds.attrs["campaign"] == name
            assert ds.attrs["export_commit"] == "abc1234"
        run = json.loads((finished / name / "run.json").read_text())
        row = next(line for line in shipped.readme.splitlines() if line.startswith(f"| {name} |"))
        assert run["profile_hash"] in row and run["evaluation_hash"] in row
        assert f"| {run['profile']['campaign']['seed']} |" in row
        # the front holds every point of the hypervolume (a design it lacks is dominated in all objectives,
        # hence in the hypervolume's): its hypervolume is the history's last
        reference = tuple(json.loads(history.attrs["hypervolume_reference"]).items())
        columns = {k: shipped.fronts[name][k].values for k, _ in reference}
        points = hypervolume_points(columns, np.ones(front.sizes["design"], bool), reference)
        assert hypervolume_of_front(front_of(points)) == pytest.approx(
            float(history["hypervolume"][-1]), rel=1e-12, abs=0.0
        )
    seeds = [int(h.attrs["seed"]) for h in shipped.histories.values()]
    assert seeds == [1, 2]
    assert "**Study: complete**" in shipped.readme
    assert "abc1234" in shipped.readme and "packages (of the runs)" in shipped.readme
    files = [p for p in folder.rglob("*") if p.is_file()]
    assert len(files) == 6 and all(p.stat().st_size < MAX_FILE_BYTES for p in files)
    costs = read_costs(folder / COSTS_FILE)  # the replay's input: every design of every campaign
    for name in ("seed1", "seed2"):
        n_designs = export_results(finished / name)[0].sizes["design"]
        assert sum(len(generation) for generation in costs[name]) == n_designs
    again = sref.export_study_reference(finished, tmp_path)  # replaces its own previous export
    assert sref.load_study_reference(STUDY, tmp_path).readme.count("commit of the export | unknown")
    assert sorted(p.name for p in tmp_path.iterdir()) == [STUDY] and again == folder


def _refused(run_dir, root, match, **kwargs):
    with pytest.raises(ConfigError, match=match):
        sref.export_study_reference(run_dir, root, **kwargs)
    assert not (root / STUDY).exists()


def test_unfinished_study_refused(unfinished, tmp_path):
    _refused(
        unfinished,
        tmp_path,
        r"study ci_pair in .* has not finished \(seed1 at 1 of 3 generations; seed2 at 1 of 3 "
        r"generations\): continue it with python -m lnss_lib study --resume",
    )
    one = _copy(unfinished, tmp_path, "half")
    shutil.rmtree(one / "seed2")
    _refused(one, tmp_path, r"seed2 not started")


def test_foreign_or_edited_study_refused(finished, tmp_path):
    """Not a study folder; a study no study file gives (the file edited since); a campaign run with another
    campaign's settings (the seeds' folders swapped); a run.json edited after the start; a target that is not an
    export of the study."""
    _refused(finished / "seed1", tmp_path, "is not a study folder")
    other_studies = tmp_path / "studies"
    other_studies.mkdir()
    (other_studies / f"{STUDY}.toml").write_text(
        STUDY_PATH.read_text().replace("seed = 2 ", "seed = 3 ")
    )
    _refused(finished, tmp_path, "no study file in .* as it stands", studies_dir=other_studies)
    swapped = _copy(finished, tmp_path, "swapped")
    (swapped / "seed1").rename(swapped / "tmp")
    (swapped / "seed2").rename(swapped / "seed1")
    (swapped / "tmp").rename(swapped / "seed2")
    _refused(
        swapped,
        tmp_path,
        r"is not a campaign of campaign 'seed1' of study 'ci_pair' as it stands: .*campaign.seed = 2",
    )
    edited = _copy(finished, tmp_path, "edited")
    run = json.loads((edited / "seed2" / "run.json").read_text())
    run["commit"] = "0000000"
    (edited / "seed2" / "run.json").write_text(json.dumps(run))
    _refused(edited, tmp_path, "edited after the run started")
    mine = tmp_path / "mine"
    (mine / STUDY).mkdir(parents=True)
    (mine / STUDY / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="is not a previous export of study ci_pair"):
        sref.export_study_reference(finished, mine)
    assert [p.name for p in (mine / STUDY).iterdir()] == ["notes.txt"]
    with pytest.raises(ValueError, match="not a complete export"):
        sref.load_study_reference(STUDY, mine)
    assert sref.load_study_reference(STUDY, tmp_path / "none") is None


def test_export_command_line(finished, unfinished, tmp_path, monkeypatch, capsys):
    from lnss_lib.__main__ import main

    monkeypatch.setattr(sref, "REFERENCE_DIR", tmp_path)
    assert main(["study", "--export-reference", str(finished)]) == 0
    out = capsys.readouterr().out
    assert f"reference results of study '{STUDY}'" in out and "seed2/front.nc" in out
    histories = sref.load_study_reference(STUDY, tmp_path).histories
    assert all(np.all(np.diff(h["hypervolume"].values) >= 0) for h in histories.values())
    for args in (
        [str(unfinished)],
        [str(tmp_path / "missing")],
        [str(finished), "--workers", "2"],
    ):
        assert main(["study", "--export-reference", *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: ") and "Traceback" not in err[0]
