"""Start a subprocess as a terminal starts a foreground command, for the Ctrl-C tests.

A shell without job control starts its background commands with SIGINT ignored, and a child inherits
that: under ``python -m pytest ... &`` the commands these tests interrupt would never see the signal
(exit 0, or a hang until the timeout). A terminal's foreground job has the default action.
"""

import signal


def foreground_signals() -> None:
    """``preexec_fn`` of the child: SIGINT back to its default action (KeyboardInterrupt in Python)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
