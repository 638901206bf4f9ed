"""Compiled kernels never come from a cache of other sources (numba checks a function against its own file only), and
are compiled for one named processor wherever it can run (the same bits on every machine)."""

import os
import shutil
import subprocess
import sys

import numba.core.config
import pytest

import lnss_lib
from lnss_lib import kernel_cache_dir, source_digest


def test_cache_folder_is_keyed_by_every_source(tmp_path):
    root = tmp_path / "pkg"
    shutil.copytree(
        os.path.dirname(lnss_lib.__file__), root, ignore=shutil.ignore_patterns("__pycache__")
    )
    before = source_digest(root)
    gravity = root / "gravity.py"
    gravity.write_text(gravity.read_text() + "\n# a change in a module that others inline\n")
    assert source_digest(root) != before
    assert before == source_digest(__import__("pathlib").Path(lnss_lib.__file__).parent)


def test_this_process_and_its_children_use_the_keyed_folder():
    keyed = os.environ["NUMBA_CACHE_DIR"]
    assert keyed == kernel_cache_dir() and os.path.basename(keyed) == source_digest(
        __import__("pathlib").Path(lnss_lib.__file__).parent
    )
    assert numba.core.config.CACHE_DIR == keyed
    child = subprocess.run(
        [sys.executable, "-c", "import lnss_lib, os; print(os.environ['NUMBA_CACHE_DIR'])"],
        capture_output=True,
        text=True,
        check=True,
        env=os.environ.copy(),
    )
    assert child.stdout.strip() == keyed  # inherited parent, keyed once, not nested


def test_kernels_loaded_from_the_cache_give_the_bits_of_a_fresh_compile(fresh_compile):
    """A campaign's designs are evaluated by worker processes that load the kernels from numba's cache, a fresh
    clone compiles them: both must give the same bits (with the full fastmath set in the gravity kernels they did
    not: these 16 satellites, the Table 3 designs where it showed, drifted apart by up to 3e-5 relative in 10 days).
    The fresh compile is the suite's kernel warm-up when it found the cache empty (conftest.py), else a child that
    compiled into a cache folder of its own; a second child loads from that cache."""
    fresh = fresh_compile.record
    loaded = fresh_compile.loaded()
    assert fresh["compiled"] and not fresh["loaded"]  # every kernel it ran compiled from source
    assert loaded["propagator_loaded"]  # the integrator from the cache
    assert len(fresh["digests"]) == 2 and fresh["digests"] == loaded["digests"]


def test_kernels_are_compiled_for_one_named_processor_where_it_can_run():
    """The pins and the shipped campaigns hold the bits of kernels compiled for ``KERNEL_CPU``: compiled for the host
    processor instead (numba's default) an AMD Zen 4 gave the shipped population's DOP up to 2e-7 apart."""
    from numba.core.registry import cpu_target

    name = lnss_lib.kernel_cpu()
    if name.startswith("host:"):
        assert numba.core.config.CPU_NAME is None
        return
    assert numba.core.config.CPU_NAME == name and os.environ["NUMBA_CPU_NAME"] == name
    assert (
        cpu_target.target_context.codegen().magic_tuple()[1] == name
    )  # numba's cache is keyed by it too
    child = subprocess.run(
        [sys.executable, "-c", "import lnss_lib, numba.core.config as c; print(c.CPU_NAME)"],
        capture_output=True,
        text=True,
        check=True,
        env=os.environ.copy(),
    )
    assert child.stdout.strip() == name
    bare = {
        k: v for k, v in os.environ.items() if k not in ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES")
    }
    numba_first = subprocess.run(
        [
            sys.executable,
            "-c",
            "import numba.core.config as c; import lnss_lib; "
            "print(c.CPU_NAME, repr(c.CPU_FEATURES))",
        ],
        capture_output=True,
        text=True,
        check=True,
        env=bare,
    )  # a notebook that imported numba
    assert numba_first.stdout.split() == [name, "''"]


def test_a_processor_without_the_named_models_features_compiles_for_itself(monkeypatch):
    import llvmlite.binding as llvm

    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    everything = {name: True for name in lnss_lib.KERNEL_CPU_NEEDS}
    monkeypatch.setattr(llvm, "get_host_cpu_features", lambda: everything)
    assert lnss_lib.kernel_cpu() == lnss_lib.KERNEL_CPU
    monkeypatch.setattr(llvm, "get_host_cpu_features", lambda: {**everything, "avx512bw": False})
    assert lnss_lib.kernel_cpu() == f"host:{llvm.get_host_cpu_name()}"
    monkeypatch.setenv("NUMBA_CPU_NAME", "znver4")
    assert lnss_lib.kernel_cpu() == "znver4"


def test_a_processor_model_this_machine_cannot_run_is_refused(monkeypatch):
    """NUMBA_CPU_NAME naming a model whose instructions the processor lacks died by SIGILL (exit 132) without a word:
    refused with the missing features named, in-process (ConfigError) and on the command line (one line, exit 2)."""
    import llvmlite.binding as llvm

    from lnss_lib.config import PROJECT_DIR
    from lnss_lib.errors import ConfigError

    host_features = llvm.get_host_cpu_features()
    monkeypatch.setenv("NUMBA_CPU_NAME", lnss_lib.KERNEL_CPU)
    monkeypatch.setattr(llvm, "get_host_cpu_features", lambda: {"avx2": True, "avx": True})
    with pytest.raises(
        ConfigError, match="NUMBA_CPU_NAME=skylake-avx512 names a processor model .* lacks avx512f"
    ):
        lnss_lib.kernel_cpu()
    monkeypatch.setenv("NUMBA_CPU_NAME", "znver4")
    with pytest.raises(ConfigError, match="lacks avx512f,"):
        lnss_lib.kernel_cpu()
    monkeypatch.setenv("NUMBA_CPU_NAME", "haswell")  # no AVX-512 needed: taken as named
    assert lnss_lib.kernel_cpu() == "haswell"
    if not host_features.get(
        "avx512f", False
    ):  # this machine cannot run the model: the command line
        done = subprocess.run(
            [sys.executable, "-m", "lnss_lib", "evaluate", "--help"],
            cwd=PROJECT_DIR,
            capture_output=True,
            text=True,
            env={**os.environ, "NUMBA_CPU_NAME": "skylake-avx512"},
        )
        assert (
            done.returncode == 2 and done.stderr.count("\n") == 1 and "lacks avx512f" in done.stderr
        ), done.stderr
