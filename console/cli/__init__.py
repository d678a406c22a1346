"""The ``morphonavi`` command: one module per subcommand (the pipeline's ``map`` / ``bench`` included).
The entry point is :func:`console.cli.morphonavi.main`; errors for users are :class:`console.cli.errors.CliError`.
"""
