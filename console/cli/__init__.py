"""The ``morphonavi`` command: one module per subcommand (the pipeline's ``map`` / ``bench`` included).
The entry point is :func:`console.cli.morphonavi.morphonavi.main`; errors for users are :class:`console.cli.morphonavi.errors.CliError`.
"""
