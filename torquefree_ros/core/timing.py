"""The contract's sample times: sample ``k`` is the state at exactly ``t_k = k / rate``."""

from __future__ import annotations

import math

import numpy as np

# duration * rate is rounded (2.3 s * 100 Hz = 229.99999999999997): a product within this relative
# distance of an integer counts as that integer, so the sample at t = duration is not lost.
_COUNT_RTOL = 1e-12


def sample_times(duration: float, rate: float) -> np.ndarray:
    """``k / rate`` for ``k = 0 ... floor(duration * rate)``, both ends included."""
    if not (math.isfinite(duration) and duration >= 0.0):
        raise ValueError(f"duration: must be a finite number >= 0, got {duration!r}")
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate: must be a finite number > 0, got {rate!r}")
    product = duration * rate
    last = math.floor(product * (1.0 + _COUNT_RTOL))
    return np.arange(last + 1) / rate
