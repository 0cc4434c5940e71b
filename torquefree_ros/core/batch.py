"""Many bodies on one time grid (Monte Carlo campaigns): ``propagate_batch``.

Each body is propagated exactly as :func:`~torquefree_ros.core.propagate` propagates it alone, so
a batch is bit for bit the same as the loop a user would write; the batch checks every input once
and names the body a bad one belongs to. The exact solution's bodies off the separatrix (nearly all
of a dispersed campaign) are evaluated together: their constants stacked as columns, the same
elementwise operations run on ``(bodies, times)`` arrays at once, a group of bodies at a time so
that memory stays bounded; the rest (other propagators, separatrix, stationary motions) one by one.
"""

from __future__ import annotations

import numpy as np

from .polhode import PolhodeAttitude
from .propagators import make_propagator
from .propagators.analytic import AnalyticPropagator
from .validation import sample_times

GROUP_ELEMENTS = 1 << 17  # bodies x times evaluated in one stacked call (~100 arrays of this size)


def propagate_batch(inertia, angular_velocity, orientation, times, propagator="auto", **options):
    """``(omega_B, q_NB)`` of shapes ``(N, M, 3)`` and ``(N, M, 4)`` for ``N`` bodies at the ``M``
    sorted ``times`` (s): ``inertia (N, 3)`` principal moments or ``(N, 6)`` tensors ``[Ixx, Iyy, Izz,
    Ixy, Ixz, Iyz]`` (kg m^2), ``angular_velocity (N, 3)`` (rad/s, body frame), ``orientation (N, 4)``
    (``q_NB`` as ``x, y, z, w``); ``propagator`` and ``options`` as for ``propagate``."""
    inertia = _table(inertia, "inertia", (3, 6))
    count = inertia.shape[0]
    angular_velocity = _table(angular_velocity, "angular_velocity", (3,), count)
    orientation = _table(orientation, "orientation", (4,), count)
    times = sample_times(times)
    omega = np.empty((count, times.size, 3))
    q = np.empty((count, times.size, 4))
    stacked = []
    for i in range(count):
        try:
            body = make_propagator(inertia[i], angular_velocity[i], orientation[i], propagator, **options)
        except ValueError as error:
            raise ValueError(f"body {i}: {error}") from None
        if isinstance(body, AnalyticPropagator) and body.polhode is not None and body.polhode.jacobi.mc > 0.0:
            stacked.append((i, body))
        else:
            omega[i], q[i] = body(times)
    group = max(1, GROUP_ELEMENTS // max(times.size, 1))
    zeros = int(np.searchsorted(times, 0.0, side="right"))  # t = 0 is the initial state itself
    for start in range(0, len(stacked), group):
        indices, bodies = zip(*stacked[start:start + group])
        rows = list(indices)
        omega[rows], q[rows] = PolhodeAttitude.stack([body._attitude for body in bodies])(times)
        if zeros:
            omega[rows, :zeros] = np.array([body.omega0_B for body in bodies])[:, None]
            q[rows, :zeros] = np.array([body.q0_NB for body in bodies])[:, None]
    return omega, q


def _table(values, name: str, widths: tuple, rows: int | None = None) -> np.ndarray:
    try:
        table = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected an array of numbers, shape (N, {' or '.join(map(str, widths))})") from None
    if table.ndim != 2 or table.shape[1] not in widths:
        raise ValueError(f"{name}: expected shape (N, {' or '.join(map(str, widths))}), got {table.shape}")
    if rows is not None and table.shape[0] != rows:
        raise ValueError(f"{name}: {table.shape[0]} rows for {rows} bodies (inertia has {rows})")
    return table
