"""One map from many captures: association and fusion, floor support, consistency checks, observation sigmas.
Pure functions over :class:`pipeline.scene.Scene` objects in the world frame (z up) [m].
"""
