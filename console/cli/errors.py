"""The error every ``morphonavi`` subcommand raises for a user's mistake."""

from __future__ import annotations


class CliError(Exception):
    """A user-facing error: printed without a traceback, exit status 2."""
