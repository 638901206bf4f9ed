"""``python -m lnss_lib study``: many campaigns side by side on one Dask cluster, the export of a finished study
as its shipped results, or the replay of recorded campaigns' costs on local thread workers."""

from __future__ import annotations

import argparse

from ..errors import ConfigError
from .arguments import integer, refuse_flags, require

RUN_FLAGS = (
    "FILE",
    "--run-dir",
    "--resume",
    "--workers",
    "--scheduler-address",
    "--max-generations",
)  # what running a study is given


def run(args: argparse.Namespace) -> int:
    from ..campaign.study import run_study

    if args.replay:
        return _replay(args)
    if args.export_reference is not None:
        return _export_reference(args)
    require("--workers", args.workers, (0, None, False, False), integer=True)
    require("--max-generations", args.max_generations, (1, None, False, False), integer=True)
    if (args.file is None) == (args.resume is None):
        raise ConfigError(
            "study needs a study FILE (with --run-dir) or --resume RUN_DIR, not both", key="FILE"
        )
    if args.resume is not None and args.run_dir is not None:
        raise ConfigError(
            "--resume continues the study in its folder: drop --run-dir", key="--run-dir"
        )
    result = run_study(
        args.file,
        run_dir=args.run_dir if args.resume is None else args.resume,
        resume=args.resume is not None,
        workers=args.workers,
        scheduler_address=args.scheduler_address,
        progress=not args.no_progress,
        max_generations=args.max_generations,
    )
    for name, run in result.campaigns.items():
        print(
            f"campaign {name}: {run.run_dir}: {run.generations} generation(s), {run.n_evaluations} unique designs "
            f"({run.n_feasible} feasible, {run.n_errors} evaluation errors); this session "
            f"{run.session_evaluations} evaluations"
            + (
                f", {run.resubmitted} design(s) resubmitted after lost workers"
                if run.resubmitted
                else ""
            )
        )
    print(
        f"study {result.run_dir}: {len(result.campaigns)} campaign(s) in {result.wall_s:.1f} s "
        f"({result.designs_per_s:.2f} designs/s)"
    )
    return 0


def _export_reference(args: argparse.Namespace) -> int:
    from ..campaign.study_reference import export_study_reference
    from ..outputs import display_path
    from ..provenance import git_revision

    refuse_flags(
        args,
        RUN_FLAGS,
        "--export-reference exports a finished study folder and runs nothing",
        key="--export-reference",
    )
    folder = export_study_reference(args.export_reference, export_commit=git_revision())
    print(
        f"exported {args.export_reference} as the reference results of study {folder.name!r}: "
        f"{display_path(folder)}"
    )
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            print(f"wrote {path.relative_to(folder)} ({path.stat().st_size} bytes)")
    return 0


def _replay(args: argparse.Namespace) -> int:
    from ..campaign.replay import recorded_costs, replay

    refuse_flags(
        args,
        (*RUN_FLAGS, "--export-reference"),
        "--replay measures recorded runs on local thread workers and runs no campaign",
        key="--replay",
    )
    for n in args.replay_workers:
        require("--replay-workers", n, (1, None, False, False), integer=True)
    require("--copies", args.copies, (1, None, False, False), integer=True)
    require("--time-scale", args.time_scale, (0.0, 1.0, True, False))
    campaigns = [
        costs for folder in args.replay for costs in recorded_costs(folder).values()
    ] * args.copies
    print(
        f"replay of {len(campaigns)} campaign(s), each design sleeping its recorded cost x {args.time_scale:g}:"
    )
    print("workers  projected wall (s)  busy  perfect scaling (s)")
    for n in args.replay_workers:
        result = replay(campaigns, n, time_scale=args.time_scale)
        print(
            f"{n:7d}  {result.wall_s:18.1f}  {result.busy_fraction:4.2f}  {result.cost_s / n:19.1f}"
        )
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help="study file (TOML, e.g. params/studies/ci_pair.toml)",
    )
    parser.add_argument(
        "--run-dir",
        help="new folder of the study (missing or empty); campaign NAME runs in RUN_DIR/NAME",
    )
    parser.add_argument(
        "--resume",
        metavar="RUN_DIR",
        help="continue the study in RUN_DIR (every campaign from its last checkpoint)",
    )
    parser.add_argument(
        "--workers",
        type=integer,
        help="Dask worker processes on this machine (default: one per core; "
        "0 or 1: the campaigns one after the other in this process)",
    )
    parser.add_argument(
        "--scheduler-address", help="use an existing Dask cluster, e.g. tcp://HOST:8786"
    )
    parser.add_argument(
        "--max-generations",
        type=integer,
        help="stop each campaign's session after N generations (resumable)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress line")
    parser.add_argument(
        "--export-reference",
        metavar="RUN_DIR",
        help="export the finished study folder RUN_DIR as the "
        "study's shipped results, outputs/reference/<study>/ (each campaign's history and front), and run nothing",
    )
    parser.add_argument(
        "--replay",
        nargs="+",
        metavar="RUN_DIR",
        help="instead of running: replay the recorded "
        "per-design costs of these campaign or study folders (or shipped costs.nc files) as sleeping tasks on "
        "local thread workers and print the projected wall time and busy fraction",
    )
    parser.add_argument(
        "--replay-workers",
        nargs="+",
        type=integer,
        default=[2, 8, 32, 128],
        metavar="N",
        help="replay: the worker counts (default 2 8 32 128)",
    )
    parser.add_argument(
        "--copies",
        type=integer,
        default=1,
        help="replay: the recorded campaigns N times side by side "
        "(a study of N seeds projected from one)",
    )
    parser.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="replay: each design sleeps its cost times this, "
        "in (0, 1] (smaller: faster, the dispatch weighs more)",
    )
