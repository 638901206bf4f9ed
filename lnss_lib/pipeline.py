"""Orchestration: output folders, run manifests, and headless notebook execution (papermill)."""

from __future__ import annotations

from pathlib import Path

from .config import OUTPUTS_DIR


def output_dir(profile_name: str, kind: str) -> Path:
    """``outputs/<profile>/<kind>/`` (created): kind is notebooks, figures, tables, data or campaign."""
    allowed = ("notebooks", "figures", "tables", "data", "campaign")
    if kind not in allowed:
        raise ValueError(f"unknown output kind {kind!r}; allowed: {', '.join(allowed)}")
    folder = OUTPUTS_DIR / profile_name / kind
    folder.mkdir(parents=True, exist_ok=True)
    return folder
