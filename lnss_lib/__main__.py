"""Command line: ``python -m lnss_lib {reproduce, propagate, evaluate, campaign, study, bench} ...`` (``--help`` on each).

This module parses and dispatches; each command's arguments and work live in its module of
:mod:`lnss_lib.cli`. Errors end in one line with an exit code that tells bad input from failure.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import traceback
from pathlib import Path

from .cli import bench, campaign, evaluate, propagate, reproduce, study
from .config import PACKAGE_DIR, use_profile_file
from .errors import ConfigError, EphemerisRangeError, InvalidOrbitError, SpiceError, Terminated

COMMAND_MODULES = {
    "reproduce": reproduce,
    "propagate": propagate,
    "evaluate": evaluate,
    "campaign": campaign,
    "study": study,
    "bench": bench,
}
COMMANDS = {  # name -> (one-line help, description, example) for ``--help``
    "reproduce": (
        "execute the notebooks headless into outputs/<profile>/",
        "Run the workbook's notebooks with papermill under a profile, write the executed notebooks, "
        "figures, tables and manifest under outputs/<profile>/, and the index.html and FINDINGS.md that "
        "open on the run's findings beside the paper's.",
        "python -m lnss_lib reproduce --profile ci --only 05 07",
    ),
    "propagate": (
        "propagate one orbit with the high-fidelity model; CSV or NetCDF out",
        "Propagate one Moon-centred state or element set with the profile's force model (lunar gravity "
        "field, third bodies, solar pressure, relativity) and write the states.",
        "python -m lnss_lib propagate --epoch-tdb 2025-05-01T00:00:00 --elements 6143 0.6 51.7 0 90 0 "
        "--days 1 --out elfo.csv",
    ),
    "evaluate": (
        "every objective of eq. 45 for one Walker design or one catalogue constellation",
        "Evaluate one design as the campaign does (propagation, south-pole DOP grid, station-keeping "
        "Delta-V, GPS link) and print every metric with its unit, or one JSON object.",
        "python -m lnss_lib evaluate --sma-km 6143 --ecc 0.6 --aop-deg 90 --inc-deg 51.7 --planes 2 "
        "--sats-per-plane 8",
    ),
    "campaign": (
        "NSGA-II design search (Section 5, Table 5), checkpointed every generation",
        "Search the eq. 43-44 design grid with NSGA-II under Table 3's bounds; every generation is "
        "checkpointed, so --resume continues an interrupted run.",
        "python -m lnss_lib campaign --profile ci --workers 2; "
        "python -m lnss_lib campaign --export-reference RUN_DIR (ship a run's results)",
    ),
    "study": (
        "many campaigns (seeds, sizes, profiles) side by side on one Dask cluster",
        "Run the campaigns a study file lists, all at once on one Dask cluster, each in its own run folder "
        "under --run-dir with its journal and checkpoint; --resume continues the whole study.",
        "python -m lnss_lib study params/studies/ci_pair.toml --run-dir runs/pair --workers 2",
    ),
    "bench": (
        "benchmarks that print numbers",
        "Time a part of the workbook and print the new path beside the one it replaces.",
        "python -m lnss_lib bench dop",
    ),
}


def _command(sub, name: str) -> argparse.ArgumentParser:
    """A subcommand with its help line, description and example (:data:`COMMANDS`)."""
    import textwrap

    brief, description, example = COMMANDS[name]
    example = " \\\n      ".join(
        textwrap.wrap(example, 72, break_on_hyphens=False, break_long_words=False)
    )
    return sub.add_parser(
        name,
        help=brief,
        description=textwrap.fill(description, 78),
        epilog=f"example:\n  {example}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def build_parser() -> argparse.ArgumentParser:
    """The command line: one subcommand a module of :mod:`lnss_lib.cli`, each with its arguments."""
    parser = OneLineParser(
        prog="python -m lnss_lib",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="LNSS design workbook: lunar navigation constellations after Malik & Yang.",
        epilog="example:\n  python -m lnss_lib evaluate --constellation bhamidipati2023_case_c\n"
        "run 'python -m lnss_lib COMMAND --help' for a command's options and example",
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="show the traceback of an error (also accepted after the command)",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    for name, module in COMMAND_MODULES.items():
        command = _command(sub, name)
        module.add_arguments(command)
        command.set_defaults(func=module.run)
    return parser


class OneLineParser(argparse.ArgumentParser):
    """argparse with a one-line usage error (exit 2) that points at ``--help``."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


INPUT_ERRORS = (
    ConfigError,
    EphemerisRangeError,
    InvalidOrbitError,
    SpiceError,
    FileNotFoundError,
)  # bad input: exit 2


def _raised_by_lnss(error: BaseException) -> bool:
    """True when the innermost frame of ``error``'s traceback is lnss_lib code (one of its own checks)."""
    tb = error.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and Path(tb.tb_frame.f_code.co_filename).resolve().is_relative_to(
        PACKAGE_DIR
    )


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    if isinstance(error, OSError) and error.filename is not None:
        text = f"cannot write or read {error.filename}: {error.strerror or text}"
    return text or type(error).__name__


def classify(error: Exception) -> tuple[int, str]:
    """Exit code and one-line message: 2 for bad input (the input-error classes, and ValueErrors raised by
    lnss_lib's own checks), 1 for a failure (impact, OSError, RuntimeError) and for anything else, which is
    an internal error, not bad input."""
    if isinstance(error, FileNotFoundError):
        return 2, f"no such file or folder: {error.filename}" if error.filename else _one_line(
            error
        )
    if isinstance(error, INPUT_ERRORS) or (type(error) is ValueError and _raised_by_lnss(error)):
        return 2, _one_line(error)
    if isinstance(error, (OSError, RuntimeError)):
        return 1, _one_line(error)
    return (
        1,
        f"internal error: {type(error).__name__}: {_one_line(error)} (run with --debug for the traceback)",
    )


def main(argv: list[str] | None = None) -> int:
    """Run a command; errors end in one line on stderr with exit 2 (bad input), 1 (failure or internal
    error) or 130 (interrupted); ``--debug`` adds the traceback before that line, with the same exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help (0) or a usage error (2, one line already printed)
        return stop.code if isinstance(stop.code, int) else 2
    if _prints_result(args) and (sys.stdout is None or sys.stdout.closed):
        print(
            "error: standard output is closed: the command's result would be lost; open it or redirect it to a "
            "file",
            file=sys.stderr,
        )
        return 1
    previous = signal.signal(signal.SIGTERM, _terminate) if _in_main_thread() else None
    try:
        if getattr(args, "profile_file", None):
            args.profile = use_profile_file(args.profile_file)
        code = args.func(args)
        if sys.stdout is not None:
            sys.stdout.flush()  # a reader gone or a full disk is this command's failure, not exit 0
        return code
    except (KeyboardInterrupt, Exception) as error:
        code, text = (
            (143, "terminated (SIGTERM)")
            if isinstance(error, Terminated)
            else (130, "interrupted")
            if isinstance(error, KeyboardInterrupt)
            else classify(error)
        )
        if debug:
            traceback.print_exception(error)
        elif code in (
            130,
            143,
        ):  # tasks abandoned by the interrupt (a notebook kernel's) are logged when collected
            logging.getLogger("asyncio").setLevel(logging.CRITICAL)
        print(f"error: {text}", file=sys.stderr)
        return code
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _terminate(signum, frame):
    """SIGTERM raises :class:`~lnss_lib.errors.Terminated`: the run stops as on Ctrl-C (journal, checkpoint and
    workers closed), with one line and exit 143 (it ended silently, leaking semaphores)."""
    raise Terminated()


def _prints_result(args: argparse.Namespace) -> bool:
    """Whether the command's result goes to standard output (``evaluate``; ``propagate`` without ``--out``)."""
    return args.command == "evaluate" or (args.command == "propagate" and args.out is None)


if __name__ == "__main__":
    sys.exit(main())
