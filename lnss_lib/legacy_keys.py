"""Profiles stored before a section, a key or one key per quantity existed (run folders' ``run.json``,
the shipped results): the sections and keys they lack, read as off; the keys they spell otherwise,
moved to today's (:func:`migrate_legacy`) and back (:func:`legacy_spelling`, what
:func:`lnss_lib.config.profile_hash` fingerprints), so a stored run and today's same settings share
one fingerprint.
"""

from __future__ import annotations

import copy

from .errors import ConfigError
from .keys import NAVIGATION_ERROR_KEYS
from .profile_rules import lookup

OFF_WHEN_ABSENT = {
    "front_validation": lambda profile: profile["front_validation"].get("max_designs", 0) == 0,
    "navigation_error": lambda profile: (
        not set(profile.get("evaluator", {}).get("extra_metrics", ())) & set(NAVIGATION_ERROR_KEYS)
    ),
    "gnss": lambda profile: list(profile["gnss"].get("systems", ["gps"])) == ["gps"],
    "life_navigation": lambda profile: profile["life_navigation"].get("designs", 0) == 0,
    "robustness": lambda profile: profile["robustness"].get("draws", 0) == 0,
}
"""Sections a profile stored before they existed lacks, each with its test of being off: read as params/paper.toml's
(front validation off, ``max_designs = 0``; the navigation error unused while no metric of
:data:`~lnss_lib.keys.NAVIGATION_ERROR_KEYS` is asked for; the GPS link alone, ``[gnss] systems = ["gps"]``; notebook
08's life navigation check off, ``designs = 0``; no insertion dispersions, ``draws = 0``), and left out of the profile
hash while off, so runs and shipped results from before them keep their hash."""


KEYS_OFF_WHEN_ABSENT = {("campaign", "n_sat"): 0}
"""Keys a profile stored before they existed lacks, with the value that keeps their effect off (a campaign over
every size): read so when absent and left out of the profile hash at that value, like :data:`OFF_WHEN_ABSENT`."""


LEGACY_KEYS = {
    "stability.life_days": "stability.span_days",
    "sk_estimate.element_frame": "sk_estimate.arc_frame",
    "deltav.element_frame": "deltav.gve_frame",
    "sk_estimate.year_days": "deltav.year_days",
}
"""Keys of profiles stored before each quantity had one key (run folders' ``run.json``, the shipped results)
-> the key that holds the quantity now. The screen's span is the design life unless set apart (``span_days``,
0: ``[design_life] life_days``); the arc estimate's box and the GVEs read their elements in frames of their own,
named so, and the design's elements are ``[frames] element_frame`` alone; the year of every per-year figure is
``[deltav] year_days``. :func:`migrate_legacy` reads a stored profile in today's keys;
:func:`lnss_lib.config.profile_hash` spells a profile in the stored keys, so a stored profile and today's same
settings share one fingerprint."""
FOLLOWS = {
    "stability.span_days": "design_life.life_days"
}  # an override at 0 takes this key's value
OLD_KEYS_KEPT = {
    new for old, new in LEGACY_KEYS.items() if old.split(".")[-1] == new.split(".")[-1]
}  # one key now


def _pop(profile: dict, key: str):
    section, name = key.split(".")
    return profile.get(section, {}).pop(name, None)


def _put(profile: dict, key: str, value) -> None:
    section, name = key.split(".")
    profile.setdefault(section, {})[name] = value


def migrate_legacy(profile: dict) -> dict:
    """``profile`` (changed in place) with every key of :data:`LEGACY_KEYS` it holds moved to today's key; an
    override equal to the value it follows (:data:`FOLLOWS`) becomes 0. ConfigError when two old keys of one
    quantity disagree (a stored profile today's keys cannot spell)."""
    for old, new in LEGACY_KEYS.items():
        value = _pop(profile, old)
        if value is None:
            continue
        if new in FOLLOWS and value == lookup(profile, FOLLOWS[new]):
            value = 0.0
        kept = lookup(profile, new)
        if new in OLD_KEYS_KEPT and kept is not None and kept != value:
            raise ConfigError(
                f"stored profile: {old} = {value!r} and {new} = {kept!r} are one quantity with two "
                f"values; it cannot be read in one key",
                key=old,
            )
        _put(profile, new, value)
    return profile


def legacy_spelling(profile: dict) -> dict:
    """A copy of a complete ``profile`` in the keys of :data:`LEGACY_KEYS` (what :func:`lnss_lib.config.profile_hash` fingerprints):
    the inverse of :func:`migrate_legacy`; a profile already so spelled comes back unchanged."""
    content = copy.deepcopy(profile)
    for old, new in LEGACY_KEYS.items():
        value = lookup(content, new)
        if value is None or lookup(content, old) is not None:
            continue
        if new in FOLLOWS and value == 0:
            value = lookup(content, FOLLOWS[new])
        _put(content, old, value)
        if new not in OLD_KEYS_KEPT:
            _pop(content, new)
    return content
