"""The accuracy benchmark against photos with ground-truth 3D objects (``morphonavi bench``) and its report.
:func:`pipeline.bench.evaluate.run_bench` runs it; :mod:`pipeline.bench.report` sums and prints.
"""
