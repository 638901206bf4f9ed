"""Run profiles: TOML files in ``params/`` merged along their ``inherits`` chain.

A profile is a plain nested ``dict``; :func:`load_profile` returns it with the chain resolved and
``profile.name`` set. :func:`profile_hash` fingerprints everything that can change a result, so
caches and manifests can tell runs apart. Data paths in a profile are relative to ``params/``.
"""

from __future__ import annotations

import copy
import hashlib
import json
import platform
import tomllib
from importlib import metadata
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
PROJECT_DIR = PACKAGE_DIR.parent
PARAMS_DIR = PROJECT_DIR / "params"
OUTPUTS_DIR = PROJECT_DIR / "outputs"


def available_profiles() -> list[str]:
    """Names of the profiles in ``params/`` (one ``NAME.toml`` each)."""
    return sorted(p.stem for p in PARAMS_DIR.glob("*.toml"))


def deep_merge(base: dict, override: dict) -> dict:
    """A copy of ``base`` with the nested ``override`` applied."""
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def load_profile(name: str = "quick", overrides: dict | None = None) -> dict:
    """Load profile ``name`` from ``params/NAME.toml``, resolving ``inherits``, then apply ``overrides``.

    Raises ``ValueError`` naming the unknown profile and the available ones.
    """
    chain: list[dict] = []
    seen: set[str] = set()
    current: str | None = name
    while current is not None:
        path = PARAMS_DIR / f"{current}.toml"
        if not path.is_file():
            raise ValueError(
                f"unknown profile {current!r}: expected {path}; available profiles: "
                f"{', '.join(available_profiles())}"
            )
        if current in seen:
            raise ValueError(f"profile {name!r} has an inheritance cycle through {current!r}")
        seen.add(current)
        with path.open("rb") as handle:
            data = tomllib.load(handle)
        chain.append(data)
        current = data.get("profile", {}).get("inherits")
    profile: dict = {}
    for data in reversed(chain):
        profile = deep_merge(profile, data)
    profile = deep_merge(profile, overrides or {})
    profile["profile"]["name"] = name
    profile["profile"].pop("inherits", None)
    return profile


def data_path(relative: str) -> Path:
    """Absolute path of a data file named relative to ``params/``."""
    return PARAMS_DIR / relative


def profile_hash(profile: dict) -> str:
    """SHA-256 (16 hex digits) of a profile's canonical JSON, excluding its name and description."""
    content = copy.deepcopy(profile)
    content.get("profile", {}).pop("name", None)
    content.get("profile", {}).pop("description", None)
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def integrator_setting(profile: dict, setting: str | None = None) -> dict:
    """The integrator settings (method, rtol, atol) named ``setting`` (default: the profile's)."""
    settings = profile["integrator"]["settings"]
    name = setting or profile["integrator"]["setting"]
    if name not in settings:
        raise ValueError(f"unknown integrator setting {name!r}; available: {', '.join(settings)}")
    return {"name": name, **settings[name]}



MANIFEST_PACKAGES = ("numpy", "scipy", "spiceypy", "sgp4", "numba", "xarray", "pymoo", "plotly", "dask",
                     "distributed", "papermill", "skyfield-data", "h5netcdf", "pandas")


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
    versions = {"python": platform.python_version()}
    for name in MANIFEST_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions
