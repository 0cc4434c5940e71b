"""The exact torque-free motion of a rigid body: body rates by Jacobi elliptic functions, attitude by
the rotation about the constant angular momentum.

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
``n = -J3 (J2-J1) / (J1 (J3-J2)) <= 0``. Its two terms cancel for a thin rod (``J3 << J1``), so it is
used as ``psi_e' = |m|/J1 + |m|(J3-J1) n/(J1 J3) sn^2/(1 - n sn^2)``, integrated exactly by
:class:`JacobiElliptic`'s ``S``;
the shortest-arc frame differs from it by the angle of ``(m1, m2)``, which is ``am(u)`` plus a
bounded periodic term, so the quaternion stays continuous over any number of periods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import quaternion
from .elliptic import JacobiElliptic, JacobiValues
from .rigid_body import EQUAL_MOMENTS_RTOL, MotionRegime, RigidBody


@dataclass(frozen=True)
class Polhode:
    """Constants of one non-stationary torque-free motion, in the solver frame."""

    to_solver: np.ndarray  # 3x3 proper signed permutation: omega_S = to_solver @ omega_P
    moments: np.ndarray  # J1, J2, J3 (monotonic)
    amplitudes: np.ndarray  # a, sign(J3-J2) b, c
    rate: float  # lambda (1/s)
    initial_phase: float  # u0
    momentum: float  # |m|
    jacobi: JacobiElliptic
    initial: JacobiValues  # at u0, from the initial rate itself (scalars)

    @property
    def polhode_period(self) -> float:
        return 4.0 * self.jacobi.quarter_period / self.rate


def solve_polhode(moments_P: np.ndarray, omega_P: np.ndarray) -> Polhode | None:
    """Choose the solver frame and regime once; ``None`` for a stationary motion (rest, a sphere,
    or a spin about a principal axis), whose rate is constant. (Plain float arithmetic: this runs
    on every reset and for every propagator built, where numpy's per-call cost would dominate.)"""
    I = [float(v) for v in moments_P]
    w = [float(v) for v in omega_P]
    # Euler's equations' right-hand side, exactly zero only for a relative equilibrium.
    if not any(((I[1] - I[2]) * w[1] * w[2], (I[2] - I[0]) * w[2] * w[0], (I[0] - I[1]) * w[0] * w[1])):
        return None
    lo, mid, hi = sorted(range(3), key=I.__getitem__)  # stable, like argsort(kind="stable")
    gap_mid = I[lo] * (I[lo] - I[mid]) * w[lo] ** 2 + I[hi] * (I[hi] - I[mid]) * w[hi] ** 2
    axes = (lo, mid, hi) if gap_mid >= 0.0 else (hi, mid, lo)
    # row i of the solver frame is principal axis axes[i] times signs[i]; a proper rotation
    signs = [_permutation_sign(axes), 1.0, 1.0]
    if signs[2] * w[axes[2]] < 0.0:  # rotate the solver frame by pi about its axis 1: m3 > 0
        signs[1], signs[2] = -signs[1], -signs[2]
    if signs[0] * w[axes[0]] < 0.0:  # rotate by pi about axis 3: m1(0) >= 0, so u0 lies in [-K, K]
        signs[0], signs[1] = -signs[0], -signs[1]
    S = np.zeros((3, 3))
    S[[0, 1, 2], list(axes)] = signs
    J = [I[axis] for axis in axes]
    ws = [sign * w[axis] for sign, axis in zip(signs, axes)]
    d21, d31, d32 = J[1] - J[0], J[2] - J[0], J[2] - J[1]
    w1s, w2s, w3s = (v * v for v in ws)
    P1 = J[1] * d21 * w2s + J[2] * d31 * w3s
    P2 = -J[0] * d21 * w1s + J[2] * d32 * w3s
    P3 = J[0] * d31 * w1s + J[1] * d32 * w2s
    mc = min(max(d31 * P2 / (d32 * P1), 0.0), 1.0)  # >= 0 by the choice of axis 3; clip rounding
    n = -J[2] * d21 / (J[0] * d32)
    rate = math.sqrt(d32 * P1 / (J[0] * J[1] * J[2]))
    a = math.sqrt(P3 / (J[0] * d31))
    b = math.copysign(math.sqrt(P3 / (J[1] * d32)), d32)
    c = math.sqrt(P1 / (J[2] * d31))
    jacobi = JacobiElliptic(mc, n)
    sn0, cn0, dn0 = min(max(ws[1] / b, -1.0), 1.0), ws[0] / a, ws[2] / c
    return Polhode(
        to_solver=S,
        moments=np.array(J),
        amplitudes=np.array([a, b, c]),
        rate=rate,
        initial_phase=float(jacobi.incomplete_first_kind(sn0, cn0, dn0)),
        momentum=math.hypot(J[0] * ws[0], J[1] * ws[1], J[2] * ws[2]),
        jacobi=jacobi,
        initial=jacobi.values_at(sn0, cn0, dn0),
    )


@dataclass(frozen=True)
class _StackedPolhode:
    """What :meth:`PolhodeAttitude.__call__` reads of a polhode, as columns over bodies."""

    jacobi: JacobiElliptic
    rate: np.ndarray
    initial_phase: np.ndarray
    momentum: np.ndarray


def _permutation_sign(axes) -> float:
    inversions = sum(axes[i] > axes[j] for i in range(3) for j in range(i + 1, 3))
    return -1.0 if inversions % 2 else 1.0


class PolhodeAttitude:
    """Exact ``(omega_F, q_NF)`` at any times, from ``q_NF(0)``, for a frame F fixed in the body with
    ``omega_S = solver_from_frame @ omega_F`` (the propagator's body frame).

    Per sample: ``omega_F = (cn, sn, dn) diag(a, b, c) C`` and ``q_NF = L ⊗ Rz(psi) ⊗ Q(m) ⊗ q_SF``; the
    constant left and right factors are one 4x4 matrix, and ``Rz(psi) ⊗ Q(m)`` is written out
    (``Q(m)`` has no z part, ``Rz`` only z and w)."""

    def __init__(self, polhode: Polhode, q_NF0: np.ndarray, solver_from_frame: np.ndarray):
        self.polhode = polhode
        C = np.asarray(solver_from_frame, dtype=float)
        J, (a, b, c) = polhode.moments.tolist(), polhode.amplitudes.tolist()
        self._rate_matrix = polhode.amplitudes[:, None] * C  # omega_F = (cn, sn, dn) @ this
        self._momentum_amplitudes = (J[0] * a, J[1] * b, J[2] * c)  # m = (cn, sn, dn) * these
        self._direction = math.copysign(1.0, b)  # sign(J3 - J2)
        self._lever = (self._momentum_amplitudes[0], abs(self._momentum_amplitudes[1]))  # A, B
        self._psi_rate = polhode.momentum / J[0]
        self._psi_integral_gain = polhode.momentum * (J[2] - J[0]) * polhode.jacobi.n / (J[0] * J[2] * polhode.rate)
        v0 = polhode.initial
        self._psi_offset = self._angle_terms(v0) - self._psi_integral_gain * v0.sn2_integral
        m0 = [amplitude * value for amplitude, value in zip(self._momentum_amplitudes, (v0.cn, v0.sn, v0.dn))]
        arc0 = np.array([m0[1], -m0[0], 0.0, polhode.momentum + m0[2]])
        arc0 /= np.linalg.norm(arc0)
        q_SF = quaternion.from_matrix(C)
        q_NS0 = quaternion.multiply(q_NF0, quaternion.conjugate(q_SF))
        left = quaternion.multiply(q_NS0, quaternion.conjugate(arc0))
        self._frame_change = quaternion.product_matrix(left, q_SF).T

    @staticmethod
    def stack(attitudes) -> "PolhodeAttitude":
        """Many bodies off the separatrix at once: called with times ``(M,)`` it gives ``(N, M, 3)``
        rates and ``(N, M, 4)`` attitudes, body ``i`` exactly as ``attitudes[i]`` gives it alone."""
        def column(values):
            return np.array(values, dtype=float)[:, None]

        polhodes = [a.polhode for a in attitudes]
        stacked = object.__new__(PolhodeAttitude)
        stacked.polhode = _StackedPolhode(JacobiElliptic.stack([p.jacobi for p in polhodes]),
                                          column([p.rate for p in polhodes]),
                                          column([p.initial_phase for p in polhodes]),
                                          column([p.momentum for p in polhodes]))
        stacked._rate_matrix = np.stack([a._rate_matrix for a in attitudes])
        stacked._frame_change = np.stack([a._frame_change for a in attitudes])
        stacked._momentum_amplitudes = tuple(column(values) for values in zip(*(a._momentum_amplitudes
                                                                                  for a in attitudes)))
        stacked._lever = tuple(column(values) for values in zip(*(a._lever for a in attitudes)))
        for name in ("_direction", "_psi_rate", "_psi_integral_gain", "_psi_offset"):
            setattr(stacked, name, column([getattr(a, name) for a in attitudes]))
        return stacked

    def _angle_terms(self, v):
        """Continuous angle of ``(m1, m2)``: ``sign(J3-J2) (am + atan2((B-A) sn cn, A cn^2 + B sn^2))``."""
        A, B = self._lever
        wobble = np.arctan2((B - A) * (v.sn * v.cn), A * (v.cn * v.cn) + B * (v.sn * v.sn))
        return self._direction * (v.am + wobble)

    def __call__(self, t: np.ndarray):
        p = self.polhode
        v = p.jacobi(p.rate * t + p.initial_phase)
        omega_F = _combine((v.cn, v.sn, v.dn), self._rate_matrix)
        psi = self._psi_rate * t + self._psi_integral_gain * v.sn2_integral - self._angle_terms(v) + self._psi_offset
        half = 0.5 * psi
        m_amp = self._momentum_amplitudes
        m0, m1 = m_amp[0] * v.cn, m_amp[1] * v.sn
        arc_w = p.momentum + m_amp[2] * v.dn  # m3 > 0: no cancellation
        # Q(m) = (m2, -m1, 0, |m| + m3) / sqrt(2 |m| (|m| + m3)), its norm in closed form
        scale = 1.0 / np.sqrt((2.0 * p.momentum) * arc_w)
        cos_half, sin_half = np.cos(half) * scale, np.sin(half) * scale
        about_H_arc = (cos_half * m1 + sin_half * m0, sin_half * m1 - cos_half * m0, sin_half * arc_w, cos_half * arc_w)
        return omega_F, _combine(about_H_arc, self._frame_change)


def _combine(columns, matrix: np.ndarray) -> np.ndarray:
    """``np.stack(columns, -1) @ matrix``, summed element by element rather than by BLAS, whose
    kernels (and so roundings) change with the number of rows: a sample must not depend on how many
    were requested with it. Columns ``(M,)`` with a matrix ``(k, l)``, or ``(N, M)`` with ``(N, k, l)``
    (a stack of bodies: the same operations, row by row)."""
    total = columns[0][..., None] * matrix[..., None, 0, :]
    for i, column in enumerate(columns[1:], start=1):
        total += column[..., None] * matrix[..., None, i, :]
    return total


def _angle(vector: np.ndarray, axial: float, axis: int) -> float:
    """Acute angle between ``vector`` and the line of principal axis ``axis``."""
    transverse = float(np.linalg.norm(np.delete(vector, axis)))
    return float(np.arctan2(transverse, axial))


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))


def classify_motion(body: RigidBody, omega_B) -> MotionRegime:
    """The regime of the torque-free motion starting at ``omega_B`` (seed 000 and 002)."""
    omega_P = body.to_principal(omega_B)
    I = body.moments
    lo, mid, hi = np.argsort(I, kind="stable")
    scale = float(np.max(I))
    equal_lo = I[mid] - I[lo] <= EQUAL_MOMENTS_RTOL * scale
    equal_hi = I[hi] - I[mid] <= EQUAL_MOMENTS_RTOL * scale
    if not np.any(omega_P):
        return MotionRegime("at_rest")
    if equal_lo and equal_hi:
        return MotionRegime("sphere")
    gaps = body.momentum_energy_gaps(omega_B)
    two_T = float(2.0 * body.kinetic_energy(omega_B))
    distance = float(gaps[mid] / (two_T * I[mid]))
    polhode = solve_polhode(I, omega_P)
    if polhode is None:
        axis_index = int(np.argmax(np.abs(omega_P)))
        if (equal_lo and axis_index in (lo, mid)) or (equal_hi and axis_index in (mid, hi)):
            axis = "symmetric-plane"
        else:
            axis = {lo: "minor", mid: "intermediate", hi: "major"}[axis_index]
        stable = "unstable" if axis == "intermediate" else "marginally stable"
        return MotionRegime("pure_spin", axis, stable, separatrix_distance=distance)
    period = polhode.polhode_period
    if equal_lo or equal_hi:
        symmetry_axis = hi if equal_lo else lo
        transverse = I[mid]
        precession = (I[symmetry_axis] / transverse - 1.0) * float(omega_P[symmetry_axis])
        kind = "axisymmetric_oblate" if equal_lo else "axisymmetric_prolate"
        # The cones of seed 000: the body cone is swept by w about the symmetry axis, the space cone
        # by w about H; the symmetry axis precesses about H_N at |H| / I_transverse.
        axial = abs(float(omega_P[symmetry_axis]))
        H_P = I * omega_P
        return MotionRegime(kind, polhode_period=period, precession_rate=precession,
                            body_cone_angle=_angle(omega_P, axial, symmetry_axis),
                            space_cone_angle=_angle_between(omega_P, H_P),
                            inertial_precession_rate=float(np.linalg.norm(H_P)) / transverse)
    if polhode.jacobi.mc == 0.0:
        kind = "separatrix"
    else:
        kind = "major_axis_polhode" if gaps[mid] > 0.0 else "minor_axis_polhode"
    return MotionRegime(
        kind, polhode_period=period, flip_period=0.5 * period, separatrix_distance=distance
    )
