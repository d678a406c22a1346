"""How far each detected object is: the cues (size prior, ground contact, depth map), their fusion, and placement.
The mapper uses :class:`pipeline.ranging.ranger.Ranger`; the cue modules are pure functions.
"""
