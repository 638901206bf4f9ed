"""The workbook's own tree at a past commit, for benchmarks that time a previous path beside
today's.

A benchmark's "before" is the code of a recorded commit, read from git (``git archive``) rather than
a copy kept in the package: :func:`extract_tree` writes a commit's tree into a folder;
:func:`cached_tree` keeps it under ``~/.cache/lnss_lib/tree/<commit>`` so that the compiled kernels
numba caches beside its sources are reused by the next run. Both raise RuntimeError, naming what is
missing, in a copy without git or without that commit (a clone with its history has it).
"""

from __future__ import annotations

import io
import os
import shutil
import subprocess
import tarfile
import tempfile
from pathlib import Path

from ..config import PROJECT_DIR
from ..provenance import GIT_DIRS

__all__ = ["extract_tree", "cached_tree"]

CACHE_DIR = Path.home() / ".cache" / "lnss_lib" / "tree"


def extract_tree(commit: str, folder: Path, what: str) -> None:
    """The workbook's tree at ``commit`` written into ``folder``; ``what`` (e.g. "the force model
    before its speed work") names the code the commit holds in the RuntimeError raised when git or
    the commit is not there."""
    executable = shutil.which("git", path=os.pathsep.join(GIT_DIRS))
    if executable is None:
        raise RuntimeError(f"{what} is commit {commit[:12]}, and git is not installed")
    env = {key: value for key, value in os.environ.items() if not key.startswith("GIT_")}
    done = subprocess.run(
        [executable, "archive", "--format=tar", commit],
        cwd=PROJECT_DIR,
        capture_output=True,
        env=env,
        timeout=300,
    )
    if done.returncode != 0:
        raise RuntimeError(
            f"{what} is commit {commit[:12]}, which this copy of the workbook does not hold "
            f"(a clone with its history does): {done.stderr.decode()[:200]}"
        )
    with tarfile.open(fileobj=io.BytesIO(done.stdout)) as archive:
        archive.extractall(folder, filter="data")


def cached_tree(commit: str, what: str) -> Path:
    """The folder holding the workbook's tree at ``commit`` (extracted once, then reused)."""
    tree = CACHE_DIR / commit
    if not (tree / "lnss_lib" / "__init__.py").is_file():
        CACHE_DIR.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=CACHE_DIR, prefix=f"{commit[:12]}-") as scratch:
            extract_tree(commit, Path(scratch), what)
            shutil.rmtree(tree, ignore_errors=True)
            os.replace(scratch, tree)
            Path(scratch).mkdir()  # for the context manager's own clean-up
    return tree
