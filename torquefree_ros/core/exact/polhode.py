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
The exact torque-free motion of a rigid body.

Body rates by Jacobi elliptic functions, attitude by the rotation about the constant angular
momentum.

Equations (Landau & Lifshitz, Mechanics §37; Celledoni, Fassò, Säfström & Zanna, "The exact
computation of the free rigid body motion and its use in splitting methods", SIAM J. Sci. Comput.
30 (2008)). In a *solver frame* S, a signed permutation of the principal axes whose moments
``J1, J2, J3`` are monotonic and whose axis 3 is the one the polhode circles (the major axis when
``H^2 > 2 T I_mid``, else the minor one), with ``m3 > 0`` and ``m1(0) >= 0``:

* ``P1 = H^2 - 2 T J1``, ``P2 = H^2 - 2 T J2``, ``P3 = 2 T J3 - H^2`` (sums without cancellation);
* ``k^2 = (J2-J1) P3 / ((J3-J2) P1)``, ``k'^2 = (J3-J1) P2 / ((J3-J2) P1)``,
  ``lambda^2 = (J3-J2) P1 / (J1 J2 J3)``;
* ``w1 = a cn(u)``, ``w2 = sign(J3-J2) b sn(u)``, ``w3 = c dn(u)``, ``u = lambda t + u0``, with
  ``a^2 = P3/(J1 (J3-J1))``, ``b^2 = P3/(J2 (J3-J2))``, ``c^2 = P1/(J3 (J3-J1))``.

Attitude: ``R_NS(t) = P Rz(psi(t)) Q(m(t))`` where ``Q(m)`` is the shortest-arc rotation taking
``m/|m|`` to ``e_z`` and ``P`` is constant. Landau's angle about ``H`` for the frame built on
``e3 x m`` obeys ``psi_e' = |m|/J3 + |m|(J3-J1)/(J1 J3) / (1 - n sn^2 u)`` with
``n = -J3 (J2-J1) / (J1 (J3-J2)) <= 0``. Its two terms cancel for a thin rod (``J3 << J1``), so it
is used as ``psi_e' = |m|/J1 + |m|(J3-J1) n/(J1 J3) sn^2/(1 - n sn^2)``, integrated exactly by
:class:`JacobiElliptic`'s ``S`` as its mean slope times ``u`` plus the theta phase (the weights
combine to ``sign(J3 - J1)``): ``psi`` is a constant rate plus a bounded periodic term; the
shortest-arc frame differs from it by the angle of ``(m1, m2) = (A cn, ±B sn)``, taken continuously
(``atan2(B sn(r), A cn(r)) + pi j`` for ``u = r + 2K j``, ``|r| <= K``), so the quaternion stays
continuous over any number of periods.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import attitude_kernels
from .elliptic import JacobiElliptic
from .polhode_constants import (
    attitude_constants,
    AttitudeConstants,
    is_stationary,
    solver_frame,
    solver_from_body,
    SolverFrame,
    to_principal,
)
from ..numerics import kernels
from ..numerics.ops import FLOATS


@dataclass(frozen=True)
class Polhode:
    """
    One non-stationary torque-free motion.

    Its solver frame and regime parameters, and the Jacobi functions of its parameter.
    """

    frame: SolverFrame
    jacobi: JacobiElliptic

    @property
    def rate(self) -> float:
        return self.frame.rate

    @property
    def polhode_period(self) -> float:
        return 4.0 * self.jacobi.quarter_period / self.rate


def solve_polhode(moments_P, omega_P) -> Polhode | None:
    """
    Choose the solver frame and regime once; return ``None`` for a stationary motion.

    Stationary: rest, a sphere, or a spin about a principal axis, whose rate is constant. (Plain
    float arithmetic: this runs on every reset, where numpy's per-call cost would dominate.)
    """
    moments = [float(v) for v in moments_P]
    w = [float(v) for v in omega_P]
    if is_stationary(moments, w):
        return None
    frame = solver_frame(FLOATS, moments, w)
    return Polhode(frame, JacobiElliptic(frame.mc, frame.n, frame.m))


def body_polhode(body, omega0_B) -> Polhode | None:
    """
    Return the polhode of ``body`` starting at ``omega0_B`` (body frame).

    ``None`` for a stationary motion.
    """
    axes = body.principal_axes.tolist()
    return solve_polhode(
        body.moments.tolist(), to_principal(np.asarray(omega0_B, dtype=float).tolist(), axes)
    )


def exact_attitude(body, omega0_B, q0_NB) -> 'PolhodeAttitude | None':
    """
    Return the exact attitude from ``omega0_B`` and ``q0_NB``, ``None`` for a stationary motion.

    With the compiled kernels its constants are compiled too (:func:`.attitude_kernels.build_row`):
    a few µs.
    """
    if kernels.ENABLED:
        kinds, table = attitude_kernels.build_tables(
            body.moments, body.principal_axes, omega0_B, q0_NB
        )
        return (
            PolhodeAttitude.from_table(table, attitude_kernels.KINDS[kinds[0]])
            if kinds[0] >= 0
            else None
        )
    polhode = body_polhode(body, omega0_B)
    if polhode is None:
        return None
    constants = attitude_constants(
        FLOATS,
        polhode.frame,
        solver_from_body(FLOATS, polhode.frame, body.principal_axes.tolist()),
        np.asarray(q0_NB, dtype=float).tolist(),
        polhode.jacobi.sn2_integral_slope,
    )
    return PolhodeAttitude(polhode.jacobi, polhode.rate, constants)


class PolhodeAttitude:
    """
    Exact ``(omega_F, q_NF)`` at any times for a frame F fixed in the body.

    F is the propagator's body frame; the constants are those of
    :func:`.polhode_constants.attitude_constants`.

    Per sample: ``omega_F = (cn, sn, dn) diag(a, b, c) C`` and
    ``q_NF = L ⊗ Rz(psi) ⊗ Q(m) ⊗ q_SF``; the constant left and right factors are one 4x4 matrix,
    and ``Rz(psi) ⊗ Q(m)`` is written out (``Q(m)`` has no z part, ``Rz`` only z and w).

    One body (constants are floats): called with times ``(M,)`` it gives ``(M, 3)`` rates and
    ``(M, 4)`` attitudes. Many (constants are arrays over ``N`` bodies, ``jacobi`` from
    :meth:`JacobiElliptic.columns`): ``(M, N, 3)`` and ``(M, N, 4)``, times first and bodies along
    the contiguous axis, body ``i`` exactly as it alone.
    """

    def __init__(self, jacobi: JacobiElliptic, rate, constants: AttitudeConstants):
        self.jacobi = jacobi
        c = constants
        self._bodies = c.momentum.shape[0] if isinstance(c.momentum, np.ndarray) else None
        self._table = self._kernel = None  # (compiled: from_table)
        rate_matrix, frame_change = (
            np.array(c.rate_matrix, dtype=float),
            np.array(c.frame_change, dtype=float),
        )
        if self._bodies is not None:  # many bodies: rows (N, l) of (k, l, N) matrices
            rate_matrix, frame_change = (
                rate_matrix.transpose(0, 2, 1),
                frame_change.transpose(0, 2, 1),
            )
        self._rate_rows, self._frame_change_rows = tuple(rate_matrix), tuple(frame_change)
        # numpy values, 0-d for one body (a Python float operand is converted again on every
        # operation); half of psi = psi_rate t + direction (phase - angle) + psi_offset, each term
        # halved (exact)
        values = np.array(
            (
                rate,
                c.initial_phase,
                c.momentum,
                2.0 * c.momentum,
                *c.momentum_amplitudes,
                *c.lever,
                0.5 * c.direction,
                0.5 * c.psi_rate,
                0.5 * c.psi_offset,
            ),
            dtype=float,
        )
        (
            self._rate,
            self._initial_phase,
            self._momentum,
            self._two_momentum,
            *amplitudes,
            lever_cn,
            lever_sn,
            self._half_direction,
            self._half_psi_rate,
            self._half_psi_offset,
        ) = (values[i, ...] for i in range(len(values)))
        self._momentum_amplitudes, self._lever = tuple(amplitudes), (lever_cn, lever_sn)
        if jacobi._theta is not None:  # (None on the separatrix: closed forms)
            # built now: part of the propagator's construction, not of its first call
            jacobi._theta.phased_cubics

    @classmethod
    def from_table(cls, table: np.ndarray, kind: str, many: bool = False) -> 'PolhodeAttitude':
        """
        Build a compiled attitude from a table of :func:`.attitude_kernels.build_tables`.

        The table's bodies are all of one ``kind``: one body (one row), or ``many`` (results
        ``(M, N, k)``).
        """
        attitude = object.__new__(cls)
        attitude.jacobi = None
        attitude._bodies = table.shape[0] if many else None
        attitude._table, attitude._kernel = table, attitude_kernels.kernel(kind)
        return attitude

    #: elements evaluated in one pass: the pass's temporaries (~35 arrays of this many floats) stay
    #: in cache, and a long request does not grow the heap by megabytes that the allocator hands
    #: back to the system after every call and takes again, page by page, on the next
    ELEMENTS_PER_PASS = 2560

    def __call__(self, t: np.ndarray, out: tuple | None = None):
        """
        Return the rates and attitudes at ``t``.

        They go into ``out = (omega, q)`` if given (arrays of the result's shape).
        """
        if self._table is not None:
            return self._compiled(t, out)
        if self._bodies is not None:
            t = t[:, None]  # (M, 1) against constants over bodies (N,)
        step = max(1, self.ELEMENTS_PER_PASS // (self._bodies or 1))
        count = t.shape[0]
        if count <= step and out is None:
            return self._pass(t)
        shape = (count, self._bodies) if self._bodies is not None else (count,)
        omega, q = out if out is not None else (np.empty(shape + (3,)), np.empty(shape + (4,)))
        for start in range(0, count, step):
            omega[start: start + step], q[start: start + step] = self._pass(
                t[start: start + step]
            )
        return omega, q

    def _compiled(self, t: np.ndarray, out: tuple | None):
        """
        Do :meth:`__call__`'s work with :mod:`.attitude_kernels`.

        The kernels fill ``(bodies, samples, k)`` arrays.
        """
        bodies = self._bodies or 1
        # the kernel's layout is bodies first: (M, N, k) views of it are taken back
        if out is not None:
            given = tuple(a[None] if self._bodies is None else a.swapaxes(0, 1) for a in out)
            filled = tuple(a if a.flags.c_contiguous else np.empty(a.shape) for a in given)
        else:
            filled = (np.empty((bodies, t.shape[0], 3)), np.empty((bodies, t.shape[0], 4)))
        self._kernel(np.ascontiguousarray(t, dtype=float), self._table, *filled)
        if out is not None:
            for target, values in zip(given, filled):
                if target is not values:
                    target[...] = values
            return out
        omega, q = filled
        return (
            (omega[0], q[0]) if self._bodies is None else (omega.swapaxes(0, 1), q.swapaxes(0, 1))
        )

    def _pass(self, t: np.ndarray):
        v = self.jacobi(self._rate * t + self._initial_phase, integral=False, phase=True)
        cn, sn, dn = v.cn, v.sn, v.dn
        omega_F = _combine((cn, sn, dn), self._rate_rows)
        # the angle of (m1, m2) is sign(J3 - J2) times the continuous angle of (A cn, B sn)
        half = (
            self._half_psi_rate * t + self._half_direction * v.phase_minus_angle(*self._lever)
        ) + self._half_psi_offset
        m_amp = self._momentum_amplitudes
        m0, m1 = m_amp[0] * cn, m_amp[1] * sn
        arc_w = self._momentum + m_amp[2] * dn  # m3 > 0: no cancellation
        # Q(m) = (m2, -m1, 0, |m| + m3) / sqrt(2 |m| (|m| + m3)), its norm in closed form
        scale = np.reciprocal(np.sqrt(self._two_momentum * arc_w))
        cos_half, sin_half = np.cos(half) * scale, np.sin(half) * scale
        about_H_arc = (
            cos_half * m1 + sin_half * m0,
            sin_half * m1 - cos_half * m0,
            sin_half * arc_w,
            cos_half * arc_w,
        )
        return omega_F, _combine(about_H_arc, self._frame_change_rows)


def _combine(columns, rows) -> np.ndarray:
    """
    Compute ``np.stack(columns, -1) @ matrix`` from the matrix's ``rows``, element by element.

    Summed element by element rather than by BLAS, whose kernels (and so roundings) change with the
    number of rows: a sample must not depend on how many were requested with it. Columns ``(M,)``
    with rows ``(l,)``, or ``(M, N)`` with rows ``(N, l)`` (bodies: the same operations, body by
    body).
    """
    total = columns[0][..., None] * rows[0]
    for column, row in zip(columns[1:], rows[1:]):
        total += column[..., None] * row
    return total
