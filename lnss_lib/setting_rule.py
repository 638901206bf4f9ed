"""How a setting declares its rule: :func:`setting` puts a :class:`Rule` (range, allowed values, form,
reason) in a dataclass field's metadata, :func:`derived` marks a field that has no key of its own,
and :func:`rule_of` reads the rule back. The section classes of :mod:`lnss_lib.sections` are written
with these; :mod:`lnss_lib.profile_rules` checks a profile against them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Rule:
    """What a setting allows. ``range``: ``(low, high, low open, high open)``, None unbounded, each entry of a list;
    ``choices``: the allowed texts (each entry of a list); ``form``: the name of an open form checked by
    :data:`lnss_lib.config.FORMS`; ``why``: the reason a range has, quoted in the message."""

    range: tuple | None = None
    choices: tuple[str, ...] | None = None
    form: str | None = None
    why: str = ""
    infinite_ok: bool = False  # -inf or inf is a value (a side lobe off)
    non_empty: bool = False  # a list that needs an entry
    names_integrator_setting: bool = False  # a name of [integrator.settings.*]
    pair: bool = False  # [low, high] with low < high
    free: bool = False  # a table of any keys (finite numbers; the campaign's checked apart)
    sections: bool = False  # a table of profile sections (campaign.overrides)
    derived: bool | tuple[str, ...] = (
        False  # no key: the value of the one key of its quantity (derived())
    )
    file_only: bool = False  # a key of a profile file, resolved when the files are merged
    # read by the campaign's life estimate: in the evaluation hash of evaluations that run it
    life_estimate: bool = False


NO_RULE = Rule()


def setting(**rule) -> Any:
    """A field whose :class:`Rule` is ``rule`` (keywords of :class:`Rule`)."""
    return field(metadata={"rule": Rule(**rule)})


def derived(default, of: tuple[str, ...] = ()) -> Any:
    """A field with no key of its own: the loader sets it to the first of the dotted keys ``of`` whose value is
    not 0 (none: its section's code fills it in), so a kernel reads the quantity in the one section it takes."""
    return field(default=default, metadata={"rule": Rule(derived=of or True)})


def rule_of(item) -> Rule:
    """The :class:`Rule` of a dataclass field (:data:`NO_RULE` when it has none)."""
    return item.metadata.get("rule", NO_RULE)


def allowed_range_text(spec: tuple) -> str:
    """``(0, inf)``-style text of a range ``(low, high, low open, high open)``."""
    low, high, low_open, high_open = spec
    left = "(-inf" if low is None else f"{'(' if low_open else '['}{low:g}"
    right = "inf)" if high is None else f"{high:g}{')' if high_open else ']'}"
    return f"{left}, {right}"


def in_range(value: float, spec: tuple) -> bool:
    low, high, low_open, high_open = spec
    return (low is None or (value > low if low_open else value >= low)) and (
        high is None or (value < high if high_open else value <= high)
    )
