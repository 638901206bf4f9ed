"""Command line: ``python -m lnss_lib {reproduce, propagate, evaluate, campaign, study, bench} ...`` (``--help`` on each)."""

from __future__ import annotations

import argparse
import contextlib
import errno
import logging
import math
import os
import signal
import sys
import threading
import traceback
from pathlib import Path

import numpy as np

from .config import PACKAGE_DIR, available_profiles, parse_sets, use_profile_file
from .constants import DAYS_PER_JULIAN_YEAR, INTEGER_SETTING_MAX, SECONDS_PER_DAY
from .errors import ConfigError, EphemerisRangeError, InvalidOrbitError, SpiceError, Terminated
from .sections import CR_AREA_MASS, CR_AREA_MASS_WHY, allowed_range_text, in_range
from .settings import load_settings

BENCHMARKS = (
    "propagator",
    "dop",
    "evaluate",
    "estimate",
    "navigation",
    "campaign",
    "integrator",
    "design-life",
    "stability",
    "gnss",
)


def _require(flag: str, value, spec: tuple, integer: bool = False, why: str = ""):
    """``value`` if finite (an integer with ``integer``) and inside ``spec`` (a range of lnss_lib.sections), else ConfigError
    (with the reason ``why``)."""
    if value is None:
        return None
    if not math.isfinite(value) or (integer and value != int(value)) or not in_range(value, spec):
        kind = "an integer" if integer else "a finite number"
        raise ConfigError(
            f"{flag} {value!r} is not allowed; allowed: {kind} in {allowed_range_text(spec)}"
            + (f" ({why})" if why else ""),
            key=flag,
        )
    return value


def integer(text: str) -> int:
    """An integer flag's value: an integer that outputs can store (magnitude at most 2**63 - 1), for argparse."""
    value = int(
        text
    )  # ValueError (also for more than 4300 digits): argparse says "invalid integer value"
    if abs(value) > INTEGER_SETTING_MAX:
        raise argparse.ArgumentTypeError(
            f"an integer of about {len(text.strip().lstrip('+-'))} digits is too large; "
            f"allowed: at most 2**63 - 1 in magnitude"
        )
    return value


def _overrides(args: argparse.Namespace) -> dict | None:
    """``--set SECTION.KEY=VALUE`` items as a nested overrides dict (checked by load_settings), or None."""
    return parse_sets(getattr(args, "set", None)) or None


def _check_output(path: str | None) -> Path | None:
    """The ``--out`` path, checked before any work: a .csv or .nc file in an existing, writable folder."""
    if path is None:
        return None
    out = Path(path)
    if out.suffix not in (".csv", ".nc") or out.is_dir():
        raise ConfigError(f"--out {path}: need a file name ending in .csv or .nc", key="--out")
    if not out.parent.is_dir():
        raise ConfigError(f"--out {path}: folder {out.parent} does not exist", key="--out")
    if not os.access(out.parent, os.W_OK):
        raise PermissionError(errno.EACCES, "folder is not writable", str(out.parent))
    return out


def _say_which_campaign(profile_name: str, overrides: dict | None, numbers: set[str]) -> None:
    """Print (stderr) where notebooks 06-07 take their campaigns from under a profile that loads them: a local
    run or the shipped reference results (the notebooks print the same)."""
    from .studies.campaign import campaign_source
    from .studies.pareto import physical_bound_campaign

    if not numbers & {"06", "07"}:
        return
    source = campaign_source(profile_name, overrides)
    if source:
        print(f"campaign of {profile_name}: {source}", file=sys.stderr)
    if "07" in numbers:
        with contextlib.suppress(FileNotFoundError):
            physical = physical_bound_campaign(profile_name)
            if physical is not None:
                print(f"notebook 07's figures: {physical.note}", file=sys.stderr)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .pipeline import notebook_paths, reproduce

    overrides = _overrides(args)
    _say_which_campaign(
        args.profile, overrides, {book.stem[:2] for book in notebook_paths(args.only)}
    )
    return reproduce(args.profile, only=args.only, overrides=overrides)


def _cmd_propagate(args: argparse.Namespace) -> int:
    import io

    from .atomicio import write_netcdf_atomic, write_text_atomic
    from .elements import check_states_km
    from .ephemeris import check_span, ensure_kernels, tdb_seconds
    from .propagator import check_elements_deg, elements_deg_to_states, propagate_states

    _require("--days", args.days, (0.0, None, True, False))
    _require("--step-s", args.step_s, (0.0, None, True, False))
    _require("--degree", args.degree, (0, 100, False, False), integer=True)
    _require("--srp-cr-area-mass", args.srp_cr_area_mass, CR_AREA_MASS, why=CR_AREA_MASS_WHY)
    if args.elements is not None:
        check_elements_deg([args.elements])
    elif not all(math.isfinite(v) for v in args.state_km):
        raise ConfigError(
            f"--state-km {' '.join(map(str, args.state_km))}: every component must be finite",
            key="--state-km",
        )
    out = _check_output(args.out)
    overrides = _overrides(args) or {}
    if args.degree is not None:
        overrides = {
            **overrides,
            "gravity": {**overrides.get("gravity", {}), "degree": args.degree},
        }
    profile = load_settings(args.profile, overrides=overrides or None)
    ensure_kernels(profile.ephemeris)
    t0 = tdb_seconds(args.epoch_tdb, "TDB")
    check_span(t0, t0 + args.days * SECONDS_PER_DAY)
    if args.elements is not None:
        state = elements_deg_to_states(profile.dynamics, [args.elements], t0)
    else:
        try:
            state = check_states_km(
                [args.state_km], profile.dynamics.gravity.gm_km3_s2, profile.dynamics.r_impact_km
            )
        except ConfigError as error:
            raise ConfigError(
                f"--state-km {' '.join(map(str, args.state_km))}: {str(error).removeprefix('state 0: ')}",
                key="--state-km",
            ) from None
    ds = propagate_states(
        profile.dynamics,
        state,
        t0,
        args.days * SECONDS_PER_DAY,
        args.step_s,
        setting=args.setting,
        srp_cr_area_mass_m2_kg=args.srp_cr_area_mass,
    )
    if out is not None and out.suffix == ".nc":
        write_netcdf_atomic(ds, out)
    else:
        table = np.column_stack([ds.time.values, ds.r_mci_km.values[0], ds.v_mci_kms.values[0]])
        header = (
            "t_tdb_s,x,y,z,vx,vy,vz  # Moon-centred J2000, km and km/s, TDB seconds past J2000; "
            f"{ds.attrs['force_model']}; {ds.attrs['integrator']} rtol={ds.attrs['rtol']} atol={ds.attrs['atol']}"
        )
        buffer = io.StringIO()
        np.savetxt(buffer, table, delimiter=",", header=header, comments="", fmt="%.9f")
        if out is not None:
            write_text_atomic(out, buffer.getvalue())
        else:
            sys.stdout.write(buffer.getvalue())
    if out is not None:
        print(f"wrote {out} ({ds.sizes['time']} samples)", file=sys.stderr)
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    import json

    life = args.design_life_days
    if life is not None and not (np.isfinite(life) and life > 0):
        raise ValueError(f"--design-life-days must be a positive number of days; got {life!r}")
    if (
        life is not None
    ):  # a life past the kernels' span is refused before the 10-day evaluation runs
        from .ephemeris import check_span, ensure_kernels, tdb_seconds

        profile = load_settings(args.profile, overrides=_overrides(args))
        ensure_kernels(profile.ephemeris)
        t0 = tdb_seconds(profile.epoch.start_tdb, "TDB")
        try:
            check_span(t0, t0 + life * SECONDS_PER_DAY)
        except EphemerisRangeError as error:
            allowed_days = (error.end_tdb_s - t0) / SECONDS_PER_DAY
            raise ConfigError(
                f"--design-life-days {life!r} ({life / DAYS_PER_JULIAN_YEAR:,.1f} years from "
                f"{profile.epoch.start_tdb}): {error}; allowed: 0 < days <= {math.floor(allowed_days):,} from "
                f"{profile.epoch.start_tdb}",
                key="--design-life-days",
            ) from None
    walker = {
        "--sma-km": args.sma_km,
        "--ecc": args.ecc,
        "--aop-deg": args.aop_deg,
        "--inc-deg": args.inc_deg,
        "--planes": args.planes,
        "--sats-per-plane": args.sats_per_plane,
    }
    if args.constellation is not None:
        given = [flag for flag, value in walker.items() if value is not None]
        if given:
            raise ConfigError(
                f"--constellation replaces the Walker arguments; drop {', '.join(given)}"
            )
        from .cli import evaluate_catalogue_cli

        result = evaluate_catalogue_cli(
            args.profile,
            args.constellation,
            epoch=args.constellation_epoch,
            overrides=_overrides(args),
        )
    else:
        missing = [flag for flag, value in walker.items() if value is None]
        if missing:
            raise ConfigError(
                f"evaluate needs --constellation NAME_OR_PATH or all Walker arguments; "
                f"missing {', '.join(missing)}"
            )
        from .cli import evaluate_cli

        _check_walker(args)
        result = evaluate_cli(
            args.profile,
            args.sma_km,
            args.ecc,
            args.aop_deg,
            args.inc_deg,
            args.planes,
            args.sats_per_plane,
            overrides=_overrides(args),
        )
    from .campaign.settings import bounds_verdict

    profile = load_settings(args.profile, overrides=_overrides(args))
    result.update(bounds_verdict(profile.campaign, result))
    if args.design_life_days is not None:
        from .cli import design_life_cli

        result.update(
            design_life_cli(
                args.profile,
                args.design_life_days,
                constellation=args.constellation,
                constellation_epoch=args.constellation_epoch,
                walker=(
                    args.sma_km,
                    args.ecc,
                    args.aop_deg,
                    args.inc_deg,
                    args.planes,
                    args.sats_per_plane,
                ),
                overrides=_overrides(args),
            )
        )
    if args.json:
        print(json.dumps(result))
    else:
        from .cli import human_lines

        result["violated_bounds"] = bounds_verdict(profile.campaign, result, labelled=True)[
            "violated_bounds"
        ]
        what = (
            f"constellation {args.constellation}"
            if args.constellation
            else f"a {args.sma_km:g} km, e {args.ecc:g}, AOP {args.aop_deg:g} deg, i {args.inc_deg:g} deg, "
            f"{args.planes} planes x {args.sats_per_plane}"
        )
        print("\n".join(human_lines(args.profile, what, result)))
    return 0


def _check_walker(args: argparse.Namespace) -> None:
    """The Walker arguments checked (evaluator.check_design) with the message naming the flag."""
    from .evaluator import check_design

    flags = {
        "sma_km": "--sma-km",
        "e": "--ecc",
        "inc_deg": "--inc-deg",
        "aop_deg": "--aop-deg",
        "n_planes": "--planes",
        "sats_per_plane": "--sats-per-plane",
    }
    try:
        check_design(
            args.sma_km, args.ecc, args.aop_deg, args.inc_deg, args.planes, args.sats_per_plane
        )
    except ConfigError as error:
        flag = flags.get(error.key, error.key)
        raise ConfigError(f"{flag}: {error}", key=flag) from None


def _export_reference(args: argparse.Namespace) -> int:
    from .campaign.reference import export_reference, load_reference
    from .outputs import display_path
    from .provenance import git_revision

    given = [
        flag
        for flag, value in (
            ("--profile", args.profile),
            ("--set", args.set),
            ("--resume", args.resume),
            ("--run-dir", args.run_dir),
            ("--evaluator", args.evaluator),
            ("--workers", args.workers),
            ("--scheduler-address", args.scheduler_address),
            ("--max-generations", args.max_generations),
            ("--validate", args.validate),
        )
        if value is not None
    ]
    if given:
        raise ConfigError(
            f"--export-reference exports a run folder with its stored settings and runs nothing: drop "
            f"{', '.join(given)}",
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
    from .campaign.runner import validate_run

    given = [
        flag
        for flag, value in (
            ("--profile", args.profile),
            ("--set", args.set),
            ("--resume", args.resume),
            ("--run-dir", args.run_dir),
            ("--evaluator", args.evaluator),
            ("--max-generations", args.max_generations),
            ("--export-reference", args.export_reference),
        )
        if value is not None
    ]
    if given:
        raise ConfigError(
            f"--validate flies a finished run's front with its stored settings: drop {', '.join(given)}",
            key="--validate",
        )
    _require("--workers", args.workers, (0, None, False, False), integer=True)
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


def _cmd_campaign(args: argparse.Namespace) -> int:
    from .campaign import run_campaign

    if args.validate is not None:
        return _validate(args)
    if args.export_reference is not None:
        return _export_reference(args)
    overrides = _overrides(args)
    _require("--workers", args.workers, (0, None, False, False), integer=True)
    _require("--max-generations", args.max_generations, (1, None, False, False), integer=True)
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


def _replay(args: argparse.Namespace) -> int:
    from .campaign.replay import recorded_costs, replay

    given = [
        flag
        for flag, value in (
            ("FILE", args.file),
            ("--run-dir", args.run_dir),
            ("--resume", args.resume),
            ("--workers", args.workers),
            ("--scheduler-address", args.scheduler_address),
            ("--max-generations", args.max_generations),
        )
        if value is not None
    ]
    if given:
        raise ConfigError(
            f"--replay measures recorded runs on local thread workers and runs no campaign: drop "
            f"{', '.join(given)}",
            key="--replay",
        )
    for n in args.replay_workers:
        _require("--replay-workers", n, (1, None, False, False), integer=True)
    _require("--copies", args.copies, (1, None, False, False), integer=True)
    _require("--time-scale", args.time_scale, (0.0, 1.0, True, False))
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


def _cmd_study(args: argparse.Namespace) -> int:
    from .campaign.study import run_study

    if args.replay:
        return _replay(args)
    _require("--workers", args.workers, (0, None, False, False), integer=True)
    _require("--max-generations", args.max_generations, (1, None, False, False), integer=True)
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


def _cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    module = importlib.import_module(f"lnss_lib.bench.{args.name.replace('-', '_')}")
    for flag, given in (("--scaling", args.scaling), ("--history", args.history is not None)):
        if given and args.name != "campaign":
            raise ConfigError(
                f"{flag} applies to 'bench campaign' only; got bench {args.name}", key=flag
            )
    overrides = _overrides(args)
    load_settings(
        args.profile, overrides=overrides
    )  # every setting checked before the benchmark starts
    extra = {"scaling_run": True} if args.scaling else {}
    if args.history is not None:
        extra["history"] = args.history
    module.run(profile_name=args.profile, overrides=overrides, **extra)
    return 0


COMMANDS = {  # name -> (one-line help, description, example) for ``--help``
    "reproduce": (
        "execute the notebooks headless into outputs/<profile>/",
        "Run the workbook's notebooks with papermill under a profile, write the executed notebooks, "
        "figures, tables and manifest under outputs/<profile>/, and the index.html and FINDINGS.md that "
        "open on the run's findings beside the paper's.",
        "python -m lnss_lib reproduce --profile ci --only 05 07",
    ),
    "propagate": (
        "propagate one orbit with the high-fidelity model; CSV or NetCDF out",
        "Propagate one Moon-centred state or element set with the profile's force model (lunar gravity "
        "field, third bodies, solar pressure, relativity) and write the states.",
        "python -m lnss_lib propagate --epoch-tdb 2025-05-01T00:00:00 --elements 6143 0.6 51.7 0 90 0 "
        "--days 1 --out elfo.csv",
    ),
    "evaluate": (
        "every objective of eq. 45 for one Walker design or one catalogue constellation",
        "Evaluate one design as the campaign does (propagation, south-pole DOP grid, station-keeping "
        "Delta-V, GPS link) and print every metric with its unit, or one JSON object.",
        "python -m lnss_lib evaluate --sma-km 6143 --ecc 0.6 --aop-deg 90 --inc-deg 51.7 --planes 2 "
        "--sats-per-plane 8",
    ),
    "campaign": (
        "NSGA-II design search (Section 5, Table 5), checkpointed every generation",
        "Search the eq. 43-44 design grid with NSGA-II under Table 3's bounds; every generation is "
        "checkpointed, so --resume continues an interrupted run.",
        "python -m lnss_lib campaign --profile ci --workers 2; "
        "python -m lnss_lib campaign --export-reference RUN_DIR (ship a run's results)",
    ),
    "study": (
        "many campaigns (seeds, sizes, profiles) side by side on one Dask cluster",
        "Run the campaigns a study file lists, all at once on one Dask cluster, each in its own run folder "
        "under --run-dir with its journal and checkpoint; --resume continues the whole study.",
        "python -m lnss_lib study params/studies/ci_pair.toml --run-dir runs/pair --workers 2",
    ),
    "bench": (
        "benchmarks that print numbers",
        "Time a part of the workbook and print the new path beside the one it replaces.",
        "python -m lnss_lib bench dop",
    ),
}


def _command(sub, name: str) -> argparse.ArgumentParser:
    """A subcommand with its help line, description and example (:data:`COMMANDS`)."""
    import textwrap

    brief, description, example = COMMANDS[name]
    example = " \\\n      ".join(
        textwrap.wrap(example, 72, break_on_hyphens=False, break_long_words=False)
    )
    return sub.add_parser(
        name,
        help=brief,
        description=textwrap.fill(description, 78),
        epilog=f"example:\n  {example}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="python -m lnss_lib",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="LNSS design workbook: lunar navigation constellations after Malik & Yang.",
        epilog="example:\n  python -m lnss_lib evaluate --constellation bhamidipati2023_case_c\n"
        "run 'python -m lnss_lib COMMAND --help' for a command's options and example",
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="show the traceback of an error (also accepted after the command)",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    set_help = (
        "override a profile value (TOML literal: true/false, numbers, quoted strings and dates), e.g. "
        "gravity.degree=8; repeatable; checked like the profile"
    )

    rep = _command(sub, "reproduce")
    _add_profile(rep, "quick")
    rep.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="notebook names or number prefixes (e.g. 01 02_dop_grid)",
    )
    rep.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=set_help)
    rep.set_defaults(func=_cmd_reproduce)

    prop = _command(sub, "propagate")
    prop.add_argument(
        "--epoch-tdb",
        required=True,
        help="start epoch in TDB, ISO 8601 YYYY-MM-DDTHH:MM:SS without zone "
        "(e.g. 2022-11-25T00:00:00)",
    )
    group = prop.add_mutually_exclusive_group(required=True)
    group.add_argument(
        "--state-km",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "VX", "VY", "VZ"),
        help="Moon-centred J2000 state, km and km/s",
    )
    group.add_argument(
        "--elements",
        nargs=6,
        type=float,
        metavar=("A_KM", "E", "I", "RAAN", "AOP", "M"),
        help="Keplerian elements (km, deg) in the profile's element frame",
    )
    prop.add_argument("--days", type=float, required=True, help="duration in days")
    prop.add_argument("--step-s", type=float, default=900.0, help="output sampling step in seconds")
    prop.add_argument(
        "--degree", type=integer, help="gravity degree and order (0-100; 0 = point mass)"
    )
    prop.add_argument(
        "--srp-cr-area-mass",
        type=float,
        help="Cr*A/m in m^2/kg (default: the profile's spacecraft)",
    )
    prop.add_argument(
        "--setting", help="integrator setting: paper or converged (default: the profile's)"
    )
    _add_profile(prop, "paper")
    prop.add_argument("--out", help="output path, .csv or .nc (default: CSV to stdout)")
    prop.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=set_help)
    prop.set_defaults(func=_cmd_propagate)

    ev = _command(sub, "evaluate")
    ev.add_argument(
        "--constellation",
        metavar="NAME_OR_PATH",
        help="catalogue name (params/constellations/NAME.toml) or a TOML file in that format, "
        "instead of the Walker arguments",
    )
    ev.add_argument(
        "--constellation-epoch",
        choices=("study", "file"),
        default="study",
        help="read the constellation's elements at the study epoch (default) or at its file's epoch",
    )
    ev.add_argument("--sma-km", type=float, help="semi-major axis (km)")
    ev.add_argument("--ecc", type=float, help="eccentricity, [0, 1)")
    ev.add_argument("--aop-deg", type=float, help="argument of perilune (deg)")
    ev.add_argument(
        "--inc-deg", type=float, help="inclination to the element frame's equator (deg)"
    )
    ev.add_argument("--planes", type=integer, help="number of planes Np (RAAN by eq. 42)")
    ev.add_argument("--sats-per-plane", type=integer, help="satellites per plane Ns")
    _add_profile(ev, "quick")
    ev.add_argument(
        "--design-life-days",
        type=float,
        metavar="D",
        help="also fly the design life of D days: closed-loop station keeping, natural drift, DOP "
        "over the life, the campaign-grade Delta-V estimate and the stability screen",
    )
    ev.add_argument("--json", action="store_true", help="print one JSON object")
    ev.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=set_help)
    ev.set_defaults(func=_cmd_evaluate)

    camp = _command(sub, "campaign")
    _add_profile(camp, None)
    camp.add_argument(
        "--workers",
        type=integer,
        help="Dask worker processes on this machine (default: one per core; "
        "0 or 1: evaluate in this process)",
    )
    camp.add_argument(
        "--scheduler-address", help="use an existing Dask cluster, e.g. tcp://HOST:8786"
    )
    camp.add_argument(
        "--resume", metavar="RUN_DIR", help="continue the run in RUN_DIR from its last checkpoint"
    )
    camp.add_argument(
        "--run-dir", help="new run directory (default outputs/<profile>/campaign/run_<time>)"
    )
    camp.add_argument(
        "--evaluator",
        choices=("walker", "synthetic"),
        help="walker (default): the design evaluator; synthetic: closed-form stand-in for tests",
    )
    camp.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=set_help)
    camp.add_argument(
        "--max-generations", type=integer, help="stop this session after N generations (resumable)"
    )
    camp.add_argument("--no-progress", action="store_true", help="no progress bars")
    camp.add_argument(
        "--export-reference",
        metavar="RUN_DIR",
        help="export the run folder RUN_DIR (finished or not) "
        "as its profile's shipped results, outputs/reference/<profile>/, and run nothing",
    )
    camp.add_argument(
        "--validate",
        metavar="RUN_DIR",
        help="fly the front of the finished run RUN_DIR in closed "
        "loop over the design life ([front_validation]; continues a validation), write validated.nc",
    )
    camp.set_defaults(func=_cmd_campaign)

    study = _command(sub, "study")
    study.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help="study file (TOML, e.g. params/studies/ci_pair.toml)",
    )
    study.add_argument(
        "--run-dir",
        help="new folder of the study (missing or empty); campaign NAME runs in RUN_DIR/NAME",
    )
    study.add_argument(
        "--resume",
        metavar="RUN_DIR",
        help="continue the study in RUN_DIR (every campaign from its last checkpoint)",
    )
    study.add_argument(
        "--workers",
        type=integer,
        help="Dask worker processes on this machine (default: one per core; "
        "0 or 1: the campaigns one after the other in this process)",
    )
    study.add_argument(
        "--scheduler-address", help="use an existing Dask cluster, e.g. tcp://HOST:8786"
    )
    study.add_argument(
        "--max-generations",
        type=integer,
        help="stop each campaign's session after N generations (resumable)",
    )
    study.add_argument("--no-progress", action="store_true", help="no progress line")
    study.add_argument(
        "--replay",
        nargs="+",
        metavar="RUN_DIR",
        help="instead of running: replay the recorded "
        "per-design costs of these campaign or study folders as sleeping tasks on local thread workers "
        "and print the projected wall time and busy fraction",
    )
    study.add_argument(
        "--replay-workers",
        nargs="+",
        type=integer,
        default=[2, 8, 32, 128],
        metavar="N",
        help="replay: the worker counts (default 2 8 32 128)",
    )
    study.add_argument(
        "--copies",
        type=integer,
        default=1,
        help="replay: the recorded campaigns N times side by side "
        "(a study of N seeds projected from one)",
    )
    study.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="replay: each design sleeps its cost times this, "
        "in (0, 1] (smaller: faster, the dispatch weighs more)",
    )
    study.set_defaults(func=_cmd_study)

    bench = _command(sub, "bench")
    bench.add_argument(
        "name", choices=BENCHMARKS, metavar="NAME", help=f"one of {', '.join(BENCHMARKS)}"
    )
    _add_profile(bench, "paper")
    bench.add_argument(
        "--scaling",
        action="store_true",
        help="campaign: local scaling and loopback-cluster overhead",
    )
    bench.add_argument(
        "--history",
        metavar="RUN_DIR",
        help="campaign: project 120 x 1000 with the designs this run "
        "folder evaluated per generation (its cache hits), printed as a range down from no hits",
    )
    bench.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE", help=set_help)
    bench.set_defaults(func=_cmd_bench)
    return parser


def _add_profile(command: argparse.ArgumentParser, default: str | None) -> None:
    """``--profile NAME`` (a file of params/) or ``--profile-file PATH`` (outputs in outputs/<stem>/)."""
    group = command.add_mutually_exclusive_group()
    group.add_argument(
        "--profile",
        default=default,
        help=f"profile name: {', '.join(available_profiles())} "
        f"(params/NAME.toml; default {default or 'quick'})",
    )
    group.add_argument(
        "--profile-file",
        metavar="PATH",
        help="a profile TOML file outside params/ (it may inherit "
        "from params/ profiles); its name is the file's stem, outputs go to outputs/<stem>/",
    )


class OneLineParser(argparse.ArgumentParser):
    """argparse with a one-line usage error (exit 2) that points at ``--help``."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


INPUT_ERRORS = (
    ConfigError,
    EphemerisRangeError,
    InvalidOrbitError,
    SpiceError,
    FileNotFoundError,
)  # bad input: exit 2


def _raised_by_lnss(error: BaseException) -> bool:
    """True when the innermost frame of ``error``'s traceback is lnss_lib code (one of its own checks)."""
    tb = error.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and Path(tb.tb_frame.f_code.co_filename).resolve().is_relative_to(
        PACKAGE_DIR
    )


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    if isinstance(error, OSError) and error.filename is not None:
        text = f"cannot write or read {error.filename}: {error.strerror or text}"
    return text or type(error).__name__


def classify(error: Exception) -> tuple[int, str]:
    """Exit code and one-line message: 2 for bad input (the input-error classes, and ValueErrors raised by
    lnss_lib's own checks), 1 for a failure (impact, OSError, RuntimeError) and for anything else, which is
    an internal error, not bad input."""
    if isinstance(error, FileNotFoundError):
        return 2, f"no such file or folder: {error.filename}" if error.filename else _one_line(
            error
        )
    if isinstance(error, INPUT_ERRORS) or (type(error) is ValueError and _raised_by_lnss(error)):
        return 2, _one_line(error)
    if isinstance(error, (OSError, RuntimeError)):
        return 1, _one_line(error)
    return (
        1,
        f"internal error: {type(error).__name__}: {_one_line(error)} (run with --debug for the traceback)",
    )


def main(argv: list[str] | None = None) -> int:
    """Run a command; errors end in one line on stderr with exit 2 (bad input), 1 (failure or internal
    error) or 130 (interrupted); ``--debug`` adds the traceback before that line, with the same exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help (0) or a usage error (2, one line already printed)
        return stop.code if isinstance(stop.code, int) else 2
    if _prints_result(args) and (sys.stdout is None or sys.stdout.closed):
        print(
            "error: standard output is closed: the command's result would be lost; open it or redirect it to a "
            "file",
            file=sys.stderr,
        )
        return 1
    previous = signal.signal(signal.SIGTERM, _terminate) if _in_main_thread() else None
    try:
        if getattr(args, "profile_file", None):
            args.profile = use_profile_file(args.profile_file)
        code = args.func(args)
        if sys.stdout is not None:
            sys.stdout.flush()  # a reader gone or a full disk is this command's failure, not exit 0
        return code
    except (KeyboardInterrupt, Exception) as error:
        code, text = (
            (143, "terminated (SIGTERM)")
            if isinstance(error, Terminated)
            else (130, "interrupted")
            if isinstance(error, KeyboardInterrupt)
            else classify(error)
        )
        if debug:
            traceback.print_exception(error)
        elif code in (
            130,
            143,
        ):  # tasks abandoned by the interrupt (a notebook kernel's) are logged when collected
            logging.getLogger("asyncio").setLevel(logging.CRITICAL)
        print(f"error: {text}", file=sys.stderr)
        return code
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _terminate(signum, frame):
    """SIGTERM raises :class:`~lnss_lib.errors.Terminated`: the run stops as on Ctrl-C (journal, checkpoint and
    workers closed), with one line and exit 143 (it ended silently, leaking semaphores)."""
    raise Terminated()


def _prints_result(args: argparse.Namespace) -> bool:
    """Whether the command's result goes to standard output (``evaluate``; ``propagate`` without ``--out``)."""
    return args.command == "evaluate" or (args.command == "propagate" and args.out is None)


if __name__ == "__main__":
    sys.exit(main())
