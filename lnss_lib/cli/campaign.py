"""``python -m lnss_lib campaign``: the NSGA-II design search, and its two other uses: export a run as
a profile's shipped results, or fly a finished run's front over the design life."""

from __future__ import annotations

import argparse

from ..errors import ConfigError
from .arguments import add_profile, add_set, integer, profile_overrides, refuse_flags, require

NEW_RUN_FLAGS = (
    "--profile",
    "--set",
    "--resume",
    "--run-dir",
    "--evaluator",
)  # what a new run is given


def run(args: argparse.Namespace) -> int:
    from ..campaign import run_campaign

    if args.validate is not None:
        return _validate(args)
    if args.export_reference is not None:
        return _export_reference(args)
    overrides = profile_overrides(args)
    require("--workers", args.workers, (0, None, False, False), integer=True)
    require("--max-generations", args.max_generations, (1, None, False, False), integer=True)
    if args.evaluator:
        overrides = {
            **(overrides or {}),
            "campaign": {**(overrides or {}).get("campaign", {}), "evaluator": args.evaluator},
        }
    if args.resume and (args.profile or overrides or args.run_dir):
        raise ConfigError(
            "--resume continues a run with its stored parameters: "
            "drop --profile or --profile-file, --set, --evaluator and --run-dir"
        )
    result = run_campaign(
        args.profile or "quick",
        overrides=overrides,
        workers=args.workers,
        scheduler_address=args.scheduler_address,
        run_dir=args.run_dir,
        resume=args.resume,
        progress=not args.no_progress,
        max_generations=args.max_generations,
    )
    rate = result.session_evaluations / result.session_wall_s if result.session_wall_s > 0 else 0.0
    print(
        f"run {result.run_dir}: {result.generations} generation(s), {result.n_evaluations} unique designs "
        f"evaluated ({result.n_feasible} feasible, {result.n_errors} evaluation errors); this session {result.session_evaluations} evaluations in "
        f"{result.session_wall_s:.1f} s ({rate:.2f} designs/s)"
        + (
            f"; {result.resubmitted} design(s) resubmitted after lost workers"
            if result.resubmitted
            else ""
        )
    )
    for path in result.files:
        print(f"wrote {path}")
    if result.publication:
        print(result.publication)
    return 0


def _export_reference(args: argparse.Namespace) -> int:
    from ..campaign.reference import export_reference, load_reference
    from ..outputs import display_path
    from ..provenance import git_revision

    refuse_flags(
        args,
        (*NEW_RUN_FLAGS, "--workers", "--scheduler-address", "--max-generations", "--validate"),
        "--export-reference exports a run folder with its stored settings and runs nothing",
        key="--export-reference",
    )
    folder = export_reference(args.export_reference, export_commit=git_revision())
    reference = load_reference(folder.name, folder.parent)
    attrs = reference.history.attrs
    state = (
        "complete"
        if reference.finished
        else f"PARTIAL ({attrs['generations_done']} generations, not finished)"
    )
    print(
        f"exported {args.export_reference} as the reference results of profile {folder.name!r} ({state}): "
        f"{display_path(folder)}"
    )
    for path in sorted(folder.iterdir()):
        print(f"wrote {display_path(path)} ({path.stat().st_size} bytes)")
    return 0


def _validate(args: argparse.Namespace) -> int:
    from ..campaign.runner import validate_run

    refuse_flags(
        args,
        (*NEW_RUN_FLAGS, "--max-generations", "--export-reference"),
        "--validate flies a finished run's front with its stored settings",
        key="--validate",
    )
    require("--workers", args.workers, (0, None, False, False), integer=True)
    result, note = validate_run(
        args.validate,
        workers=args.workers,
        scheduler_address=args.scheduler_address,
        progress=not args.no_progress,
    )
    counts = {
        status: int((result.dataset["status"].values == status).sum())
        for status in ("kept", "failed", "error")
    }
    print(
        f"validated {result.n_journaled} of {result.n_selected} selected designs of {args.validate} "
        f"({result.n_flown} flown now in {result.wall_s:.1f} s; kept {counts['kept']}, failed {counts['failed']}, "
        f"error {counts['error']}): wrote {result.path}"
    )
    if note:
        print(note)
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_profile(parser, None)
    parser.add_argument(
        "--workers",
        type=integer,
        help="Dask worker processes on this machine (default: one per core; "
        "0 or 1: evaluate in this process)",
    )
    parser.add_argument(
        "--scheduler-address", help="use an existing Dask cluster, e.g. tcp://HOST:8786"
    )
    parser.add_argument(
        "--resume", metavar="RUN_DIR", help="continue the run in RUN_DIR from its last checkpoint"
    )
    parser.add_argument(
        "--run-dir", help="new run directory (default outputs/<profile>/campaign/run_<time>)"
    )
    parser.add_argument(
        "--evaluator",
        choices=("walker", "synthetic"),
        help="walker (default): the design evaluator; synthetic: closed-form stand-in for tests",
    )
    add_set(parser)
    parser.add_argument(
        "--max-generations", type=integer, help="stop this session after N generations (resumable)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument(
        "--export-reference",
        metavar="RUN_DIR",
        help="export the run folder RUN_DIR (finished or not) "
        "as its profile's shipped results, outputs/reference/<profile>/, and run nothing",
    )
    parser.add_argument(
        "--validate",
        metavar="RUN_DIR",
        help="fly the front of the finished run RUN_DIR in closed "
        "loop over the design life ([front_validation]; continues a validation), write validated.nc",
    )
