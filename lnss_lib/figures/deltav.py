"""Notebook 04: station-keeping Delta-V model (paper Figures 5 and 6, Table 4, Section 3.1)."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from .charts import days_since_start


def thrust_history(dv_ds, model: str, *, title: str) -> go.Figure:
    """Required thrust acceleration, total and optimised, and its RTN components (paper Figure 6)."""
    from plotly.subplots import make_subplots

    days = days_since_start(dv_ds)
    one = dv_ds.sel(model=model)
    fig = make_subplots(
        rows=2,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.06,
        subplot_titles=["|T| total and optimised (km/s^2)", "|T_R|, |T_T|, |T_N| (km/s^2)"],
    )
    fig.add_trace(
        go.Scatter(x=days, y=one["T_total_kms2"].values, name="total (eq. 36)"), row=1, col=1
    )
    fig.add_trace(
        go.Scatter(x=days, y=one["T_opt_kms2"].values, name="optimised (eq. 40-41)"), row=1, col=1
    )
    for component in ("R", "T", "N"):
        fig.add_trace(
            go.Scatter(
                x=days, y=abs(one["T_rtn_kms2"].sel(rtn=component).values), name=f"|T_{component}|"
            ),
            row=2,
            col=1,
        )
    fig.update_yaxes(type="log", exponentformat="power")
    fig.update_xaxes(title_text="days since epoch (TDB)", row=2, col=1)
    fig.update_layout(title=title, template="plotly_white", height=700)
    return fig


def deltav_elements_and_rates(res, *, title: str) -> go.Figure:
    """Osculating a, e, i, RAAN, AOP (left) and their central-difference rates (right) of a
    :func:`lnss_lib.deltav.deltav_from_propagation` result (paper Figure 5)."""
    from plotly.subplots import make_subplots

    days = days_since_start(res)
    deg = np.degrees(1.0)
    names = [
        ("a_km", "a (km)", 1.0),
        ("ecc", "e", 1.0),
        ("inc_rad", "i (deg)", deg),
        ("raan_rad", "RAAN (deg)", deg),
        ("aop_rad", "AOP (deg)", deg),
    ]
    rate_units = [
        ("km/day", 86400.0),
        ("1/day", 86400.0),
        ("deg/day", np.degrees(86400.0)),
        ("deg/day", np.degrees(86400.0)),
        ("deg/day", np.degrees(86400.0)),
    ]
    fig = make_subplots(
        rows=5,
        cols=2,
        shared_xaxes=True,
        horizontal_spacing=0.1,
        vertical_spacing=0.03,
        subplot_titles=[
            label if c == 0 else f"d/dt {label.split(' ')[0]} ({rate_units[r][0]})"
            for r, (_, label, _) in enumerate(names)
            for c in range(2)
        ],
    )
    for r, ((var, label, scale), (_, rate_scale)) in enumerate(zip(names, rate_units)):
        fig.add_trace(
            go.Scatter(
                x=days, y=res[var].values * scale, mode="lines", name=label, showlegend=False
            ),
            row=r + 1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=days,
                y=res["rate"].values[:, r] * rate_scale,
                mode="lines",
                name=f"rate {label}",
                showlegend=False,
            ),
            row=r + 1,
            col=2,
        )
    fig.update_xaxes(title_text="days since epoch (TDB)", row=5)
    fig.update_layout(height=1100, width=1000, title=title)
    return fig


def deltav_thrust_components(
    res, *, title: str, models=("lsq", "paper"), budget_model: str = "lsq"
) -> go.Figure:
    """|T_R|, |T_T|, |T_N| of the osculating models and T_total (eq. 36) and T_opt (eq. 40) of ``budget_model``
    against time, log scale (paper Figure 6). ``res``: :func:`lnss_lib.deltav.deltav_from_propagation`."""
    from plotly.subplots import make_subplots

    days = days_since_start(res)
    fig = make_subplots(
        rows=4,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.04,
        subplot_titles=[
            "|T_R| (km/s^2)",
            "|T_T| (km/s^2)",
            "|T_N| (km/s^2)",
            f"T_total and T_opt of {budget_model} (km/s^2)",
        ],
    )
    dashes = ("solid", "dot", "dash")
    for k, comp in enumerate("RTN"):
        for model, dash in zip(models, dashes):
            fig.add_trace(
                go.Scatter(
                    x=days,
                    y=np.abs(res["T_rtn_kms2"].sel(model=model, rtn=comp).values),
                    mode="lines",
                    line={"dash": dash},
                    name=f"{model} |T_{comp}|",
                    legendgroup=model,
                ),
                row=k + 1,
                col=1,
            )
    fig.add_trace(
        go.Scatter(
            x=days,
            y=res["T_total_kms2"].sel(model=budget_model).values,
            mode="lines",
            name=f"{budget_model} T_total",
        ),
        row=4,
        col=1,
    )
    fig.add_trace(
        go.Scatter(
            x=days,
            y=res["T_opt_kms2"].sel(model=budget_model).values,
            mode="lines",
            name=f"{budget_model} T_opt (eq. 40)",
        ),
        row=4,
        col=1,
    )
    fig.update_yaxes(type="log", exponentformat="e")
    fig.update_xaxes(title_text="days since epoch (TDB)", row=4)
    fig.update_layout(height=1000, width=1000, title=title)
    return fig


def lsq_recovery_series(
    t_tdb_s, truth_rtn_kms2, out: dict, *, title: str, max_days: float = 2.0
) -> go.Figure:
    """RTN perturbing acceleration of the force model (truth) against the ``lsq`` and corrected ``paper`` inverses
    over the first ``max_days`` (notebook 04); inputs from :func:`lnss_lib.deltav.lsq_recovery`."""
    from plotly.subplots import make_subplots

    t = np.asarray(t_tdb_s, dtype=float)
    days = (t - t[0]) / 86400.0
    window = days <= min(max_days, days[-1])
    fig = make_subplots(
        rows=3,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.05,
        subplot_titles=[f"T_{c} (km/s^2)" for c in "RTN"],
    )
    for k in range(3):
        fig.add_trace(
            go.Scatter(
                x=days[window],
                y=truth_rtn_kms2[window, k],
                mode="lines",
                name="force model (truth)",
                line={"color": "black"},
                showlegend=k == 0,
            ),
            row=k + 1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=days[window],
                y=out["T_rtn_lsq"][window, k],
                mode="markers",
                marker={"size": 4},
                name="lsq inverse",
                marker_color="#d62728",
                showlegend=k == 0,
            ),
            row=k + 1,
            col=1,
        )
        fig.add_trace(
            go.Scatter(
                x=days[window],
                y=out["T_rtn_paper"][window, k],
                mode="markers",
                marker={"size": 4, "symbol": "x"},
                name="paper (corrected)",
                marker_color="#1f77b4",
                showlegend=k == 0,
            ),
            row=k + 1,
            col=1,
        )
    fig.update_xaxes(title_text="days since epoch (TDB)", row=3)
    fig.update_layout(height=800, width=1000, title=title)
    return fig


def deltav_sampling(sampling, paper: dict, *, models=("paper", "lsq", "secular")) -> go.Figure:
    """Delta-V against sampling step for each integrator setting (:func:`lnss_lib.deltav.sampling_sweep`),
    with Table 4's total and optimised budgets (``paper``: ``dv_total``, ``dv_opt``)."""
    fig = go.Figure()
    for setting, dash in zip(
        dict.fromkeys(sampling.index.get_level_values(0)), ("solid", "dot", "dash")
    ):
        sub = sampling.loc[setting]
        for m in models:
            fig.add_trace(
                go.Scatter(
                    x=sub.index,
                    y=sub[f"{m} total"],
                    mode="lines+markers",
                    line={"dash": dash},
                    name=f"{m} total, {setting} tolerances",
                )
            )
        fig.add_trace(
            go.Scatter(
                x=sub.index,
                y=sub["lsq opt"],
                mode="lines+markers",
                line={"dash": dash},
                name=f"lsq opt, {setting} tolerances",
            )
        )
    fig.add_hline(
        y=paper["dv_total"],
        line_dash="dash",
        annotation_text=f"paper total {paper['dv_total']:.2f}",
    )
    fig.add_hline(
        y=paper["dv_opt"],
        line_dash="dash",
        annotation_text=f"paper optimised {paper['dv_opt']:.2f}",
    )
    fig.update_layout(
        xaxis_title="sampling step (s)",
        yaxis_title="Delta-V (km/s per year)",
        xaxis_type="log",
        title="Delta-V of ELFO satellite 1 against sampling step and integrator tolerances",
        width=1000,
        height=550,
    )
    return fig


def deltav_singularity(singular) -> go.Figure:
    """``paper``-model total Delta-V against the divisor floor (no cap), one line per variant of eq. 32/35
    (:func:`lnss_lib.deltav.singularity_sweep`); a floor of 0 is plotted at 1e-8."""
    fig = go.Figure()
    for label in dict.fromkeys(singular.index.get_level_values("variant")):
        sub = singular.xs(label, level="variant").xs("none", level="cap (km/s^2)")
        x = np.where(sub.index.values > 0, sub.index.values, 1e-8)
        fig.add_trace(go.Scatter(x=x, y=sub["dv total"], mode="lines+markers", name=label))
    fig.update_layout(
        xaxis_type="log",
        yaxis_type="log",
        xaxis_title="divisor floor (0 plotted at 1e-8)",
        yaxis_title="paper-model Delta-V total (km/s per year)",
        width=1000,
        height=500,
        title="paper model: dependence on the singularity handling (no cap)",
    )
    return fig
