"""Per-design costs of recorded campaigns, small enough to ship: what a replay (:mod:`.replay`) reads of a journal.

A journal (``evaluations.jsonl``) holds every metric of every design; a replay needs of each design only the
generation that asked for it, the two integers the campaign's backend orders it by (``n_planes`` and
``sats_per_plane``, decoded by the run's own design grid: the journal's key holds them scaled, and the product of
the scaled integers orders constellations differently) and its cost (``task_wall_s``: the task's wall time on its worker). ``costs.nc``
keeps those, one row per design first evaluated in each campaign (about a dozen bytes a design compressed: 5
campaigns of 120 x 300, some 2 MB), with where the costs were measured: the machine and processor model, the
worker processes that shared it, and each run's commit and evaluation hash. :func:`costs_netcdf` gives its bytes
from run folders (for a study's export); :func:`read_costs` gives back what
:func:`journal_costs` gives of each journal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import ConfigError
from .journal import read_cache_records
from .reference import machine_text, netcdf_bytes
from .rundir import load_checkpoint, load_run
from .timing import concurrent_workers

__all__ = ["COSTS_FILE", "journal_costs", "costs_netcdf", "read_costs"]

COSTS_FILE = "costs.nc"


def _generations(records: list[dict], checkpoint: dict | None) -> dict[int, list[dict]]:
    """``{generation: items}`` of the records (in the order the campaign asked for them), the generations the
    run's last ``checkpoint`` completed (a journal being written holds part of the next generation, which a replay
    leaves out; none before the first checkpoint), each design's planes and satellites per plane decoded by the
    checkpoint's design grid."""
    if checkpoint is None:
        return {}
    completed, grid = len(checkpoint["history"]), checkpoint["algorithm"].problem.plan.grid
    kept = sorted(
        (r for r in records if int(r["generation"]) <= completed),
        key=lambda r: (r["generation"], r["order"]),
    )
    generations: dict[int, list[dict]] = {}
    designs = grid.designs([r["key"] for r in kept]) if kept else []
    for record, design in zip(kept, designs):
        generations.setdefault(int(record["generation"]), []).append(
            {
                "n_planes": int(design["n_planes"]),
                "sats_per_plane": int(design["sats_per_plane"]),
                "cost_s": float(record["task_wall_s"]),
            }
        )
    return dict(sorted(generations.items()))


def journal_costs(run_dir) -> list[list[dict]]:
    """Per generation of the run in ``run_dir`` (first to last; those its last checkpoint completed, none before
    the first), one item per design first evaluated in it: ``{"n_planes", "sats_per_plane", "cost_s"}`` (the task's wall
    time on its worker; the design's planes and satellites per plane, which order the designs as the campaign
    does)."""
    run_dir = Path(run_dir)
    return list(_generations(read_cache_records(run_dir), load_checkpoint(run_dir)).values())


def costs_netcdf(runs: dict[str, Path], *, export_commit: str = "unknown") -> bytes:
    """The bytes of ``costs.nc`` (NetCDF-4) from the campaign run folders ``runs`` (``{campaign name: run folder}``,
    each with its journal and run.json; a study's export puts them beside its campaigns): one row per design
    (``campaign``, ``generation``, ``n_planes``, ``sats_per_plane``, ``cost_s``) and, in the attributes, the campaigns in order, each run's worker processes,
    processor model, commit and evaluation hash, and the machine that writes the file. ConfigError for an empty
    ``runs``."""
    if not runs:
        raise ConfigError("costs_netcdf needs at least one campaign run folder", key="runs")
    columns: dict[str, list] = {
        k: [] for k in ("campaign", "generation", "n_planes", "sats_per_plane", "cost_s")
    }
    provenance: dict[str, list[str]] = {
        k: [] for k in ("workers", "kernel_cpu", "run_commit", "evaluation_hash")
    }
    for index, run_dir in enumerate(runs.values()):
        run_dir = Path(run_dir)
        run, records = load_run(run_dir), read_cache_records(run_dir)
        for generation, items in _generations(records, load_checkpoint(run_dir)).items():
            for item in items:
                columns["campaign"].append(index)
                columns["generation"].append(generation)
                for key in ("n_planes", "sats_per_plane", "cost_s"):
                    columns[key].append(item[key])
        provenance["workers"].append(str(concurrent_workers(records)))
        provenance["kernel_cpu"].append(str(run.get("versions", {}).get("kernel_cpu", "unknown")))
        provenance["run_commit"].append(str(run.get("commit", "unknown")))
        provenance["evaluation_hash"].append(str(run["evaluation_hash"]))
    dtypes = {
        "campaign": np.int16,
        "generation": np.int32,
        "n_planes": np.int16,
        "sats_per_plane": np.int16,
        "cost_s": np.float32,
    }
    ds = xr.Dataset({k: ("design", np.asarray(v, dtype=dtypes[k])) for k, v in columns.items()})
    ds["cost_s"].attrs = {"units": "s", "long_name": "wall time of the design's task on its worker"}
    ds["campaign"].attrs = {
        "long_name": "index of the design's campaign in the attribute campaigns"
    }
    ds["generation"].attrs = {"long_name": "generation that first asked for the design"}
    for key in ("n_planes", "sats_per_plane"):
        ds[key].attrs = {
            "long_name": f"{key} of the design (decoded from the grid's scaled integer)"
        }
    ds.attrs = {
        "title": "Per-design costs of recorded campaigns (for the cluster replay)",
        "Conventions": "CF-1.8",
        "campaigns": ",".join(runs),
        **{k: ",".join(v) for k, v in provenance.items()},
        "machine": machine_text(),
        "export_commit": export_commit,
    }
    return netcdf_bytes(ds)


def read_costs(path) -> dict[str, list[list[dict]]]:
    """``{campaign: per generation the items of :func:`journal_costs`}`` from a ``costs.nc`` written by
    :func:`costs_netcdf`."""
    with xr.open_dataset(Path(path), engine="h5netcdf") as ds:
        names = ds.attrs["campaigns"].split(",")
        columns = {
            k: ds[k].values for k in ("campaign", "generation", "n_planes", "sats_per_plane")
        }
        cost_s = ds["cost_s"].values.astype(float)
    out = {}
    for index, name in enumerate(names):
        rows = np.flatnonzero(columns["campaign"] == index)
        generations: dict[int, list[dict]] = {}
        for row in rows:
            generations.setdefault(int(columns["generation"][row]), []).append(
                {
                    "n_planes": int(columns["n_planes"][row]),
                    "sats_per_plane": int(columns["sats_per_plane"][row]),
                    "cost_s": float(cost_s[row]),
                }
            )
        out[name] = [generations[g] for g in sorted(generations)]
    return out
