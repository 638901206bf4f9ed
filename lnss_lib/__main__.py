"""Command line: ``python -m lnss_lib {reproduce, propagate, evaluate, campaign, bench} ...`` (``--help`` on each)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .config import available_profiles, load_profile
from .constants import SECONDS_PER_DAY

BENCHMARKS = ("propagator", "dop", "evaluate", "campaign", "integrator")


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from .pipeline import reproduce

    return reproduce(args.profile, only=args.only)


def _cmd_propagate(args: argparse.Namespace) -> int:
    from .ephemeris import ensure_kernels, tdb_seconds
    from .propagator import elements_deg_to_states, propagate_states

    profile = load_profile(args.profile, overrides={"gravity": {"degree": args.degree}} if args.degree else None)
    ensure_kernels(profile)
    t0 = tdb_seconds(args.epoch_tdb, "TDB")
    if args.elements is not None:
        state = elements_deg_to_states(profile, [args.elements], t0)
    else:
        state = np.array([args.state_km])
    ds = propagate_states(profile, state, t0, args.days * SECONDS_PER_DAY, args.step_s, setting=args.setting,
                          srp_cr_area_mass_m2_kg=args.srp_cr_area_mass)
    out = Path(args.out) if args.out else None
    if out is not None and out.suffix == ".nc":
        ds.to_netcdf(out, engine="h5netcdf")
    else:
        table = np.column_stack([ds.time.values, ds.r_mci_km.values[0], ds.v_mci_kms.values[0]])
        header = ("t_tdb_s,x,y,z,vx,vy,vz  # Moon-centred J2000, km and km/s, TDB seconds past J2000; "
                  f"{ds.attrs['force_model']}; {ds.attrs['integrator']} rtol={ds.attrs['rtol']} atol={ds.attrs['atol']}")
        target = out.open("w") if out is not None else sys.stdout
        np.savetxt(target, table, delimiter=",", header=header, comments="", fmt="%.9f")
        if out is not None:
            target.close()
    if out is not None:
        print(f"wrote {out} ({ds.sizes['time']} samples)", file=sys.stderr)
    return 0


def _cmd_evaluate(args: argparse.Namespace) -> int:
    import json

    walker = {"--sma-km": args.sma_km, "--ecc": args.ecc, "--aop-deg": args.aop_deg, "--inc-deg": args.inc_deg,
              "--planes": args.planes, "--sats-per-plane": args.sats_per_plane}
    if args.constellation is not None:
        given = [flag for flag, value in walker.items() if value is not None]
        if given:
            raise ValueError(f"--constellation replaces the Walker arguments; drop {', '.join(given)}")
        from .catalogue import evaluate_catalogue_cli

        result = evaluate_catalogue_cli(args.profile, args.constellation, epoch=args.constellation_epoch)
    else:
        missing = [flag for flag, value in walker.items() if value is None]
        if missing:
            raise ValueError(f"evaluate needs --constellation NAME_OR_PATH or all Walker arguments; "
                             f"missing {', '.join(missing)}")
        from .evaluator import evaluate_cli

        result = evaluate_cli(args.profile, args.sma_km, args.ecc, args.aop_deg, args.inc_deg, args.planes,
                              args.sats_per_plane)
    if args.json:
        print(json.dumps(result))
    else:
        width = max(map(len, result))
        for key, value in result.items():
            print(f"{key:<{width}}  {value:.6g}" if isinstance(value, float) else f"{key:<{width}}  {value}")
    return 0


def _parse_sets(items: list[str] | None) -> dict | None:
    """``SECTION.KEY=VALUE`` strings (VALUE a TOML literal) as a nested overrides dict."""
    import tomllib

    from .config import deep_merge

    overrides: dict = {}
    for item in items or []:
        path, sep, literal = item.partition("=")
        if not sep or not path.strip():
            raise ValueError(f"--set needs SECTION.KEY=VALUE (VALUE in TOML syntax); got {item!r}")
        try:
            value = tomllib.loads(f"v = {literal}")["v"]
        except tomllib.TOMLDecodeError as error:
            raise ValueError(f"--set {item!r}: VALUE is not a TOML literal ({error})") from None
        nested: dict = value
        for part in reversed(path.strip().split(".")):
            nested = {part: nested}
        overrides = deep_merge(overrides, nested)
    return overrides or None


def _cmd_campaign(args: argparse.Namespace) -> int:
    from .campaign import run_campaign

    overrides = _parse_sets(args.set)
    if args.evaluator:
        overrides = {**(overrides or {}), "campaign": {**(overrides or {}).get("campaign", {}),
                                                       "evaluator": args.evaluator}}
    if args.resume and (args.profile or overrides or args.run_dir):
        raise ValueError("--resume continues a run with its stored parameters: "
                         "drop --profile, --set, --evaluator and --run-dir")
    result = run_campaign(args.profile or "quick", overrides=overrides, workers=args.workers,
                          scheduler_address=args.scheduler_address, run_dir=args.run_dir, resume=args.resume,
                          progress=not args.no_progress, max_generations=args.max_generations)
    rate = result.session_evaluations / result.session_wall_s if result.session_wall_s > 0 else 0.0
    print(f"run {result.run_dir}: {result.generations} generation(s), {result.n_evaluations} unique designs "
          f"evaluated ({result.n_feasible} feasible); this session {result.session_evaluations} evaluations in "
          f"{result.session_wall_s:.1f} s ({rate:.2f} designs/s)"
          + (f"; {result.resubmitted} design(s) resubmitted after lost workers" if result.resubmitted else ""))
    for path in result.files:
        print(f"wrote {path}")
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    module = importlib.import_module(f"lnss_lib.bench.{args.name}")
    if args.scaling and args.name != "campaign":
        raise SystemExit("--scaling applies to 'bench campaign' only")
    module.run(profile_name=args.profile, **({"scaling_run": True} if args.scaling else {}))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m lnss_lib", description="LNSS design workbook")
    sub = parser.add_subparsers(dest="command", required=True)

    rep = sub.add_parser("reproduce", help="execute the notebooks headless into outputs/<profile>/")
    rep.add_argument("--profile", default="quick", help=f"profile in params/ ({', '.join(available_profiles())})")
    rep.add_argument("--only", nargs="+", metavar="NAME", help="notebook names or number prefixes (e.g. 01 02_dop_grid)")
    rep.set_defaults(func=_cmd_reproduce)

    prop = sub.add_parser("propagate", help="propagate one orbit with the high-fidelity model; CSV or NetCDF out")
    prop.add_argument("--epoch-tdb", required=True, help="start epoch, ISO calendar in TDB (e.g. 2022-11-25T00:00:00)")
    group = prop.add_mutually_exclusive_group(required=True)
    group.add_argument("--state-km", nargs=6, type=float, metavar=("X", "Y", "Z", "VX", "VY", "VZ"),
                       help="Moon-centred J2000 state, km and km/s")
    group.add_argument("--elements", nargs=6, type=float, metavar=("A_KM", "E", "I", "RAAN", "AOP", "M"),
                       help="Keplerian elements (km, deg) in the profile's element frame")
    prop.add_argument("--days", type=float, required=True, help="duration in days")
    prop.add_argument("--step-s", type=float, default=900.0, help="output sampling step in seconds")
    prop.add_argument("--degree", type=int, help="gravity degree and order (2-100)")
    prop.add_argument("--srp-cr-area-mass", type=float, help="Cr*A/m in m^2/kg (default: the profile's spacecraft)")
    prop.add_argument("--setting", help="integrator setting: paper or converged (default: the profile's)")
    prop.add_argument("--profile", default="paper", help="profile for force model and constants")
    prop.add_argument("--out", help="output path, .csv or .nc (default: CSV to stdout)")
    prop.set_defaults(func=_cmd_propagate)

    ev = sub.add_parser("evaluate", help="every objective of eq. 45 for one Walker design or one catalogue constellation")
    ev.add_argument("--constellation", metavar="NAME_OR_PATH",
                    help="catalogue name (params/constellations/NAME.toml) or a TOML file in that format, "
                         "instead of the Walker arguments")
    ev.add_argument("--constellation-epoch", choices=("study", "file"), default="study",
                    help="read the constellation's elements at the study epoch (default) or at its file's epoch")
    ev.add_argument("--sma-km", type=float, help="semi-major axis (km)")
    ev.add_argument("--ecc", type=float, help="eccentricity, [0, 1)")
    ev.add_argument("--aop-deg", type=float, help="argument of perilune (deg)")
    ev.add_argument("--inc-deg", type=float, help="inclination to the element frame's equator (deg)")
    ev.add_argument("--planes", type=int, help="number of planes Np (RAAN by eq. 42)")
    ev.add_argument("--sats-per-plane", type=int, help="satellites per plane Ns")
    ev.add_argument("--profile", default="quick", help=f"profile in params/ ({', '.join(available_profiles())})")
    ev.add_argument("--json", action="store_true", help="print one JSON object")
    ev.set_defaults(func=_cmd_evaluate)

    camp = sub.add_parser("campaign", help="NSGA-II design search (Section 5, Table 5), checkpointed every generation")
    camp.add_argument("--profile", help=f"profile in params/ ({', '.join(available_profiles())}; default quick)")
    camp.add_argument("--workers", type=int, help="Dask worker processes on this machine (default: one per core; "
                      "0 or 1: evaluate in this process)")
    camp.add_argument("--scheduler-address", help="use an existing Dask cluster, e.g. tcp://HOST:8786")
    camp.add_argument("--resume", metavar="RUN_DIR", help="continue the run in RUN_DIR from its last checkpoint")
    camp.add_argument("--run-dir", help="new run directory (default outputs/<profile>/campaign/run_<time>)")
    camp.add_argument("--evaluator", choices=("walker", "synthetic"),
                      help="walker (default): the design evaluator; synthetic: closed-form stand-in for tests")
    camp.add_argument("--set", action="append", metavar="SECTION.KEY=VALUE",
                      help="override a profile value (TOML literal), e.g. campaign.generations=20; repeatable")
    camp.add_argument("--max-generations", type=int, help="stop this session after N generations (resumable)")
    camp.add_argument("--no-progress", action="store_true", help="no progress bars")
    camp.set_defaults(func=_cmd_campaign)

    bench = sub.add_parser("bench", help="benchmarks that print numbers")
    bench.add_argument("name", choices=BENCHMARKS)
    bench.add_argument("--profile", default="paper")
    bench.add_argument("--scaling", action="store_true", help="campaign: local scaling and loopback-cluster overhead")
    bench.set_defaults(func=_cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
