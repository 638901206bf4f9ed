"""Live design explorer: sliders over the Table 3 variables, eq. 45 metrics after each change.

:class:`DesignExplorer` puts ipywidgets around :func:`lnss_lib.evaluator.analyse_constellation`: one
slider per Table 3 variable (bounds and steps from the profile's ``[campaign.variables]``), a choice
of profile, element frame and Delta-V model, and on each change (sliders report on release) the eq.
45 metrics beside the previous design's, the south-pole PDOP/HDOP availability maps (eq. 14), the
grid-mean visibility and DOP time series and the 3D constellation. Designs can be added to a
comparison table and exported as a TOML snippet plus the ``python -m lnss_lib evaluate`` command
that reproduces them. The state logic runs without a browser: tests set widget values and read
:attr:`DesignExplorer.current`.
"""

from __future__ import annotations

import html
import json
import math
import os
import shlex
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import ipywidgets as widgets
import plotly.graph_objects as go
import plotly.io as pio

from . import deltav, frames
from .atomicio import write_text_atomic
from .config import OUTPUTS_DIR, available_profiles, deep_merge, profile_path, toml_literal
from .constellation import walker_design
from .errors import ImpactError, InfeasibleDesignError
from .evaluator import EvaluationContext, analyse_constellation, context_for
from .figures import POLE_AXES, constellation_3d, dop_time_series, polar_wedges
from .keys import DESIGN_KEYS, INTEGER_DESIGN_KEYS, METRIC_KEYS, format_value, label
from .settings import StandaloneElfoSettings, VariableBounds, load_settings

ELEMENT_FRAMES = frames.ELEMENT_FRAMES
DELTAV_MODELS = deltav.MODELS

SLIDER_LABELS = {
    "sma_km": "a (km)",
    "ecc": "e",
    "aop_deg": "AOP (deg)",
    "inc_deg": "i (deg)",
    "n_planes": "planes Np",
    "sats_per_plane": "sats/plane Ns",
}
CLI_FLAGS = {
    "sma_km": "--sma-km",
    "ecc": "--ecc",
    "aop_deg": "--aop-deg",
    "inc_deg": "--inc-deg",
    "n_planes": "--planes",
    "sats_per_plane": "--sats-per-plane",
}
SETTING_KEYS = {"frame": ("frames", "element_frame"), "model": ("deltav", "model")}
FIGURES = ("availability", "time_series", "constellation")


@dataclass
class Evaluation:
    """One explored design: settings, eq. 45 metrics (NaN when infeasible) and the analysis datasets."""

    profile_name: str
    frame: str
    model: str
    design: dict
    metrics: dict
    reason: str = ""
    study: dict | None = field(default=None, repr=False)

    @property
    def feasible(self) -> bool:
        return not self.reason


def snap_to_grid(value: float, spec: VariableBounds) -> float | int:
    """``value`` on the Table 3 grid ``lower + k * step`` (eq. 43-44; ``spec`` checked at load), clipped to
    [lower, upper]."""
    lower, upper, step = float(spec.lower), float(spec.upper), float(spec.step)
    if not math.isfinite(value):
        raise ValueError(
            f"cannot snap {value!r} to the grid lower={lower}, upper={upper}, step={step}"
        )
    snapped = round(min(max(lower + round((float(value) - lower) / step) * step, lower), upper), 10)
    return int(snapped) if isinstance(spec.step, int) and isinstance(spec.lower, int) else snapped


def table4_design(elfo: StandaloneElfoSettings) -> dict:
    """The standalone ELFO (Table 4, ``settings.standalone_elfo``) as Table 3 design variables (RAAN of eq. 42 assumed)."""
    return {
        "sma_km": elfo.sma_km,
        "ecc": elfo.ecc,
        "aop_deg": elfo.aop_deg,
        "inc_deg": elfo.inc_deg,
        "n_planes": len(elfo.raan_deg),
        "sats_per_plane": elfo.sats_per_plane,
    }


def initial_design(elfo: StandaloneElfoSettings, variables: Mapping[str, VariableBounds]) -> dict:
    """The explorer's first design: the grid design nearest the standalone ELFO (Table 4), variable by variable;
    Table 4 itself where it lies on the Table 3 grid ``variables`` (:func:`start_note` says which)."""
    raw = table4_design(elfo)
    return {key: snap_to_grid(raw[key], variables[key]) for key in DESIGN_KEYS}


def start_note(elfo: StandaloneElfoSettings, variables: Mapping[str, VariableBounds]) -> str:
    """One sentence on the first design: Table 4 itself, or the nearest grid design and each variable in which
    it differs from Table 4 (a value outside Table 3's bounds said so), with both satellite counts."""
    raw, start = table4_design(elfo), initial_design(elfo, variables)
    n_table4, n_start = (
        raw["n_planes"] * raw["sats_per_plane"],
        start["n_planes"] * start["sats_per_plane"],
    )
    elfo = (
        f"the standalone ELFO (Table 4: {raw['n_planes']} planes x {raw['sats_per_plane']}, "
        f"{n_table4} satellites)"
    )
    differ = []
    for key in DESIGN_KEYS:
        if not math.isclose(start[key], raw[key], rel_tol=0.0, abs_tol=1e-9):
            spec = variables[key]
            outside = (
                f", outside this profile's Table 3 range {format_value(key, spec.lower)}-"
                f"{format_value(key, spec.upper)}"
                if not spec.lower <= raw[key] <= spec.upper
                else ""
            )
            differ.append(
                f"{label(key)} {format_value(key, start[key])} (Table 4: {format_value(key, raw[key])}{outside})"
            )
    if not differ:
        return f"First design: {elfo}, which lies on this profile's grid."
    return (
        f"First design: the grid design nearest {elfo}, NOT Table 4 itself: {'; '.join(differ)}; "
        f"{n_start} satellites instead of {n_table4}. Notebook 05 evaluates Table 4 itself."
    )


def served_by_voila() -> bool:
    """True in a kernel that voila started for a page (voila sets ``SERVER_SOFTWARE=voila/<version>``)."""
    return os.environ.get("SERVER_SOFTWARE", "").startswith("voila/")


def availability_polar_maps(dop_ds, threshold: float, *, title: str) -> go.Figure:
    """PDOP and HDOP availability (%, eq. 14: DOP < threshold, no DOP = unavailable) per south-pole node.

    Radius: latitude (labelled); angle: Moon-fixed longitude. Fixed 0-100 % colour
    scale, so successive designs compare by colour.
    """
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=1,
        cols=2,
        specs=[[{"type": "polar"}] * 2],
        subplot_titles=[f"PDOP < {threshold:g} (% of time)", f"HDOP < {threshold:g} (% of time)"],
    )
    for col, name in enumerate(("pdop", "hdop"), start=1):
        pct = 100.0 * (dop_ds[name] < threshold).mean("time").values
        fig.add_trace(
            polar_wedges(
                pct, dop_ds["lat"].values, dop_ds["lon"].values, name.upper(), "coloraxis"
            ),
            row=1,
            col=col,
        )
    fig.update_polars(**POLE_AXES)
    fig.update_layout(
        title=title,
        height=430,
        showlegend=False,
        template="plotly_white",
        coloraxis={
            "colorscale": "Viridis",
            "cmin": 0.0,
            "cmax": 100.0,
            "colorbar": {"title": "%", "thickness": 12},
        },
    )
    return fig


def _plotly_output(fig: go.Figure) -> dict:
    """A display_data output carrying the figure as plotly's mimetype (rendered by jupyterlab-plotly, offline)."""
    return {
        "output_type": "display_data",
        "metadata": {},
        "data": {
            "application/vnd.plotly.v1+json": json.loads(pio.to_json(fig, validate=False)),
            "text/plain": f"<plotly figure: {fig.layout.title.text}>",
        },
    }


def _fmt(value, key: str = "") -> str:
    """A table cell: a number in the format of its quantity (:func:`lnss_lib.keys.format_value`), NaN as a dash."""
    if isinstance(value, float) and math.isnan(value):
        return "&ndash;"
    return html.escape(format_value(key, value))


def _flatten(values, prefix: str = "") -> list[tuple[str, object]]:
    """``[("key.sub", value), ...]`` of a nested overrides table."""
    if not isinstance(values, Mapping):
        return [(prefix, values)]
    return [
        item
        for key, value in values.items()
        for item in _flatten(value, f"{prefix}.{key}" if prefix else key)
    ]


def _lookup(table: dict, dotted: str):
    for part in dotted.split("."):
        table = table.get(part) if isinstance(table, Mapping) else None
    return table


class DesignExplorer:
    """Widgets and state of the explorer; :attr:`widget` is what a notebook displays.

    ``start_text`` says what the first design is (:func:`start_note`); ``current`` and ``previous`` are
    :class:`Evaluation` records; ``comparison`` the rows added with
    the "add to comparison" button; ``figures`` the plotly figures of the current design.
    Evaluation contexts are cached per (profile, element frame, Delta-V model); ``overrides`` (a nested
    dict or its JSON, as ``reproduce --set`` passes them) apply to every profile the explorer loads.
    """

    def __init__(
        self,
        profile_name: str = "quick",
        *,
        design: dict | None = None,
        frame: str | None = None,
        model: str | None = None,
        outputs_dir: Path | str | None = None,
        overrides: dict | str | None = None,
    ):
        self.overrides = (
            json.loads(overrides) if isinstance(overrides, str) else dict(overrides or {})
        )
        self.outputs_dir = Path(outputs_dir) if outputs_dir is not None else OUTPUTS_DIR
        self._contexts: dict[tuple[str, str, str], EvaluationContext] = {}
        self._holding = False
        self.current: Evaluation | None = None
        self.previous: Evaluation | None = None
        self.comparison: list[dict] = []
        self.figures: dict[str, go.Figure] = {}
        self.profile = load_settings(profile_name, overrides=self.overrides)
        style = {"description_width": "110px"}
        choices = available_profiles() + (
            [] if profile_name in available_profiles() else [profile_name]
        )
        self.profile_choice = widgets.Dropdown(
            options=choices, value=profile_name, description="profile", style=style
        )
        self.frame_choice = widgets.Dropdown(
            options=ELEMENT_FRAMES,
            description="element frame",
            style=style,
            value=frame or self.profile.frames.element_frame,
        )
        self.model_choice = widgets.Dropdown(
            options=DELTAV_MODELS,
            description="Delta-V model",
            style=style,
            value=model or self.profile.deltav.model,
        )
        self.sliders: dict[str, widgets.Widget] = {}
        for key in DESIGN_KEYS:
            cls = widgets.IntSlider if key in INTEGER_DESIGN_KEYS else widgets.FloatSlider
            self.sliders[key] = cls(
                description=SLIDER_LABELS[key],
                continuous_update=False,
                style=style,
                layout={"width": "420px"},
            )
        self._configure_sliders(
            design or initial_design(self.profile.standalone_elfo, self.profile.campaign.variables)
        )
        self.start_text = (
            start_note(self.profile.standalone_elfo, self.profile.campaign.variables)
            if design is None
            else "First design: the one the explorer was given."
        )
        self.start_html = widgets.HTML(
            f"<div style='max-width:640px'>{html.escape(self.start_text)}</div>"
        )
        self.status = widgets.HTML()
        self.metrics_html = widgets.HTML()
        self.comparison_html = widgets.HTML()
        self.export_text = widgets.Textarea(layout={"width": "100%", "height": "260px"})
        self.write_export = widgets.Checkbox(
            value=False, description="also write a file in outputs/"
        )
        self.add_button = widgets.Button(description="add to comparison", icon="plus")
        self.export_button = widgets.Button(description="export design", icon="download")
        self.outputs = {name: widgets.Output() for name in FIGURES}
        for control in (*self.sliders.values(), self.frame_choice, self.model_choice):
            control.observe(self.refresh, names="value")
        self.profile_choice.observe(self._on_profile, names="value")
        self.add_button.on_click(self.add_to_comparison)
        self.export_button.on_click(lambda _: self.export(write=self.write_export.value))
        self.refresh()

    # ---- state ---------------------------------------------------------------------------------
    def _configure_sliders(self, design: dict) -> None:
        variables = self.profile.campaign.variables
        self._holding = True
        try:
            for key, slider in self.sliders.items():
                spec = variables[key]
                slider.min, slider.max = min(spec.lower, slider.min), max(spec.upper, slider.max)
                slider.step = spec.step
                slider.value = snap_to_grid(design[key], spec)
                slider.min, slider.max = spec.lower, spec.upper
                if isinstance(slider, widgets.FloatSlider):
                    slider.readout_format = ".2f" if spec.step < 1 else ".0f"
        finally:
            self._holding = False

    def design(self) -> dict:
        """The slider values on the profile's Table 3 grid, keyed as :data:`lnss_lib.keys.DESIGN_KEYS`."""
        variables = self.profile.campaign.variables
        return {key: snap_to_grid(self.sliders[key].value, variables[key]) for key in DESIGN_KEYS}

    def settings(self) -> dict:
        """Profile overrides of the chosen element frame and Delta-V model (``{"frames": ..., "deltav": ...}``)."""
        out: dict = {}
        for name, control in (("frame", self.frame_choice), ("model", self.model_choice)):
            section, key = SETTING_KEYS[name]
            out.setdefault(section, {})[key] = control.value
        return out

    def context(self) -> EvaluationContext:
        """The cached :class:`EvaluationContext` of the chosen (profile, element frame, Delta-V model)."""
        key = (self.profile_choice.value, self.frame_choice.value, self.model_choice.value)
        if key not in self._contexts:
            self._contexts[key] = context_for(
                load_settings(key[0], overrides=deep_merge(self.overrides, self.settings()))
            )
        return self._contexts[key]

    def evaluate(self) -> Evaluation:
        """Eq. 45 for the current widgets; an invalid design or an impact comes back with its reason.

        Any other exception is an error and propagates.
        """
        context, design = self.context(), self.design()
        record = Evaluation(
            self.profile_choice.value,
            self.frame_choice.value,
            self.model_choice.value,
            design,
            {key: math.nan for key in METRIC_KEYS},
        )
        try:
            elements = walker_design(
                context.dynamics,
                design["sma_km"],
                design["ecc"],
                design["aop_deg"],
                design["inc_deg"],
                design["n_planes"],
                design["sats_per_plane"],
            ).elements_deg()
        except (
            InfeasibleDesignError
        ) as error:  # no closed orbit above the surface; other errors propagate
            record.metrics["n_sat"] = design["n_planes"] * design["sats_per_plane"]
            return replace(record, reason=f"invalid design: {error}")
        try:
            study = analyse_constellation(context, elements)
        except ImpactError as error:
            record.metrics["n_sat"] = len(elements)
            return replace(record, reason=str(error))
        return replace(record, metrics=study["metrics"], study=study)

    def refresh(self, change=None) -> None:
        """Evaluate the widgets' design and update metrics, status and figures (widget callback)."""
        if self._holding:
            return
        try:
            evaluation = self.evaluate()
        except (
            Exception
        ) as error:  # shown in the page: a widget callback has nowhere else to report
            self.status.value = (
                f"<div style='color:#a00'><b>error</b> (not an infeasible design): "
                f"{html.escape(type(error).__name__)}: {html.escape(str(error))}</div>"
            )
            raise
        self.previous, self.current = self.current, evaluation
        self._render()

    def _on_profile(self, change) -> None:
        """A new profile brings its own element frame and Delta-V model (``operational`` reads ``moon_op``)."""
        design = self.design()
        self.profile = load_settings(change["new"], overrides=self.overrides)
        for control, value in (
            (self.frame_choice, self.profile.frames.element_frame),
            (self.model_choice, self.profile.deltav.model),
        ):
            control.unobserve(self.refresh, names="value")
            control.value = value
            control.observe(self.refresh, names="value")
        self._configure_sliders(design)
        self.refresh()

    def add_to_comparison(self, _=None) -> dict:
        """Append the current design, settings and metrics to :attr:`comparison`; returns the row."""
        row = {
            "profile": self.current.profile_name,
            "frame": self.current.frame,
            "model": self.current.model,
            **self.current.design,
            **{k: self.current.metrics[k] for k in METRIC_KEYS},
            "reason": self.current.reason,
        }
        self.comparison.append(row)
        self._render_comparison()
        return row

    def export(self, write: bool = False) -> dict:
        """TOML snippet and ``python -m lnss_lib evaluate`` command of the current design.

        Returns ``{"toml", "argv", "command", "path"}``: ``argv`` is what
        :func:`lnss_lib.__main__.build_parser` parses; settings that differ from the profile's are
        passed as ``--set SECTION.KEY=VALUE``. With ``write`` the snippet also goes to
        ``outputs/<profile>/explorer/<name>.toml`` (written atomically); ``path`` is None otherwise.
        """
        design, name = self.design(), self.profile_choice.value
        base = load_settings(name).as_dict()
        argv = (
            ["evaluate", "--profile", name]
            if name in available_profiles()
            else ["evaluate", "--profile-file", str(profile_path(name))]
        )  # a reproduce --profile-file run
        for key in DESIGN_KEYS:
            argv += [CLI_FLAGS[key], str(design[key])]
        for section, values in deep_merge(self.overrides, self.settings()).items():
            for key, value in _flatten(values):
                if _lookup(base[section], key) != value:
                    argv += ["--set", f"{section}.{key}={toml_literal(value)}"]
        command = "python -m lnss_lib " + shlex.join(argv)
        lines = [
            f"# LNSS design explorer: Walker design (Table 3 variables, RAAN by eq. 42), profile {name!r}",
            f"# reproduce: {command}",
            "[design]",
        ]
        lines += [f"{key} = {toml_literal(design[key])}" for key in DESIGN_KEYS]
        for section, values in self.settings().items():
            lines += ["", f"[{section}]", *(f"{k} = {toml_literal(v)}" for k, v in values.items())]
        toml_text = "\n".join(lines) + "\n"
        path = None
        if write:
            stem = "design_" + "_".join(f"{design[k]:g}" for k in DESIGN_KEYS).replace(".", "p")
            path = (
                self.outputs_dir
                / name
                / "explorer"
                / f"{stem}_{self.frame_choice.value}_{self.model_choice.value}.toml"
            )
            path.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomic(path, toml_text)
        self.export_text.value = toml_text + (f"\n# written to {path}\n" if path else "")
        return {"toml": toml_text, "argv": argv, "command": command, "path": path}

    # ---- views ---------------------------------------------------------------------------------
    def metrics_rows(self) -> list[dict]:
        """Rows (metric, label, current, previous, delta) of the metrics table."""
        prev = self.previous.metrics if self.previous else {}
        rows = []
        for key in METRIC_KEYS:
            now, before = self.current.metrics[key], prev.get(key, math.nan)
            rows.append(
                {
                    "metric": key,
                    "label": label(key),
                    "current": now,
                    "previous": before,
                    "delta": float(now - before),
                }
            )
        return rows

    def _render(self) -> None:
        cur = self.current
        where = f"{html.escape(cur.profile_name)} profile, {html.escape(cur.frame)} elements, {html.escape(cur.model)} Delta-V"
        if cur.feasible:
            wall = cur.metrics.get("wall_s", math.nan)
            self.status.value = (
                f"<div style='color:#060'><b>feasible</b>: {where}; evaluated in {wall:.2f} s</div>"
            )
        else:
            self.status.value = (
                f"<div style='color:#a00'><b>infeasible</b> ({where}): "
                f"{html.escape(cur.reason)}</div>"
            )
        body = "".join(
            f"<tr><td>{html.escape(r['label'])}</td><td>{_fmt(r['current'], r['metric'])}</td>"
            f"<td>{_fmt(r['previous'], r['metric'])}</td><td>{_fmt(r['delta'], r['metric'])}</td></tr>"
            for r in self.metrics_rows()
        )
        self.metrics_html.value = (
            "<table class='lnss-explorer-metrics' style='border-collapse:collapse' border='1' "
            "cellpadding='4'><tr><th>eq. 45 metric</th><th>this design</th>"
            f"<th>previous design</th><th>change</th></tr>{body}</table>"
        )
        self.figures = {}
        if cur.study is not None:
            profile, study = self.context().settings, cur.study
            design = ", ".join(f"{SLIDER_LABELS[k]} {v:g}" for k, v in cur.design.items())
            self.figures = {
                "availability": availability_polar_maps(
                    study["dop"],
                    profile.dop.availability_threshold,
                    title=f"South-pole DOP availability: {design}",
                ),
                "time_series": dop_time_series(
                    study["dop"], title="Grid-mean visibility, PDOP and HDOP"
                ),
                "constellation": constellation_3d(
                    study["propagation"],
                    title="Constellation (Moon-centred J2000)",
                    moon_radius_km=profile.constants.r_moon_mean_km,
                ),
            }
        for name, out in self.outputs.items():
            out.outputs = (_plotly_output(self.figures[name]),) if name in self.figures else ()

    def _render_comparison(self) -> None:
        if not self.comparison:
            self.comparison_html.value = ""
            return
        columns = list(self.comparison[0])
        head = "".join(
            f"<th title='{html.escape(c)}'>{html.escape(label(c))}</th>" for c in columns
        )
        body = "".join(
            "<tr>" + "".join(f"<td>{_fmt(row[c], c)}</td>" for c in columns) + "</tr>"
            for row in self.comparison
        )
        self.comparison_html.value = (
            f"<div style='overflow-x:auto'><table class='lnss-explorer-comparison' border='1' "
            f"cellpadding='3' style='border-collapse:collapse;font-size:90%'><tr>{head}</tr>"
            f"{body}</table></div>"
        )

    @property
    def widget(self) -> widgets.Widget:
        """The assembled explorer: controls beside status and metrics, then the figures, comparison and export."""
        controls = widgets.VBox(
            [
                self.profile_choice,
                self.frame_choice,
                self.model_choice,
                *self.sliders.values(),
                widgets.HBox([self.add_button, self.export_button]),
                self.write_export,
            ]
        )
        return widgets.VBox(
            [
                widgets.HBox(
                    [controls, widgets.VBox([self.start_html, self.status, self.metrics_html])]
                ),
                *(self.outputs[name] for name in FIGURES),
                widgets.HTML("<b>comparison</b>"),
                self.comparison_html,
                widgets.HTML("<b>export</b>"),
                self.export_text,
            ]
        )
