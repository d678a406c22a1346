"""Shared test set-up: the test helpers in this folder (MAVLink emulator, ONNX fixtures ...) importable from every sub-folder."""

import sys
from pathlib import Path

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)
