"""The console's state: the session (scene, grid, route, mission, captures, robot), its rules, undo, persistence and lock.
Views and the CLI use :class:`console.session.session.Session`; nothing here draws.
"""
