"""Command line and pipeline: propagate output, clear errors, notebook selection, manifests."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from terminal import foreground_signals

from lnss_lib.__main__ import main
from lnss_lib.config import PROJECT_DIR
from lnss_lib.outputs import write_manifest
from lnss_lib.pipeline import notebook_paths


def test_propagate_writes_csv(tmp_path):
    out = tmp_path / "orbit.csv"
    code = main(
        [
            "propagate",
            "--epoch-tdb",
            "2025-05-01T00:00:00",
            "--elements",
            "6143",
            "0.6",
            "51.7",
            "0",
            "90",
            "0",
            "--days",
            "0.5",
            "--step-s",
            "900",
            "--degree",
            "8",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("t_tdb_s,x,y,z,vx,vy,vz")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (49, 7)
    assert np.linalg.norm(table[0, 1:4]) == pytest.approx(6143 * 0.4, rel=1e-9)
    assert np.all(np.diff(table[:, 0]) == 900.0)


def test_propagate_netcdf_with_state(tmp_path):
    import xarray as xr

    out = tmp_path / "orbit.nc"
    code = main(
        [
            "propagate",
            "--epoch-tdb",
            "2022-11-25T00:00:00",
            "--state-km",
            "-16983.14",
            "21213.56",
            "-58035.63",
            "-0.044576",
            "-0.051375",
            "0.141642",
            "--days",
            "0.1",
            "--step-s",
            "600",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds.r_mci_km.dims == ("sat", "time", "xyz")


def test_bad_elements_and_profile_give_clear_errors(capsys):
    assert (
        main(
            [
                "propagate",
                "--epoch-tdb",
                "2025-05-01T00:00:00",
                "--elements",
                "6143",
                "1.2",
                "51.7",
                "0",
                "90",
                "0",
                "--days",
                "1",
            ]
        )
        == 2
    )
    assert "eccentricity" in capsys.readouterr().err
    assert main(["reproduce", "--profile", "nonexistent"]) == 2
    assert "unknown profile 'nonexistent'" in capsys.readouterr().err


def test_module_entry_point_runs():
    result = subprocess.run(
        [sys.executable, "-m", "lnss_lib", "--help"],
        cwd=PROJECT_DIR,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0 and "reproduce" in result.stdout


def test_notebook_selection():
    names = [p.stem for p in notebook_paths()]
    assert names == sorted(names) and names[0] == "01_propagator_validation"
    assert [p.stem for p in notebook_paths(["01"])] == ["01_propagator_validation"]
    with pytest.raises(ValueError, match="no notebook matches '99'"):
        notebook_paths(["99"])


def test_manifest_records_parameters_versions_and_checksums(tmp_path, monkeypatch):
    import lnss_lib.outputs as outputs

    monkeypatch.setattr(outputs, "OUTPUTS_DIR", tmp_path)
    path = write_manifest("ci", {"test": {"status": "ok", "wall_s": 0.0}})
    assert path.parent == tmp_path / "ci"
    manifest = json.loads(path.read_text())
    assert manifest["parameters"]["profile"]["name"] == "ci"
    assert manifest["packages"]["numpy"] == np.__version__
    assert len(manifest["data_sha256"]["data/gravity/Moon_AIUB-GRL350B_deg100.txt"]) == 64
    assert "skyfield-data:de421.bsp" in manifest["data_sha256"]
    assert manifest["notebooks"]["test"]["status"] == "ok"


def test_shipped_data_match_their_checksums():
    from lnss_lib.ephemeris import file_sha256

    data = PROJECT_DIR / "params" / "data"
    for line in (data / "SHA256SUMS").read_text().splitlines():
        digest, name = line.split()
        assert file_sha256(data / name) == digest, name


def test_evaluate_catalogue_constellation(capsys):
    """`evaluate --constellation NAME --json` gives the evaluator's keys plus the catalogue labels."""
    assert (
        main(["evaluate", "--constellation", "bhamidipati2023_case_c", "--profile", "ci", "--json"])
        == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert result["n_sat"] == 16 and result["evaluated"] is True
    assert result["element_frame"] == "moon_op" and result["epoch_source"].startswith("study epoch")
    assert main(["evaluate", "--constellation", "moonlight_lcns_approx", "--profile", "ci"]) == 2
    assert "approximate" in capsys.readouterr().err
    assert main(["evaluate", "--constellation", "bhamidipati2023_case_c", "--ecc", "0.5"]) == 2
    assert "--ecc" in capsys.readouterr().err
    assert main(["evaluate", "--sma-km", "6143"]) == 2
    assert "missing --ecc" in capsys.readouterr().err


def test_ctrl_c_on_reproduce_is_one_line_exit_130(tmp_path):
    """Ctrl-C (SIGINT to the foreground process group) while a notebook runs printed the kernel's ZMQ
    traceback: one line, exit 130, no temporary notebook left and no kernel left running."""
    import os
    import signal
    import time

    import nbformat

    books, outputs, marker = tmp_path / "notebooks", tmp_path / "outputs", tmp_path / "kernel.pid"
    books.mkdir()
    cells = [
        nbformat.v4.new_code_cell(
            "profile_name = 'ci'\noverrides_json = '{}'", metadata={"tags": ["parameters"]}
        ),
        nbformat.v4.new_code_cell(
            f"import os, pathlib, time\npathlib.Path({str(marker)!r}).write_text(str(os.getpid()))"
            "\ntime.sleep(300)"
        ),
    ]
    kernelspec = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(
        nbformat.v4.new_notebook(cells=cells, metadata={"kernelspec": kernelspec}),
        books / "01_wait.ipynb",
    )
    script = (
        "import sys\nfrom pathlib import Path\nimport lnss_lib.outputs as outputs, lnss_lib.pipeline as pipeline\n"
        "pipeline.NOTEBOOKS_DIR, outputs.OUTPUTS_DIR = Path(sys.argv[1]), Path(sys.argv[2])\n"
        "from lnss_lib.__main__ import main\nsys.exit(main(['reproduce', '--profile', 'ci']))\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", script, str(books), str(outputs)],
        cwd=PROJECT_DIR,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=foreground_signals,
    )
    deadline = time.monotonic() + 120
    while not marker.exists() or not marker.read_text():
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err
    assert "Traceback" not in err and "ZMQ" not in err and err.count("error:") == 1, err
    assert err.rstrip().endswith("error: interrupted"), err
    assert not [
        p.name
        for p in (outputs / "ci" / "notebooks").iterdir()
        if p.suffix == ".ipynb" or "tmp" in p.name
    ]
    kernel_pid, deadline = int(marker.read_text()), time.monotonic() + 30
    while time.monotonic() < deadline:
        try:
            os.kill(kernel_pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.2)
    else:
        pytest.fail(f"kernel process {kernel_pid} still runs after the interrupt")


def test_every_command_help_has_a_description_and_an_example_within_80_columns(capsys):
    from lnss_lib.__main__ import COMMANDS

    for command in COMMANDS:
        assert main([command, "--help"]) == 0
        text = capsys.readouterr().out
        assert "example:" in text and f"python -m lnss_lib {command}" in text, command
        assert " ".join(COMMANDS[command][1].split()[:4]) in " ".join(text.split())
        body = text[text.index("\n\n") :]  # after the usage lines (argparse's own layout)
        assert max(map(len, body.splitlines())) <= 80, command


def test_evaluate_prints_labels_with_units_and_the_profile(capsys):
    assert main(["evaluate", "--constellation", "bhamidipati2023_case_c", "--profile", "ci"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "profile ci, constellation bhamidipati2023_case_c"
    assert (
        "PDOP (3-sigma mean)" in out
        and "Delta-V total (km/s/yr)" in out
        and "dv_total_kms_per_year" not in out
    )
    pdop = next(
        line for line in out.splitlines() if line.startswith("PDOP (3-sigma mean)")
    ).split()[-1]
    assert len(pdop.split(".")[1]) == 2  # DOP to 2 decimals, not 6 significant digits


def test_an_interrupt_leaves_no_traceback_of_abandoned_tasks():
    """Ctrl-C while an asyncio task has failed unseen (a notebook kernel that died with the interrupt): one line and
    exit 130, not asyncio's 'Task exception was never retrieved' traceback when the task is collected at exit."""
    script = (
        "import asyncio, sys\nimport lnss_lib.__main__ as m\nfrom lnss_lib.cli import reproduce\n"
        "async def died():\n    raise RuntimeError('Kernel died')\n"
        "def command(args):\n    loop = asyncio.new_event_loop()\n    m.abandoned = loop.create_task(died())\n"
        "    loop.run_until_complete(asyncio.sleep(0.01))\n    raise KeyboardInterrupt\n"
        "reproduce.run = command\ncode = m.main(['reproduce'])\n"
        "del m.abandoned\nimport gc\ngc.collect()\nsys.exit(code)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=PROJECT_DIR, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "error: interrupted", done.stderr


def test_sigterm_on_a_campaign_is_one_line_exit_143_and_resumes(tmp_path):
    """SIGTERM during a campaign ended with exit 143 and no line: now one line, the run resumable to its end."""
    import signal
    import time

    run_dir = tmp_path / "run"
    args = [
        sys.executable,
        "-m",
        "lnss_lib",
        "campaign",
        "--profile",
        "ci",
        "--evaluator",
        "synthetic",
        "--workers",
        "0",
        "--no-progress",
        "--set",
        "campaign.synthetic_delay_s=0.05",
        "--set",
        "campaign.generations=4",
    ]
    process = subprocess.Popen(
        args + ["--run-dir", str(run_dir)],
        cwd=PROJECT_DIR,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    journal = run_dir / "evaluations.jsonl"
    deadline = time.monotonic() + 120
    while not (journal.is_file() and journal.read_bytes().count(b"\n") > 3):
        assert process.poll() is None and time.monotonic() < deadline, (
            process.stderr.read() if process.poll() else ""
        )
        time.sleep(0.05)
    os.kill(process.pid, signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143 and err.strip() == "error: terminated (SIGTERM)", err
    assert main(["campaign", "--resume", str(run_dir), "--workers", "0", "--no-progress"]) == 0


def test_a_closed_standard_output_is_a_failure_not_a_lost_result():
    """evaluate with standard output closed printed nothing and exited 0: now exit 1 and a line saying why."""
    done = subprocess.run(
        f"{sys.executable} -m lnss_lib evaluate --profile ci --sma-km 6143 --ecc 0.6 --aop-deg 90 "
        f"--inc-deg 51.7 --planes 2 --sats-per-plane 2 --json >&-",
        shell=True,
        cwd=PROJECT_DIR,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 1 and "standard output is closed" in done.stderr, done.stderr


def test_git_is_never_taken_from_path(tmp_path, monkeypatch):
    """The commit recorded in every manifest and run folder comes from the system's git, not a `git` first on PATH."""
    from lnss_lib.provenance import git_revision

    fake = tmp_path / "git"
    fake.write_text(f"#!/bin/sh\ntouch {tmp_path / 'ran'}\necho forged\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{tmp_path}:{os.environ['PATH']}")
    assert "forged" not in git_revision() and not (tmp_path / "ran").exists()


def test_evaluate_for_people_repeats_the_design_and_leaves_out_empty_rows():
    from lnss_lib.cli.evaluate import human_lines

    evaluated = {
        "n_sat": 6,
        "pdop_mean_3sigma": 2.345678,
        "deltav_model": "lsq",
        "evaluated": True,
        "reason": None,
        "wall_s": 0.2599,
        "meets_bounds": False,
        "violated_bounds": ["Delta-V total 2.290 km/s/yr"],
    }
    lines = human_lines("ci", "a 6143 km, e 0.6, AOP 90 deg, i 51.7 deg, 2 planes x 3", evaluated)
    assert lines[0] == "profile ci, a 6143 km, e 0.6, AOP 90 deg, i 51.7 deg, 2 planes x 3"
    rows = {
        line[: line.rindex("  ")].strip(): line[line.rindex("  ") :].strip() for line in lines[1:]
    }
    assert (
        rows["PDOP (3-sigma mean)"] == "2.35"
        and rows["wall time (s)"] == "0.3"
        and rows["satellites"] == "6"
    )
    assert "reason not evaluated" not in rows and not any("None" in line for line in lines)
    impact = dict.fromkeys(evaluated, None) | {
        "evaluated": False,
        "reason": "satellite 2 hits the Moon on day 3.1",
    }
    assert human_lines("ci", "constellation x", impact) == [
        "profile ci, constellation x",
        "not evaluated: satellite 2 hits the Moon on day 3.1",
    ]
