"""lnss_lib: the helper library behind the LNSS design workbook (Malik & Yang, LNSS optimisation).

Layers (a module imports only from its own layer or a lower one):

1. Foundations: ``config`` (profiles), ``constants`` (units in the names), ``paper`` (numbers quoted
   from the paper), ``keys`` (one spelling of design, metric and result keys), ``errors``.
2. Physics kernels (numpy, numba, scipy, xarray; no pandas, plotting or campaign machinery):
   ``ephemeris`` (SPICE kernels, bodies, tabulated geometry), ``frames`` (element frames, Moon-fixed
   rotation, RTN, precession-nutation, TEME -> J2000, time scales), ``elements``, ``gravity``,
   ``forces``, ``propagator``, ``reference`` and ``validation`` (independent checks), ``tle`` (TLE
   reading, checks, selection), ``geometry`` (the shared position block of (G^T G)^-1, filtered means,
   availability), ``dop`` (south-pole grid), ``gps`` (GPS states and link), ``gve`` (Gauss variational
   equations and their inverses), ``deltav`` (station-keeping budgets), ``constellation``,
   ``evaluator`` (the design evaluator).
   ``design_life`` (the design-life package: averaged model and screen, estimate, manoeuvres, control,
   closed loop, evaluation, frozen orbits; its docstring draws the picture); ``catalogue`` (published
   constellations).
3. Campaign engine: ``campaign`` (settings, grid, fitness, tasks, journal, backends, problem, rundir,
   runner and callbacks, timing).
4. Presentation and studies: ``outputs``, ``pipeline``, ``figures``, ``studies`` (one module per
   notebook; each docstring states the question and the verdict), ``explorer``.
   Top: ``__main__`` (argument parsing), ``cli`` (the evaluate command's results), ``bench``.

Compiled kernels are cached on disk in one folder per state of these sources (:func:`kernel_cache_dir`).
"""

import hashlib
import os
import sys
from pathlib import Path

__version__ = "0.1.0"


def source_digest(root: Path) -> str:
    """Digest (16 hex) of every ``*.py`` file under ``root``, names and contents."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def kernel_cache_dir() -> str:
    """Numba's cache folder for this state of the sources: ``NUMBA_CACHE_DIR`` (else ~/.cache/lnss_workbook/numba)
    joined with :func:`source_digest`. Numba checks a cached function against its own file only, so a kernel that
    inlines one of another module (the integrator inlines the force model, the force model the gravity field) would
    keep the old machine code after only that other module changed; with the folder keyed by every source, any
    change compiles afresh. Child processes (Dask workers, the command line) inherit the parent folder
    (``LNSS_NUMBA_CACHE_PARENT``), not the keyed one."""
    parent = (
        os.environ.get("LNSS_NUMBA_CACHE_PARENT")
        or os.environ.get("NUMBA_CACHE_DIR")
        or os.path.join(os.path.expanduser("~"), ".cache", "lnss_workbook", "numba")
    )
    os.environ["LNSS_NUMBA_CACHE_PARENT"] = parent
    return os.path.join(parent, source_digest(Path(__file__).resolve().parent))


# The processor numba compiles the kernels for. The gravity kernels may reassociate sums (``gravity.FAST``), so
# their bits follow the vector width the compiler picks, which follows the processor model: the same code gave
# results up to 2e-7 apart after 10 days compiled for an AMD Zen 4 (znver4) and for an Intel Xeon (the shipped
# campaigns' and the pins' machine), both with AVX-512. Compiled for one named model wherever the processor can run
# it, every machine computes the same bits (the shipped results reproduce bit for bit on both), at the same speed.
KERNEL_CPU = "skylake-avx512"
KERNEL_CPU_NEEDS = (
    "avx512f",
    "avx512cd",
    "avx512bw",
    "avx512dq",
    "avx512vl",
    "avx2",
    "avx",
    "fma",
    "f16c",
    "bmi",
    "bmi2",
    "lzcnt",
    "movbe",
    "popcnt",
    "sse4.2",
    "adx",
    "clflushopt",
    "clwb",
    "xsave",
)


AVX512_MODELS = (
    "skylake-avx512",
    "cascadelake",
    "cooperlake",
    "cannonlake",
    "icelake-client",
    "icelake-server",
    "tigerlake",
    "rocketlake",
    "sapphirerapids",
    "emeraldrapids",
    "graniterapids",
    "znver4",
    "znver5",
    "x86-64-v4",
)  # LLVM's names of the processor models whose code may use AVX-512


def kernel_cpu() -> str:
    """The processor model the kernels are compiled for: ``NUMBA_CPU_NAME`` when set, else :data:`KERNEL_CPU` when
    this processor has every feature of :data:`KERNEL_CPU_NEEDS`, else ``host:<model>`` (numba's default: this
    processor; its results differ from the pinned ones by round-off, amplified by adaptive step control).

    ``NUMBA_CPU_NAME`` naming a model whose instructions this processor lacks (:data:`KERNEL_CPU` without a feature
    of :data:`KERNEL_CPU_NEEDS`, a model of :data:`AVX512_MODELS` without AVX-512) raises ConfigError: its kernels
    would stop with an illegal instruction (SIGILL, exit 132) without a word."""
    import llvmlite.binding as llvm

    features = llvm.get_host_cpu_features()
    name = os.environ.get("NUMBA_CPU_NAME")
    if name:
        needs = (
            KERNEL_CPU_NEEDS
            if name == KERNEL_CPU
            else ("avx512f",)
            if name in AVX512_MODELS
            else ()
        )
        missing = [feature for feature in needs if not features.get(feature, False)]
        if missing:
            from .errors import ConfigError

            raise ConfigError(
                f"environment variable NUMBA_CPU_NAME={name} names a processor model this machine "
                f"({llvm.get_host_cpu_name()}) cannot run: it lacks {', '.join(missing)}, and the kernels "
                f"would stop with an illegal instruction; unset NUMBA_CPU_NAME (the kernels are then "
                f"compiled for this machine)",
                key="NUMBA_CPU_NAME",
            )
        return name
    if all(features.get(feature, False) for feature in KERNEL_CPU_NEEDS):
        return KERNEL_CPU
    return f"host:{llvm.get_host_cpu_name()}"


os.environ["NUMBA_CACHE_DIR"] = kernel_cache_dir()
try:
    _cpu = kernel_cpu()  # asks llvmlite once; later calls read NUMBA_CPU_NAME
except ValueError as _error:  # ConfigError: a model this machine cannot run
    if sys.argv[:1] == [
        "-m"
    ]:  # ``python -m lnss_lib`` locating its __main__: the command line's one line
        print(f"error: {_error}", file=sys.stderr)
        sys.exit(2)
    raise
if not _cpu.startswith("host:"):
    os.environ["NUMBA_CPU_NAME"] = _cpu
    os.environ.setdefault("NUMBA_CPU_FEATURES", "")  # only the features the model implies
if (
    "numba.core.config" in sys.modules
):  # numba imported first (a notebook): its settings are read when compiling
    _numba_config = sys.modules["numba.core.config"]
    _numba_config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
    _numba_config.CPU_NAME = os.environ.get("NUMBA_CPU_NAME")
    _numba_config.CPU_FEATURES = os.environ.get("NUMBA_CPU_FEATURES")
