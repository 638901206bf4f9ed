"""Exceptions that carry data (skyfield's ``EphemerisRangeError`` pattern).

Callers read the attributes; messages are for people and are never parsed back.
"""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "EphemerisRangeError",
    "InfeasibleDesignError",
    "ImpactError",
    "InvalidOrbitError",
    "PropagationError",
    "SpiceError",
    "Terminated",
    "WorkerMismatchError",
]


class ConfigError(ValueError):
    """A profile, ``--set`` override or user file is invalid; ``key`` names the setting (or None)."""

    def __init__(self, message: str, *, key: str | None = None, source: str | None = None):
        super().__init__(message)
        self.key = key
        self.source = source


class EphemerisRangeError(ValueError):
    """Epochs outside the span of the loaded tables or kernels (TDB seconds past J2000)."""

    def __init__(self, message: str, *, start_tdb_s: float, end_tdb_s: float, requested_tdb_s=None):
        super().__init__(message)
        self.start_tdb_s = start_tdb_s
        self.end_tdb_s = end_tdb_s
        self.requested_tdb_s = requested_tdb_s


class InfeasibleDesignError(Exception):
    """The design is physically impossible (it hits the Moon, escapes, or is not a closed orbit).

    The only errors an evaluation turns into an infeasible design; configuration, ephemeris and
    programming errors propagate.
    """


class InvalidOrbitError(InfeasibleDesignError, ValueError):
    """Elements that are no closed orbit above the surface (e outside [0, 1), perilune inside the Moon)."""


class PropagationError(RuntimeError):
    """A compiled batch propagation did not finish: ``sats`` the satellite indices, ``statuses`` their status texts."""

    def __init__(self, message: str, *, sats: list[int], statuses: list[str]):
        super().__init__(message)
        self.sats = sats
        self.statuses = statuses


class ImpactError(InfeasibleDesignError, RuntimeError):
    """A propagated orbit went below the lunar surface plus the minimum altitude.

    ``sat`` is the satellite index (None for a single state), ``t_tdb_s`` the first sample at or
    after the impact and ``days`` the time since the start of the propagation.
    """

    def __init__(
        self,
        message: str,
        *,
        sat: int | None = None,
        t_tdb_s: float | None = None,
        days: float | None = None,
    ):
        super().__init__(message)
        self.sat = sat
        self.t_tdb_s = t_tdb_s
        self.days = days


class SpiceError(RuntimeError):
    """SPICE could not do what was ``asked`` (a damaged kernel, an unknown frame or body): ``kernels`` are
    the kernel files concerned and ``code`` SPICE's short error (e.g. ``SPICE(UNKNOWNFRAME)``). Not a
    ValueError, so it never passes for an infeasible design."""

    def __init__(self, message: str, *, asked: str, kernels: tuple[str, ...], code: str):
        super().__init__(message)
        self.asked = asked
        self.kernels = kernels
        self.code = code


class Terminated(KeyboardInterrupt):
    """SIGTERM received by the command line: handled wherever an interrupt is (a KeyboardInterrupt), exit 143."""


class WorkerMismatchError(RuntimeError):
    """A Dask worker that would not compute what this process computes: ``worker`` its address and
    ``differences`` ``{item: (the worker's value, this process's value)}`` (package versions, the processor model
    its kernels are compiled for, the workbook's sources)."""

    def __init__(self, message: str, *, worker: str, differences: dict[str, tuple[str, str]]):
        super().__init__(message)
        self.worker = worker
        self.differences = differences
