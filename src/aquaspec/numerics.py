"""Numerical building blocks shared by the physics: each written once here.

Nothing in this module knows about water, light or cameras; it imports only
NumPy and :mod:`aquaspec.errors`.
"""

from __future__ import annotations

import numpy as np
