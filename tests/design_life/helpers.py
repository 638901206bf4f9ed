"""The closed loop flown from settings, as the tests call it."""

from lnss_lib.design_life.closed_loop import life_force_model, simulate_life
from lnss_lib.ephemeris import ensure_kernels, tdb_seconds
from lnss_lib.settings import load_settings


def fly(settings, elements_deg, **kwargs):
    """:func:`simulate_life` of ``elements_deg`` from the settings' epoch with their sections (``kwargs``: life_days,
    natural, model, sample_step_s, ...; ``design_life`` replaces the settings' section)."""
    design_life = kwargs.pop("design_life", settings.design_life)
    t0 = kwargs.pop("t0_tdb_s", None)
    t0 = tdb_seconds(settings.epoch.start_tdb, "TDB") if t0 is None else t0
    return simulate_life(
        design_life,
        settings.dynamics,
        elements_deg,
        t0,
        stability=settings.stability,
        dop=settings.dop,
        **kwargs,
    )


def paper_degree8():
    """The paper profile with the lunar field cut to degree 8 (kernels loaded): the controller tests' settings."""
    prof = load_settings("paper", overrides={"gravity": {"degree": 8}})
    ensure_kernels(prof.ephemeris)
    return prof


def model_from_epoch(settings, days: float):
    """A life force model from the settings' epoch spanning ``days``."""
    return life_force_model(settings.dynamics, tdb_seconds(settings.epoch.start_tdb, "TDB"), days)
