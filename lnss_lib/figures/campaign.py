"""Notebook 06: progress of an optimisation campaign (convergence, throughput) and its designs in the
PDOP / Delta-V plane."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from ..keys import label


def campaign_convergence(history, title: str) -> go.Figure:
    """NSGA-II progress per generation (history.nc of :func:`lnss_lib.optimize.export_results`): hypervolume
    of the feasible archive, smallest population violation (log), unique designs and feasible counts."""
    from plotly.subplots import make_subplots

    g = history.generation.values
    fig = make_subplots(
        rows=2,
        cols=2,
        subplot_titles=(
            "hypervolume of the feasible archive",
            "smallest constraint violation in the population",
            "unique designs evaluated (cumulative)",
            "feasible designs: unique so far and in the population",
        ),
    )
    panels = (
        ("hypervolume", "hypervolume", 1, 1),
        ("min_cv_pop", "min violation", 1, 2),
        ("n_evaluations_cum", "unique evaluated", 2, 1),
        ("n_feasible_cum", "unique feasible", 2, 2),
        ("n_feasible_pop", "feasible in population", 2, 2),
    )
    for var, name, row, col in panels:
        fig.add_trace(
            go.Scatter(x=g, y=history[var].values, mode="lines+markers", name=name), row, col
        )
    fig.update_yaxes(type="log", row=1, col=2)
    fig.update_xaxes(title_text="generation")
    fig.update_layout(title=title, height=650)
    if g.size and int(history["n_feasible_cum"].values[-1]) == 0:
        fig.add_annotation(
            xref="paper",
            yref="paper",
            x=0.0,
            y=1.09,
            xanchor="left",
            showarrow=False,
            font={"color": "#b00"},
            text=f"no feasible design in {g.size} generation(s): the hypervolume "
            "and feasible counts stay 0; progress is the smallest violation",
        )
        fig.update_layout(margin={"t": 120})
    return fig


def designs_pdop_deltav(
    evaluations,
    front,
    dv_bound: float,
    pdop_bound: float,
    title: str,
    dv_metric: str = "dv_total_kms_per_year",
) -> go.Figure:
    """Every evaluated design with a PDOP: PDOP_3sigma against the Delta-V ``dv_metric`` (Delta-V_total, or the
    operational geometry-keeping estimate; km/s per year), log axes, colour = n_sat, the bounds ``dv_bound``
    and ``pdop_bound`` dashed, front designs circled."""
    if dv_bound <= 0 or pdop_bound <= 0:
        raise ValueError(
            f"bounds must be positive on log axes; got dv_bound {dv_bound!r}, pdop_bound {pdop_bound!r}"
        )
    ev = evaluations
    shown = ~np.isnan(ev.pdop_mean_3sigma.values)
    fig = go.Figure()
    fig.add_trace(
        go.Scatter(
            x=ev[dv_metric].values[shown],
            y=ev.pdop_mean_3sigma.values[shown],
            mode="markers",
            name="evaluated",
            marker=dict(
                color=ev.n_sat.values[shown],
                colorscale="Viridis",
                showscale=True,
                colorbar=dict(title=label("n_sat")),
                size=7,
            ),
            text=[
                f"a {a:.0f} km, e {e:.2f}, AOP {w:.0f}, i {i:.0f}, {p}x{s}, generation {gen}"
                for a, e, w, i, p, s, gen in zip(
                    ev.sma_km.values[shown],
                    ev.ecc.values[shown],
                    ev.aop_deg.values[shown],
                    ev.inc_deg.values[shown],
                    ev.n_planes.values[shown],
                    ev.sats_per_plane.values[shown],
                    ev.generation.values[shown],
                )
            ],
        )
    )
    if front.sizes["design"]:
        fig.add_trace(
            go.Scatter(
                x=front[dv_metric].values,
                y=front.pdop_mean_3sigma.values,
                mode="markers",
                name="front (feasible)",
                marker=dict(size=14, color="rgba(0,0,0,0)", line=dict(width=2, color="red")),
            )
        )
    fig.add_vline(x=dv_bound, line_dash="dash")
    fig.add_hline(y=pdop_bound, line_dash="dash")
    # annotation coordinates on log axes are log10 values
    fig.add_annotation(
        x=np.log10(dv_bound),
        y=1.0,
        xref="x",
        yref="paper",
        text="Delta-V bound",
        showarrow=False,
        xanchor="left",
    )
    fig.add_annotation(
        x=1.0,
        y=np.log10(pdop_bound),
        xref="paper",
        yref="y",
        text="PDOP bound",
        showarrow=False,
        xanchor="right",
        yanchor="bottom",
    )
    x_all = np.append(ev[dv_metric].values[shown], dv_bound)
    y_all = np.append(ev.pdop_mean_3sigma.values[shown], pdop_bound)
    fig.update_xaxes(
        title_text=label(dv_metric),
        type="log",
        range=[np.log10(np.nanmin(x_all)) - 0.1, np.log10(np.nanmax(x_all)) + 0.1],
    )
    fig.update_yaxes(
        title_text=f"{label('pdop_mean_3sigma')}, south-pole grid",
        type="log",
        range=[np.log10(np.nanmin(y_all)) - 0.1, np.log10(np.nanmax(y_all)) + 0.1],
    )
    fig.update_layout(title=title)
    return fig


def campaign_throughput(history, title: str) -> go.Figure:
    """Designs evaluated per second in each generation of a campaign (history.nc ``designs_per_s``)."""
    fig = go.Figure(
        go.Bar(x=history.generation.values, y=history.designs_per_s.values, name="designs/s")
    )
    fig.update_layout(title=title, xaxis_title="generation", yaxis_title="designs / s")
    return fig


def generation_curve(
    history, variable: str, title: str, *, log: bool = False, marks: dict | None = None
) -> go.Figure:
    """One per-generation quantity of a campaign history (``history[variable]``: hypervolume, smallest violation,
    ...) against the generation, with a dashed vertical line and label at each ``marks`` entry (label: generation)."""
    fig = go.Figure(
        go.Scatter(
            x=history.generation.values, y=history[variable].values, mode="lines", name=variable
        )
    )
    for text, generation in (marks or {}).items():
        fig.add_vline(x=generation, line_dash="dash", line_color="#888")
        fig.add_annotation(
            x=generation,
            y=1.0,
            xref="x",
            yref="paper",
            text=text,
            showarrow=False,
            xanchor="left",
            textangle=-90,
            yanchor="top",
        )
    long_name = history[variable].attrs.get("long_name", variable.replace("_", " "))
    fig.update_xaxes(title_text="generation")
    fig.update_yaxes(title_text=long_name, type="log" if log else "linear")
    fig.update_layout(title=title, template="plotly_white", showlegend=False)
    return fig


def seed_curves(curves, spread, title: str, *, shipped=None, shipped_name: str = "") -> go.Figure:
    """The hypervolume per generation of several campaigns of one problem (``curves``: a frame, generations by
    campaigns), the band between the smallest and the largest of them per generation (``spread``: a frame with
    ``min`` and ``max`` columns on the same generations), and, dashed, one more run's curve (``shipped``: a series
    by generation, named ``shipped_name``)."""
    g = np.asarray(curves.index)
    fig = go.Figure(
        [
            go.Scatter(x=g, y=spread["max"].values, mode="lines", line_width=0, showlegend=False),
            go.Scatter(
                x=g,
                y=spread["min"].values,
                mode="lines",
                line_width=0,
                fill="tonexty",
                fillcolor="rgba(100, 100, 100, 0.2)",
                name="smallest to largest",
            ),
        ]
    )
    for name in curves.columns:
        fig.add_trace(go.Scatter(x=g, y=curves[name].values, mode="lines", name=str(name)))
    if shipped is not None:
        fig.add_trace(
            go.Scatter(
                x=np.asarray(shipped.index),
                y=shipped.values,
                mode="lines",
                line={"dash": "dash", "color": "#444"},
                name=shipped_name,
            )
        )
    fig.update_xaxes(title_text="generation")
    fig.update_yaxes(title_text="hypervolume of the feasible designs so far (normalised)")
    fig.update_layout(title=title, template="plotly_white")
    return fig


def replay_scaling(table, title: str) -> go.Figure:
    """Projected wall time against workers (log-log) for each study size of a replay table
    (:func:`lnss_lib.studies.cluster_replay.replay_table`: index campaigns, workers) or of a computed schedule
    (:func:`~lnss_lib.studies.cluster_replay.simulated_table`: a line per dispatch time per batch as well), beside
    perfect scaling (its work over the workers, dashed), with each point's busy fraction as hover text."""
    fig = go.Figure()
    computed = "dispatch per batch (ms)" in table.index.names
    for size, rows in table.groupby(level="campaigns"):
        name = f"{size} campaign{'s' if size > 1 else ''}"
        lines = rows.groupby(level="dispatch per batch (ms)") if computed else [(None, rows)]
        for dispatch_ms, line in lines:
            fig.add_scatter(
                x=line.index.get_level_values("workers"),
                y=line["projected wall (min)"],
                mode="lines+markers",
                name=f"{name}: computed, {dispatch_ms:g} ms per batch"
                if computed
                else f"{name}: replay",
                text=[f"busy {b:.2f}" for b in line["busy fraction"]],
            )
        perfect = rows.groupby(level="workers")["perfect scaling (min)"].first()
        fig.add_scatter(
            x=perfect.index,
            y=perfect.values,
            mode="lines",
            line_dash="dash",
            name=f"{name}: perfect scaling",
        )
    fig.update_layout(title=title, xaxis_title="workers", yaxis_title="wall time (min)")
    fig.update_xaxes(type="log")
    fig.update_yaxes(type="log")
    return fig
