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

from dataclasses import dataclass

import numpy as np

from . import quaternion
from .elliptic import JacobiElliptic
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

    @property
    def polhode_period(self) -> float:
        return 4.0 * self.jacobi.quarter_period / self.rate

    def rates(self, values) -> np.ndarray:
        """``omega_S`` from the Jacobi values at ``u = rate t + initial_phase``."""
        return np.stack([values.cn, values.sn, values.dn], axis=-1) * self.amplitudes


def solve_polhode(moments_P: np.ndarray, omega_P: np.ndarray) -> Polhode | None:
    """Choose the solver frame and regime once; ``None`` for a stationary motion (rest, a sphere,
    or a spin about a principal axis), whose rate is constant."""
    I = np.asarray(moments_P, dtype=float)
    w = np.asarray(omega_P, dtype=float)
    # Euler's equations' right-hand side, exactly zero only for a relative equilibrium.
    if not np.any([(I[1] - I[2]) * w[1] * w[2], (I[2] - I[0]) * w[2] * w[0], (I[0] - I[1]) * w[0] * w[1]]):
        return None
    lo, mid, hi = np.argsort(I, kind="stable")
    gap_mid = I[lo] * (I[lo] - I[mid]) * w[lo] ** 2 + I[hi] * (I[hi] - I[mid]) * w[hi] ** 2
    axes = (lo, mid, hi) if gap_mid >= 0.0 else (hi, mid, lo)
    S = np.zeros((3, 3))
    S[[0, 1, 2], list(axes)] = 1.0
    if np.linalg.det(S) < 0.0:
        S[0] = -S[0]
    J = I[list(axes)]
    ws = S @ w
    if ws[2] < 0.0:  # rotate the solver frame by pi about its axis 1: m3 > 0
        S[1:] = -S[1:]
    ws = S @ w
    if ws[0] < 0.0:  # rotate by pi about axis 3: m1(0) >= 0, so u0 lies in [-K, K]
        S[:2] = -S[:2]
    ws = S @ w
    d21, d31, d32 = J[1] - J[0], J[2] - J[0], J[2] - J[1]
    w1s, w2s, w3s = ws**2
    P1 = J[1] * d21 * w2s + J[2] * d31 * w3s
    P2 = -J[0] * d21 * w1s + J[2] * d32 * w3s
    P3 = J[0] * d31 * w1s + J[1] * d32 * w2s
    mc = min(max(d31 * P2 / (d32 * P1), 0.0), 1.0)  # >= 0 by the choice of axis 3; clip rounding
    n = -J[2] * d21 / (J[0] * d32)
    rate = float(np.sqrt(d32 * P1 / (J[0] * J[1] * J[2])))
    a = np.sqrt(P3 / (J[0] * d31))
    b = np.copysign(np.sqrt(P3 / (J[1] * d32)), d32)
    c = np.sqrt(P1 / (J[2] * d31))
    jacobi = JacobiElliptic(mc, n)
    cn0, sn0, dn0 = ws[0] / a, np.clip(ws[1] / b, -1.0, 1.0), ws[2] / c
    u0 = float(jacobi.incomplete_first_kind(sn0, cn0, dn0))
    return Polhode(
        to_solver=S,
        moments=J,
        amplitudes=np.array([a, b, c]),
        rate=rate,
        initial_phase=u0,
        momentum=float(np.linalg.norm(J * ws)),
        jacobi=jacobi,
    )


class PolhodeAttitude:
    """Exact ``(omega_S, q_NS)`` of the solver frame at any times, from ``q_NS(0)``."""

    def __init__(self, polhode: Polhode, q_NS0: np.ndarray):
        self.polhode = polhode
        J = polhode.moments
        n = polhode.jacobi.n
        self._psi_rate = polhode.momentum / J[0]
        self._psi_integral_gain = polhode.momentum * (J[2] - J[0]) * n / (J[0] * J[2] * polhode.rate)
        self._direction = np.sign(polhode.amplitudes[1])  # sign(J3 - J2)
        self._lever = np.array([J[0] * polhode.amplitudes[0], J[1] * abs(polhode.amplitudes[1])])
        v0 = polhode.jacobi(np.array([polhode.initial_phase]))
        self._angle0 = self._angle_terms(v0)[0]
        self._s0 = v0.sn2_integral[0]
        self._left = quaternion.multiply(q_NS0, quaternion.conjugate(self._shortest_arc(v0)[0]))

    def _shortest_arc(self, v) -> np.ndarray:
        """Unit quaternion of the rotation taking ``m/|m|`` (S coordinates) to ``e_z``."""
        m = self.polhode.rates(v) * self.polhode.moments
        q = np.stack([m[:, 1], -m[:, 0], np.zeros_like(v.cn), self.polhode.momentum + m[:, 2]], -1)
        return q / np.linalg.norm(q, axis=-1, keepdims=True)

    def _angle_terms(self, v) -> np.ndarray:
        """Continuous angle of ``(m1, m2)``: ``sign(J3-J2) (am + atan2((B-A) sn cn, A cn^2 + B sn^2))``."""
        A, B = self._lever
        wobble = np.arctan2((B - A) * v.sn * v.cn, A * v.cn**2 + B * v.sn**2)
        return self._direction * (v.am + wobble)

    def __call__(self, t: np.ndarray):
        p = self.polhode
        v = p.jacobi(p.rate * t + p.initial_phase)
        omega_S = p.rates(v)
        psi = (
            self._psi_rate * t
            + self._psi_integral_gain * (v.sn2_integral - self._s0)
            - (self._angle_terms(v) - self._angle0)
        )
        half = 0.5 * psi
        zero = np.zeros_like(half)
        about_H = np.stack([zero, zero, np.sin(half), np.cos(half)], axis=-1)
        q_NS = quaternion.multiply(self._left, quaternion.multiply(about_H, self._shortest_arc(v)))
        return omega_S, q_NS


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
