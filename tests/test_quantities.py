"""One key per physical quantity, and profiles stored before that still read (and fingerprint) as they did.

:data:`SAME_QUANTITY` lists, in one place, the keys a merged profile could hold for one physical quantity; a
profile holding two of one group fails. A study that needs another value of a quantity sets an override named
for what it is (``[stability] span_days``, ``[sk_estimate] arc_frame``, ``[deltav] gve_frame``), never a second
key of the same name.
"""

from __future__ import annotations

import copy

import pytest

from lnss_lib import config, legacy_keys
from lnss_lib.campaign.reference import load_reference
from lnss_lib.campaign.settings import evaluation_hash, run_differences
from lnss_lib.errors import ConfigError
from lnss_lib.settings import load_settings, settings_from_profile

SAME_QUANTITY = {
    "design life": ("design_life.life_days", "stability.life_days"),
    "element frame of the design": (
        "frames.element_frame",
        "sk_estimate.element_frame",
        "deltav.element_frame",
    ),
    "days of a year of per-year figures": ("deltav.year_days", "sk_estimate.year_days"),
}


def _keys(table: dict, prefix: str = "") -> set[str]:
    keys = set()
    for name, value in table.items():
        keys.add(f"{prefix}{name}")
        if isinstance(value, dict):
            keys |= _keys(value, f"{prefix}{name}.")
    return keys


@pytest.mark.parametrize("name", config.available_profiles())
def test_one_key_per_quantity(name):
    keys = _keys(load_settings(name).as_dict())
    doubled = {
        quantity: sorted(keys & set(group))
        for quantity, group in SAME_QUANTITY.items()
        if len(keys & set(group)) > 1
    }
    assert not doubled, doubled


def test_every_legacy_key_is_a_quantity_of_the_list():
    """Each key the migration retires was a second key of a listed quantity or is renamed for what it is."""
    listed = {key for group in SAME_QUANTITY.values() for key in group}
    assert set(legacy_keys.LEGACY_KEYS) <= listed


def test_the_derived_fields_read_the_one_key():
    operational, paper = load_settings("operational"), load_settings("paper")
    assert operational.stability.life_days == operational.design_life.life_days == 1826.25
    assert (
        paper.stability.life_days
        == paper.stability.span_days
        == 365.25
        != paper.design_life.life_days
    )
    assert paper.sk_estimate.year_days == paper.deltav.year_days
    longer = load_settings(
        "ci", overrides={"deltav": {"year_days": 366.0}, "stability": {"span_days": 0.0}}
    )
    assert (
        longer.sk_estimate.year_days == 366.0
        and longer.stability.life_days == longer.design_life.life_days
    )


@pytest.mark.parametrize("name", ["paper", "paper_dv_physical"])
def test_shipped_results_keep_their_fingerprints(name):
    """The shipped campaigns stored their profiles in the old keys: read today, they are today's profiles but for
    the stability screen (validated since; their 10-day evaluations never ran it), with the profile hash they were
    published with and today's evaluation hash."""
    reference = load_reference(name)
    stored, current = reference.profile, load_settings(name)
    assert (
        "life_days" in stored["stability"] and "element_frame" in stored["sk_estimate"]
    )  # the old keys
    assert config.profile_hash(stored) == reference.history.attrs["profile_hash"] != current.hash
    assert evaluation_hash(stored) == evaluation_hash(current)
    read, today = settings_from_profile(stored).as_dict(), current.as_dict()
    assert read["stability"] != today["stability"]
    assert {**read, "stability": today["stability"]} == today
    assert run_differences(stored, current) == []
    migrated = legacy_keys.migrate_legacy(config.with_absent_sections(copy.deepcopy(stored)))
    assert legacy_keys.legacy_spelling(migrated) == config.with_absent_sections(
        copy.deepcopy(stored)
    )
    assert {**migrated, "stability": current.as_dict()["stability"]} == current.as_dict()


def test_an_old_key_in_a_profile_file_names_its_new_key():
    with pytest.raises(ConfigError, match="stability.span_days"):
        load_settings("ci", overrides={"stability": {"life_days": 30.0}})


def test_a_stored_profile_with_two_values_of_one_quantity_is_refused():
    stored = legacy_keys.legacy_spelling(load_settings("paper").as_dict())
    stored["sk_estimate"]["year_days"] = 365.0
    with pytest.raises(ConfigError, match="one quantity with two values"):
        settings_from_profile(stored)
