"""A wall clock off by a constant for every Python process of a simulated machine (see :mod:`sitecustomize`).

:data:`SHIM_DIR` goes first on ``PYTHONPATH`` of the machine's processes, with
``GIDABOT_CLOCK_OFFSET`` (seconds) in their environment.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

SHIM_DIR = Path(str(files(__name__)))          # this package's own directory (it holds sitecustomize.py)
OFFSET_ENV = "GIDABOT_CLOCK_OFFSET"
