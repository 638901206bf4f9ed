"""The commands of ``python -m lnss_lib``, one module each: ``add_arguments(parser)`` declares the
command's flags and ``run(args)`` checks them before any work and does it (:mod:`lnss_lib.__main__`
parses and dispatches). :mod:`~lnss_lib.cli.arguments` holds what they share."""
