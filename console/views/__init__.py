"""The console's panels and 3D layers: each draws the session's state and turns clicks into session calls.
Holds one module per view plus pure picture / wording helpers; exposes nothing at package level.
"""
