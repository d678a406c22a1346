"""Mission logs: the MCAP recorder, its message schemas, reading a recording back and the read-only replay console.
Exposes nothing at package level; the console records through :mod:`console.recording.recording`.
"""
