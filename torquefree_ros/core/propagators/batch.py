# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Many bodies on one time grid (Monte Carlo campaigns): ``propagate_batch``.

Each body is propagated exactly as :func:`~torquefree_ros.core.propagate` propagates it alone, so
a batch is bit for bit the same as the loop a user would write; the batch checks every input and
names the body a bad one belongs to. The exact solution's moving bodies (nearly all of a dispersed
campaign) are built and evaluated together. Compiled (:mod:`.attitude_kernels`): each body's table
row by the code one body's comes from, then one kernel call per kind of motion. With numpy: the
constants of :mod:`.polhode_constants` computed as numpy columns over bodies by the very formulas
one body uses, then the same elementwise evaluation on ``(bodies, times)`` arrays, a group of
bodies at a time so that memory stays bounded (the separatrix, rare, goes one by one). The rest
(other propagators, stationary motions) go one by one.
"""

from __future__ import annotations

import math

import numpy as np

from . import make_propagator
from ..body.rigid_body import MAX_INERTIA, RigidBody, TRIANGLE_RTOL
from ..checks.validation import (
    initial_samples,
    sample_times,
    unit_quaternion,
    UNIT_QUATERNION_ROUNDING,
)
from ..exact import attitude_kernels
from ..exact.elliptic import JacobiElliptic
from ..exact.polhode import PolhodeAttitude
from ..exact.polhode_constants import (
    attitude_constants,
    is_stationary,
    solver_frame,
    solver_from_body,
    SolverFrame,
    to_principal,
)
from ..numerics import kernels
from ..numerics.ops import COLUMNS

# bodies whose constants are built together (then evaluated in passes of bounded size)
GROUP_BODIES = 4096
_IDENTITY_ROWS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def propagate_batch(inertia, angular_velocity, orientation, times, propagator='auto', **options):
    """
    Return ``(omega_B, q_NB)`` for ``N`` bodies at the ``M`` sorted ``times`` (s).

    The shapes are ``(N, M, 3)`` and ``(N, M, 4)``. ``inertia (N, 3)`` principal moments or
    ``(N, 6)`` tensors ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (kg m^2), ``angular_velocity (N, 3)``
    (rad/s, body frame), ``orientation (N, 4)`` (``q_NB`` as ``x, y, z, w``); ``propagator`` and
    ``options`` as for ``propagate``.
    """
    inertia = _table(inertia, 'inertia', (3, 6))
    count = inertia.shape[0]
    angular_velocity = _table(angular_velocity, 'angular_velocity', (3,), count)
    orientation = _table(orientation, 'orientation', (4,), count)
    times = sample_times(times)
    omega = np.empty((count, times.size, 3))
    q = np.empty((count, times.size, 4))
    if propagator in ('auto', 'analytic') and not options:
        alone = _exact_together(inertia, angular_velocity, orientation, times, omega, q)
    else:
        alone = range(count)
    for i in alone:
        omega[i], q[i] = _propagator(
            i, inertia, angular_velocity, orientation, propagator, **options
        )(times)
    return omega, q


def _propagator(i, inertia, angular_velocity, orientation, propagator='auto', **options):
    try:
        return make_propagator(
            inertia[i], angular_velocity[i], orientation[i], propagator, **options
        )
    except ValueError as error:
        raise ValueError(f'body {i}: {error}') from None


def _exact_together(inertia, angular_velocity, orientation, times, omega, q) -> list:
    """
    Evaluate the bodies the exact solution covers, with their constants in columns.

    The results go into ``omega`` and ``q``; return the indices of the others (to go one by one).
    Raises for a bad body.
    """
    count = inertia.shape[0]
    bodies = _bodies(inertia, angular_velocity)
    if bodies is None:  # some body is refused: building each alone names it and says why
        for i in range(count):
            _propagator(i, inertia, angular_velocity, orientation)
        return list(range(count))  # (only if the checks here were stricter than a body's own)
    moments, axes = bodies
    q0 = _unit_quaternions(orientation)
    if kernels.ENABLED:
        return _compiled_together(moments, axes, angular_velocity, q0, times, omega, q)
    omega0_P = to_principal(tuple(angular_velocity.T), axes)
    moving = np.flatnonzero(~is_stationary(tuple(moments.T), omega0_P))
    frames = solver_frame(COLUMNS, _rows(moments.T, moving), _rows(omega0_P, moving))
    mc = frames.mc
    periodic = moving[mc > 0.0]
    # bodies whose Jacobi functions take the same kind of series, in groups that bound the memory
    group = GROUP_BODIES
    # positions in moving
    kinds = (
        np.flatnonzero(mc >= JacobiElliptic.TRIGONOMETRIC_MC),
        np.flatnonzero((mc > 0.0) & (mc < JacobiElliptic.TRIGONOMETRIC_MC)),
    )
    zeros = initial_samples(times)
    for positions in (
        kind[start: start + group] for kind in kinds for start in range(0, kind.size, group)
    ):
        rows = moving[positions]
        frame = _take(frames, positions)
        body_axes = tuple(_rows(row, rows) for row in axes)
        jacobi = JacobiElliptic.columns(frame.mc, frame.n, frame.m)
        constants = attitude_constants(
            COLUMNS,
            frame,
            solver_from_body(COLUMNS, frame, body_axes),
            tuple(q0[rows].T),
            jacobi.sn2_integral_slope,
        )
        _evaluate_rows(
            PolhodeAttitude(jacobi, frame.rate, constants),
            rows,
            times,
            zeros,
            angular_velocity,
            q0,
            omega,
            q,
        )
    return sorted(set(range(count)) - set(periodic.tolist()))


def _evaluate_rows(
    attitude: PolhodeAttitude, rows, times, zeros: int, angular_velocity, q0, omega, q
) -> None:
    """
    Fill the bodies ``rows`` (ascending) of ``omega`` and ``q`` from their ``attitude``.

    Their first ``zeros`` samples (t = 0) are the initial state itself.
    """
    # consecutive: views take the result, (times, bodies, k), directly
    if rows[-1] - rows[0] == rows.size - 1:
        attitude(
            times,
            out=(
                omega[rows[0]: rows[-1] + 1].swapaxes(0, 1),
                q[rows[0]: rows[-1] + 1].swapaxes(0, 1),
            ),
        )
    else:
        group_omega, group_q = attitude(times)
        omega[rows], q[rows] = group_omega.swapaxes(0, 1), group_q.swapaxes(0, 1)
    omega[rows, :zeros] = angular_velocity[rows, None]
    q[rows, :zeros] = q0[rows, None]


def _compiled_together(moments, axes, angular_velocity, q0, times, omega, q) -> list:
    """
    Do :func:`_exact_together`'s work with :mod:`.attitude_kernels`.

    Each body's table is built by the same compiled code as for one body, then each kind's bodies
    are evaluated by its kernel in one call.
    """
    principal_axes = np.empty((moments.shape[0], 3, 3))
    for j in range(3):  # from rows of columns over bodies (or of floats)
        for k in range(3):
            principal_axes[:, j, k] = axes[j][k]
    kinds, table = attitude_kernels.build_tables(moments, principal_axes, angular_velocity, q0)
    zeros = initial_samples(times)
    for code, kind in enumerate(attitude_kernels.KINDS):
        rows = np.flatnonzero(kinds == code)
        if rows.size:
            attitude = PolhodeAttitude.from_table(table[rows], kind, many=True)
            _evaluate_rows(attitude, rows, times, zeros, angular_velocity, q0, omega, q)
    return np.flatnonzero(kinds < 0).tolist()


def _bodies(inertia, angular_velocity):
    """
    Return the principal moments ``(N, 3)`` and axes of all bodies, or ``None`` if one is refused.

    The axes are rows of columns over bodies; moments and axes as :class:`RigidBody` gives them
    body by body. ``None`` if some body would be refused (the checks of :class:`RigidBody` and of
    the propagators' representable state, on all bodies at once).
    """
    with np.errstate(over='ignore', invalid='ignore'):
        finite = np.all(np.isfinite(inertia), axis=1) & np.all(
            np.isfinite(angular_velocity), axis=1
        )
        if not np.all(finite):
            return None
        if inertia.shape[1] == 6:  # tensors: each diagonalised exactly as alone
            try:
                built = [RigidBody.from_inertia(row) for row in inertia]
            except ValueError:
                return None
            moments = np.array([body.moments for body in built])
            axes = np.array([body.principal_axes for body in built])
            tensors = np.array([body.tensor for body in built])
            axes_rows = tuple(tuple(axes[:, j, k] for k in range(3)) for j in range(3))
        else:
            moments, axes_rows = inertia, _IDENTITY_ROWS
            largest = moments.max(axis=1)
            if not (
                np.all(np.abs(moments) <= MAX_INERTIA)
                and np.all(moments > 0.0)
                and np.all(largest <= (moments.sum(axis=1) - largest) * (1.0 + TRIANGLE_RTOL))
            ):
                return None
            tensors = moments[:, :, None] * np.eye(3)
        # the representability check, |H|^2 I_max^2 finite
        h = np.einsum('nij,nj->ni', tensors, angular_velocity)
        if not np.all(np.isfinite(np.sum(h * h, axis=1) * moments.max(axis=1) ** 2)):
            return None
    return moments, axes_rows


def _unit_quaternions(orientation: np.ndarray) -> np.ndarray:
    """
    Normalise each row of ``orientation`` as :func:`unit_quaternion` does.

    The same ``math.hypot`` norm and division; a row it would refuse or divide is handed to it, so
    that the error names the body.
    """
    with np.errstate(over='ignore', invalid='ignore'):
        norms = (
            np.array([math.hypot(*row) for row in orientation.tolist()])
            if orientation.size
            else np.ones(0)
        )
        used_as_given = np.abs(norms - 1.0) <= UNIT_QUATERNION_ROUNDING  # false for nan and inf
    q0 = orientation.copy()
    for i in np.flatnonzero(~used_as_given).tolist():
        try:
            q0[i] = unit_quaternion(orientation[i], 'orientation')
        except ValueError as error:
            raise ValueError(f'body {i}: {error}') from None
    return q0


def _take(frame: SolverFrame, positions: np.ndarray) -> SolverFrame:
    """
    Return the solver frames of the bodies at ``positions``.

    Every value is an array over bodies; tuples are taken element by element.
    """
    return SolverFrame(
        *(
            _rows(value, positions) if isinstance(value, tuple) else value[positions]
            for value in frame
        )
    )


def _rows(columns, rows) -> tuple:
    """Return the selected bodies of each column."""
    return tuple(column[rows] if isinstance(column, np.ndarray) else column for column in columns)


def _table(values, name: str, widths: tuple, rows: int | None = None) -> np.ndarray:
    try:
        table = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f'{name}: expected an array of numbers, shape (N, {" or ".join(map(str, widths))})'
        ) from None
    if table.ndim != 2 or table.shape[1] not in widths:
        raise ValueError(
            f'{name}: expected shape (N, {" or ".join(map(str, widths))}), got {table.shape}'
        )
    if rows is not None and table.shape[0] != rows:
        raise ValueError(f'{name}: {table.shape[0]} rows for {rows} bodies (inertia has {rows})')
    return table
