"""Notebook 07: how few satellites keep the south-pole service for the whole life, and at what cost?

Question: the paper claims over 90 % south-pole coverage with as few as six satellites below 0.4 km/s per satellite
and year (:data:`lnss_lib.paper.SMALLEST_CONSTELLATION`). The operational search over every size finds its cheapest
designs where its front is densest, so an empty row for six satellites says little. Here each size is asked
directly: a search restricted to N satellites (``[campaign] n_sat``, profiles ``operational_n6``, ``_n8``, ``_n9``,
``_n12``) for the best worst-month availability over the five-year life within the worst satellite's 1 km/s per year,
its front and its two cheapest candidates flown in closed loop (``validated.nc``). :func:`size_table` reads, per
size, the kept design flown with the best worst-month PDOP availability within the Delta-V bound: its availability
(worst month and over the life, with its worst satellite lost where flown), its Delta-V (mean, worst satellite, by
purpose) and lowest perilune; :func:`what_breaks` says, for a size that misses the requirement, what stood in the way.

Verdict: printed by notebook 07 from the shipped size searches (the searches run for hours; the table says which
sizes are shipped).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from ..campaign.validation import N_MINUS_1_KEYS
from ..design_life.service import PURPOSES
from ..keys import DESIGN_KEYS, closed_loop_dv_key

__all__ = ["SIZES", "size_profile", "size_validations", "size_table", "what_breaks"]

SIZES = (6, 8, 9, 12)
"""The constellation sizes asked: the paper's six, the next Walker sizes on Table 3's grid and the twelve the
operational search settles on."""

_COLUMNS = (
    "pdop_avail_pct_worst_month",
    "pdop_avail_pct_life",
    "hdop_avail_pct_worst_month",
    *N_MINUS_1_KEYS[1:3],
    "closed_loop_dv_kms_per_year",
    "closed_loop_dv_max_kms_per_year",
    *(closed_loop_dv_key(p) for p in PURPOSES),
    "min_perilune_alt_km",
)


def size_profile(n_sat: int) -> str:
    """The profile of the search restricted to ``n_sat`` satellites."""
    return f"operational_n{int(n_sat)}"


def size_validations(sizes=SIZES) -> dict[int, xr.Dataset | None]:
    """Each size's ``validated.nc``, as notebook 07 reads a campaign (published, else shipped:
    :func:`lnss_lib.studies.campaign.shown_campaign`); None for a size whose search was not run or not validated."""
    from .campaign import shown_campaign

    out = {}
    for size in sizes:
        try:
            out[size] = shown_campaign(size_profile(size)).validated
        except FileNotFoundError:
            out[size] = None
    return out


def _of(validated: xr.Dataset, key: str) -> np.ndarray:
    return validated[key].values if key in validated else np.full(validated.sizes["design"], np.nan)


def what_breaks(
    validated: xr.Dataset, *, availability_min_pct: float, dv_max_kms_per_year: float
) -> str:
    """Why no flown design of one size meets both bounds (worst month, PDOP): the best worst month reached within
    the Delta-V bound, and whether more availability was flown only above the bound or by designs that lost a
    satellite; "" when a design meets both."""
    kept = _of(validated, "status") == "kept"
    worst = _of(validated, "pdop_avail_pct_worst_month").astype(float)
    dv = _of(validated, "closed_loop_dv_max_kms_per_year").astype(float)
    with np.errstate(invalid="ignore"):
        cheap = kept & (dv <= dv_max_kms_per_year)
        if (cheap & (worst >= availability_min_pct)).any():
            return ""
        reasons = [
            f"best worst month within {dv_max_kms_per_year:g} km/s/yr: "
            + (f"{np.nanmax(worst[cheap]):.1f} %" if cheap.any() else "no kept design")
        ]
        dear = kept & (dv > dv_max_kms_per_year) & (worst >= availability_min_pct)
        if dear.any():
            i = np.flatnonzero(dear)[np.argmin(dv[dear])]
            reasons.append(
                f"{availability_min_pct:g} % flown only at {dv[i]:.2f} km/s/yr (worst satellite)"
            )
        lost = ~kept & (worst >= availability_min_pct)
        if lost.any():
            reasons.append(f"{int(lost.sum())} design(s) reaching it lost a satellite")
    return "; ".join(reasons)


def size_table(
    validated_by_size: dict[int, xr.Dataset | None],
    *,
    availability_min_pct: float,
    dv_max_kms_per_year: float,
    paper: dict,
) -> pd.DataFrame:
    """One row a size (``validated_by_size``: size -> the restricted search's ``validated.nc``, None when not run):
    the kept design flown with the best worst-month PDOP availability within ``dv_max_kms_per_year`` (worst
    satellite; ties: the cheaper), its numbers (:data:`_COLUMNS`), whether it meets ``availability_min_pct`` in
    its worst month, :func:`what_breaks` otherwise, and the flown and failed counts; the paper's claim last."""
    rows = []
    for size, validated in validated_by_size.items():
        if validated is None:
            rows.append({"n_sat": size, "result": "not run"})
            continue
        status = _of(validated, "status")
        worst = _of(validated, "pdop_avail_pct_worst_month").astype(float)
        dv = _of(validated, "closed_loop_dv_max_kms_per_year").astype(float)
        with np.errstate(invalid="ignore"):
            ok = np.flatnonzero(
                (status == "kept") & (dv <= dv_max_kms_per_year) & np.isfinite(worst)
            )
        counts = {
            "flown": int(validated.sizes["design"]),
            "failed or error": int((status != "kept").sum()),
        }
        why = what_breaks(
            validated,
            availability_min_pct=availability_min_pct,
            dv_max_kms_per_year=dv_max_kms_per_year,
        )
        if not ok.size:
            rows.append(
                {
                    "n_sat": size,
                    "result": "none kept within the Delta-V bound",
                    "what breaks": why,
                    **counts,
                }
            )
            continue
        best = ok[np.lexsort((dv[ok], -worst[ok]))[0]]
        rows.append(
            {
                "n_sat": size,
                "result": "meets" if not why else "misses",
                **{k: validated[k].values[best].item() for k in DESIGN_KEYS},
                **{k: float(_of(validated, k)[best]) for k in _COLUMNS},
                "what breaks": why,
                **counts,
            }
        )
    rows.append(
        {
            "n_sat": paper["n_sat"],
            "result": "claimed (paper's abstract)",
            "pdop_avail_pct_life": paper["availability_pct"],
            "closed_loop_dv_max_kms_per_year": paper["dv_below_kms_per_year"],
        }
    )
    return pd.DataFrame(rows)
