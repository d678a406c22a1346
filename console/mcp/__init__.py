"""The Model Context Protocol interface for language-model agents: another door into the console's session.

An agent reads the session's state (map, scene graph, robot, mission, last photo, events) and
proposes actions that an operator approves or rejects in the console; it never drives the link
itself, except Hold, Land here and Return, which make things safer. Modules: :mod:`.door` (the
requests, checked and recorded), :mod:`.proposals` (the approval queue, rate-limited),
:mod:`.state_read` (the read side as JSON), :mod:`.control_api` (the console's loopback API and
its client), :mod:`.server` (the MCP tools, resources and prompts, ``mcp`` SDK), :mod:`.attach`
(wiring into :class:`console.app.ConsoleApp`). User guide: ``docs/howto/mcp.md``.
"""
