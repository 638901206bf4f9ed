"""Compiled kernels never come from a cache of other sources (numba checks a function against its own file only)."""

import os
import shutil
import subprocess
import sys

import numba.core.config

import lnss_lib
from lnss_lib import kernel_cache_dir, source_digest


def test_cache_folder_is_keyed_by_every_source(tmp_path):
    root = tmp_path / "pkg"
    shutil.copytree(os.path.dirname(lnss_lib.__file__), root, ignore=shutil.ignore_patterns("__pycache__"))
    before = source_digest(root)
    gravity = root / "gravity.py"
    gravity.write_text(gravity.read_text() + "\n# a change in a module that others inline\n")
    assert source_digest(root) != before
    assert before == source_digest(__import__("pathlib").Path(lnss_lib.__file__).parent)


def test_this_process_and_its_children_use_the_keyed_folder():
    keyed = os.environ["NUMBA_CACHE_DIR"]
    assert keyed == kernel_cache_dir() and os.path.basename(keyed) == source_digest(
        __import__("pathlib").Path(lnss_lib.__file__).parent)
    assert numba.core.config.CACHE_DIR == keyed
    child = subprocess.run([sys.executable, "-c", "import lnss_lib, os; print(os.environ['NUMBA_CACHE_DIR'])"],
                           capture_output=True, text=True, check=True, env=os.environ.copy())
    assert child.stdout.strip() == keyed                 # inherited parent, keyed once, not nested
