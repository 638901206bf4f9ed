"""``python -m lnss_lib propagate``: one orbit with the profile's force model, as CSV or NetCDF."""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from ..constants import SECONDS_PER_DAY
from ..errors import ConfigError
from ..sections import CR_AREA_MASS, CR_AREA_MASS_WHY
from ..settings import load_settings
from .arguments import add_profile, add_set, check_output, integer, profile_overrides, require


def run(args: argparse.Namespace) -> int:
    import io

    from ..atomicio import write_netcdf_atomic, write_text_atomic
    from ..elements import check_states_km
    from ..ephemeris import check_span, ensure_kernels, tdb_seconds
    from ..propagator import check_elements_deg, elements_deg_to_states, propagate_states

    require("--days", args.days, (0.0, None, True, False))
    require("--step-s", args.step_s, (0.0, None, True, False))
    require("--degree", args.degree, (0, 100, False, False), integer=True)
    require("--srp-cr-area-mass", args.srp_cr_area_mass, CR_AREA_MASS, why=CR_AREA_MASS_WHY)
    if args.elements is not None:
        check_elements_deg([args.elements])
    elif not all(math.isfinite(v) for v in args.state_km):
        raise ConfigError(
            f"--state-km {' '.join(map(str, args.state_km))}: every component must be finite",
            key="--state-km",
        )
    out = check_output(args.out)
    overrides = profile_overrides(args) or {}
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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--epoch-tdb",
        required=True,
        help="start epoch in TDB, ISO 8601 YYYY-MM-DDTHH:MM:SS without zone "
        "(e.g. 2022-11-25T00:00:00)",
    )
    group = parser.add_mutually_exclusive_group(required=True)
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
    parser.add_argument("--days", type=float, required=True, help="duration in days")
    parser.add_argument(
        "--step-s", type=float, default=900.0, help="output sampling step in seconds"
    )
    parser.add_argument(
        "--degree", type=integer, help="gravity degree and order (0-100; 0 = point mass)"
    )
    parser.add_argument(
        "--srp-cr-area-mass",
        type=float,
        help="Cr*A/m in m^2/kg (default: the profile's spacecraft)",
    )
    parser.add_argument(
        "--setting", help="integrator setting: paper or converged (default: the profile's)"
    )
    add_profile(parser, "paper")
    parser.add_argument("--out", help="output path, .csv or .nc (default: CSV to stdout)")
    add_set(parser)
