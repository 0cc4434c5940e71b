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
The kind of torque-free motion a state starts (seeds 000 and 002), and of a free gyrostat's.

Rest, a sphere, a pure spin (stable or not), the axisymmetric cones, the polhodes about the major
and minor axes and the separatrix between them, with the periods and angles each has.

A free gyrostat (``I w' + w x (I w + h) = 0``, ``h`` along a principal axis: issue 43) has
equilibria and separatrices of its own, which move with ``h`` (:func:`classify_gyrostat`). With
``h`` oblique to the principal axes (:func:`classify_oblique_gyrostat`) its equilibria and the
distance to the nearest separatrix are found the same way, its period is the closed form's, and
what the motion circles is not named.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gyrostat import solve_gyrostat, solver_frame
from .gyrostat_oblique import solve_oblique
from .polhode import solve_polhode

# Moments closer than this (relative) are *labelled* equal in the regime report; the propagators
# never use it: their formulas stay exact as two moments approach each other.
EQUAL_MOMENTS_RTOL = 1e-12


@dataclass(frozen=True)
class MotionRegime:
    """
    What kind of torque-free motion a state starts.

    Periods are in seconds (``inf`` where the motion never repeats, ``nan`` where the notion does
    not apply).
    """

    kind: str  # at_rest | sphere | pure_spin | axisymmetric_oblate | axisymmetric_prolate |
    #            major_axis_polhode | minor_axis_polhode | separatrix
    axis: str = ''  # for pure_spin: major | intermediate | minor | symmetric-plane
    stability: str = ''  # for pure_spin: "marginally stable" or "unstable" (seed 002)
    polhode_period: float = float('nan')  # period of the body rates
    flip_period: float = float('nan')  # time between reversals of the intermediate-axis rate
    precession_rate: float = float('nan')  # axisymmetric: w_p = (I3/IT - 1) w3 (seed 000)
    separatrix_distance: float = float('nan')  # (H^2/2T - I_mid) / I_mid
    body_cone_angle: float = float('nan')  # axisymmetric: between w and the symmetry axis, rad
    space_cone_angle: float = float('nan')  # axisymmetric: between w and H, rad
    # axisymmetric: symmetry axis about H_N, |H|/I_T
    inertial_precession_rate: float = float('nan')

    def summary(self) -> str:
        parts = [self.kind.replace('_', ' ')]
        if self.axis:
            parts.append(f'about the {self.axis} axis ({self.stability})')
        for label, value in (
            ('polhode period', self.polhode_period),
            ('flip period', self.flip_period),
            ('body-frame precession rate', self.precession_rate),
        ):
            if not np.isnan(value):
                parts.append(f'{label} {value:.6g}' + (' rad/s' if 'rate' in label else ' s'))
        if not np.isnan(self.body_cone_angle):
            parts.append(
                f'body cone angle {np.degrees(self.body_cone_angle):.6g} deg, space cone angle '
                f'{np.degrees(self.space_cone_angle):.6g} deg, symmetry axis precesses about H at '
                f'{self.inertial_precession_rate:.6g} rad/s'
            )
        return ', '.join(parts)


def _angle(vector: np.ndarray, axial: float, axis: int) -> float:
    """Acute angle between ``vector`` and the line of principal axis ``axis``."""
    transverse = float(np.linalg.norm(np.delete(vector, axis)))
    return float(np.arctan2(transverse, axial))


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))


def classify_motion(body, omega_B) -> MotionRegime:
    """
    Classify the torque-free motion of ``body`` starting at ``omega_B`` (seed 000 and 002).

    ``body``: a :class:`~torquefree_ros.core.body.rigid_body.RigidBody` (its moments, principal
    frame and invariants).
    """
    omega_P = body.to_principal(omega_B)
    moments = body.moments
    lo, mid, hi = np.argsort(moments, kind='stable')
    scale = float(np.max(moments))
    equal_lo = moments[mid] - moments[lo] <= EQUAL_MOMENTS_RTOL * scale
    equal_hi = moments[hi] - moments[mid] <= EQUAL_MOMENTS_RTOL * scale
    if not np.any(omega_P):
        return MotionRegime('at_rest')
    if equal_lo and equal_hi:
        return MotionRegime('sphere')
    gaps = body.momentum_energy_gaps(omega_B)
    two_T = float(2.0 * body.kinetic_energy(omega_B))
    distance = float(gaps[mid] / (two_T * moments[mid]))
    polhode = solve_polhode(moments, omega_P)
    if polhode is None:
        axis_index = int(np.argmax(np.abs(omega_P)))
        if (equal_lo and axis_index in (lo, mid)) or (equal_hi and axis_index in (mid, hi)):
            axis = 'symmetric-plane'
        else:
            axis = {lo: 'minor', mid: 'intermediate', hi: 'major'}[axis_index]
        stable = 'unstable' if axis == 'intermediate' else 'marginally stable'
        return MotionRegime('pure_spin', axis, stable, separatrix_distance=distance)
    period = polhode.polhode_period
    if equal_lo or equal_hi:
        symmetry_axis = hi if equal_lo else lo
        transverse = moments[mid]
        precession = (moments[symmetry_axis] / transverse - 1.0) * float(omega_P[symmetry_axis])
        kind = 'axisymmetric_oblate' if equal_lo else 'axisymmetric_prolate'
        # The cones of seed 000: the body cone is swept by w about the symmetry axis, the space
        # cone by w about H; the symmetry axis precesses about H_N at |H| / I_transverse.
        axial = abs(float(omega_P[symmetry_axis]))
        H_P = moments * omega_P
        return MotionRegime(
            kind,
            polhode_period=period,
            precession_rate=precession,
            body_cone_angle=_angle(omega_P, axial, symmetry_axis),
            space_cone_angle=_angle_between(omega_P, H_P),
            inertial_precession_rate=float(np.linalg.norm(H_P)) / transverse,
        )
    if polhode.jacobi.mc == 0.0:
        kind = 'separatrix'
    else:
        kind = 'major_axis_polhode' if gaps[mid] > 0.0 else 'minor_axis_polhode'
    return MotionRegime(
        kind, polhode_period=period, flip_period=0.5 * period, separatrix_distance=distance
    )


#: a gyrostat equilibrium whose tangent Hessian's determinant is within this of zero (relative to
#: the squared largest inverse moment) is *labelled* degenerate (a bifurcation: h at the value
#: where two equilibria merge); the propagator's formulas do not use it
DEGENERATE_RTOL = 1e-12


@dataclass(frozen=True)
class GyrostatEquilibrium:
    """A relative equilibrium on the momentum sphere ``|m| = H``: ``m`` along it, its kind."""

    momentum: tuple  # m (principal frame of the gyrostat's inertia)
    kind: str  # centre (stable) | saddle (unstable, a separatrix passes) | degenerate
    energy: float  # 2T there: a saddle's is its separatrix's


@dataclass(frozen=True)
class GyrostatRegime:
    """
    What kind of motion a free gyrostat's state starts, and the equilibria of its momentum sphere.

    The same reading as :class:`MotionRegime` (``kind``, ``polhode_period``, ``summary``) for the
    node's log and diagnostics; periods in seconds.
    """

    kind: str  # gyrostat_rotor_axis_polhode | gyrostat_transverse_axis_polhode |
    #            gyrostat_separatrix | gyrostat_uniform_precession | gyrostat_relative_equilibrium
    #            | gyrostat_oblique_polhode (h oblique: a periodic motion, what it circles unnamed)
    #            | gyrostat_oblique (h oblique, a state the closed form refuses: not classified)
    rotor_axis: int  # the principal axis h lies along (of the gyrostat's inertia); -1: oblique
    rotor_momentum: float  # h, N m s, signed; oblique: |h|
    momentum: float  # |m| = |I w + h|
    circled: str = ''  # what the motion circles: 'the rotor axis' or 'principal axis k'
    polhode_period: float = float('nan')  # of the body rates
    flip_period: float = float('nan')  # (a free body's notion: not the gyrostat's)
    separatrix_distance: float = float('nan')  # 2T / 2T_sep - 1 for the nearest saddle
    equilibria: tuple = ()  # GyrostatEquilibrium, the poles first (oblique: by energy)
    rotor_vector: tuple = ()  # oblique: h in the principal frame of the gyrostat's inertia
    energy: float = float('nan')  # 2T = w . I w

    def summary(self) -> str:
        if self.rotor_vector:
            h = ', '.join(f'{v:.6g}' for v in self.rotor_vector)
            where = f'h ({h}) N m s in the principal frame, off every principal axis'
        else:
            where = (
                f'h {self.rotor_momentum:.6g} N m s along principal axis {self.rotor_axis + 1}'
            )
        parts = [
            f'free gyrostat ({where}, |I w + h| {self.momentum:.6g}): '
            + self.kind.replace('gyrostat_', '').replace('_', ' ')
        ]
        if self.circled:
            parts.append(f'about {self.circled}')
        if not np.isnan(self.polhode_period):
            parts.append(f'polhode period {self.polhode_period:.6g} s')
        if not np.isnan(self.separatrix_distance):
            parts.append(f'separatrix distance {self.separatrix_distance:.3g}')
        if not np.isnan(self.energy):
            parts.append(f'2T {self.energy:.6g}')
        shown = []
        for equilibrium in self.equilibria:
            m = ', '.join(f'{v:.4g}' for v in equilibrium.momentum)
            shown.append(f'm = ({m}) {equilibrium.kind}')
        if shown:
            parts.append('equilibria ' + '; '.join(shown))
        return ', '.join(parts)


def gyrostat_equilibria(moments, rotor: int, h: float, H: float) -> tuple:
    """
    Return the relative equilibria of the gyrostat on the sphere ``|m| = H``, with their kinds.

    ``m x w = 0`` with ``w_i = (m_i - h δ_i,rotor) / J_i``: the poles ``± H e_rotor`` always and,
    in the plane of the rotor axis and transverse axis ``k``, ``m_rotor = h J_k / (J_k - J_r)``
    while ``|m_rotor| < H`` (Elipe & Lanchares 2008; they merge into a pole as ``|h|`` grows).
    The kind is the sign of the energy's Hessian on the sphere (``2 T`` has the Lagrange
    multiplier ``λ = w . m / H^2``; tangent Hessian ``diag(1/J) - λ``): a centre when definite,
    a saddle when not, its separatrix at its energy. Floats: labels for a report, not constants
    of the solution.
    """
    J = np.asarray(moments, dtype=float)
    inverse = 1.0 / J
    candidates = []
    for sign in (1.0, -1.0):
        m = np.zeros(3)
        m[rotor] = sign * H
        candidates.append(m)
    for k in (a for a in range(3) if a != rotor):
        if J[k] == J[rotor]:
            continue
        along = h * J[k] / (J[k] - J[rotor])
        if abs(along) >= H:
            continue
        across = np.sqrt(H * H - along * along)
        for sign in (1.0, -1.0):
            m = np.zeros(3)
            m[rotor], m[k] = along, sign * across
            candidates.append(m)
    equilibria = []
    for m in candidates:
        w = m * inverse
        w[rotor] -= h * inverse[rotor]
        multiplier = float(w @ m) / (H * H)
        equilibria.append(_equilibrium(m, m / H, w, J, inverse, multiplier))
    return tuple(equilibria)


def _equilibrium(m, unit, w, J, inverse, multiplier: float) -> 'GyrostatEquilibrium':
    """
    Classify the equilibrium ``m`` of the momentum sphere (``unit`` its direction, ``w`` its rate).

    By the energy's Hessian across ``m`` on the sphere, ``A - multiplier`` projected on the plane
    across it: definite, a centre; indefinite, a saddle; singular to ``DEGENERATE_RTOL``,
    degenerate.
    """
    tangent = np.linalg.svd(unit[None, :])[2][1:]  # two unit vectors across m
    hessian = tangent @ np.diag(inverse - multiplier) @ tangent.T
    determinant = float(np.linalg.det(hessian))
    if abs(determinant) <= DEGENERATE_RTOL * float(inverse.max()) ** 2:
        kind = 'degenerate'
    else:
        kind = 'centre' if determinant > 0.0 else 'saddle'
    return GyrostatEquilibrium(tuple(m.tolist()), kind, float(w @ (J * w)))


def classify_gyrostat(moments, omega_P, rotor: int, h: float) -> GyrostatRegime:
    """
    Classify the free gyrostat's motion from ``omega_P`` (principal frame of ``moments``).

    ``h`` (nonzero) along principal axis ``rotor``. The motion's regime is the closed form's own
    (:func:`.gyrostat.solve_gyrostat`: the turning points and what they circle), its period the
    rates' (``4K / lambda`` or ``2K / lambda``); the equilibria and the distance to the nearest
    saddle's separatrix from :func:`gyrostat_equilibria`.
    """
    J = np.asarray(moments, dtype=float)
    w = np.asarray(omega_P, dtype=float)
    m = J * w
    m[rotor] += h
    H = float(np.linalg.norm(m))
    equilibria = gyrostat_equilibria(J, rotor, h, H)
    two_T = float(w @ (J * w))
    saddles = [e.energy for e in equilibria if e.kind == 'saddle']
    distance = float('nan')
    if saddles:
        nearest = min(saddles, key=lambda energy: abs(two_T - energy))
        distance = two_T / nearest - 1.0 if nearest else float('nan')
    frame = solver_frame(J, np.eye(3), rotor, h)
    others = [k for k in range(3) if k != rotor]
    common = {
        'rotor_axis': rotor,
        'rotor_momentum': float(h),
        'momentum': H,
        'separatrix_distance': distance,
        'equilibria': equilibria,
    }
    J1, J2, _ = frame.moments
    omega_S = [sum(r * v for r, v in zip(row, w.tolist())) for row in frame.rows]
    if J1 == J2:  # a rotor on the symmetry axis: m_rotor constant, w turns uniformly about it
        kappa = w[rotor] - m[rotor] / J1
        period = 2.0 * np.pi / abs(kappa) if kappa else float('nan')
        return GyrostatRegime(
            'gyrostat_uniform_precession', circled='the rotor axis', polhode_period=period,
            **common,
        )
    motion = solve_gyrostat(frame.moments, omega_S, h)
    if motion is None:
        return GyrostatRegime('gyrostat_relative_equilibrium', **common)
    circled = (
        'the rotor axis'
        if motion.reference == 2
        else f'principal axis {others[motion.reference] + 1}'
    )
    # the rates repeat after 4K in u, or 2K when every transverse component holds sn and cn
    # together or neither (z is a function of sn^2 in the sn2 form; of cn in the cn form)
    even = all((powers[0] + powers[1]) % 2 == 0 for powers in motion.powers)
    period = motion.period * (2.0 if motion.form == 'sn2' and not even else 1.0)
    return GyrostatRegime(
        f'gyrostat_{motion.regime}',
        circled=circled,
        polhode_period=period / motion.rate,
        **common,
    )


def oblique_equilibria(moments, h, H: float) -> tuple:
    """
    Return the relative equilibria on ``|m| = H`` of a gyrostat with any ``h``, with their kinds.

    ``m x w = 0``, ``w = A (m - h)``: ``A (m - h) = mu m``, so ``m_i = h_i / (1 - mu J_i)`` and
    ``sum h_i^2 / (1 - mu J_i)^2 = H^2``, a sextic in ``mu`` (Basak 2009; a quartic when one
    ``h_i`` is zero) whose real roots are the equilibria (two to six); where ``h_i = 0``,
    ``mu = 1 / J_i`` adds the pair with
    ``m_i = ± sqrt(H^2 - sum of the others' squares)``. Each root is polished by Newton's method
    on the sum; the kind as :func:`gyrostat_equilibria`'s (``lambda = mu``), sorted by energy.
    Floats: labels for a report, not constants of the solution.
    """
    J = np.asarray(moments, dtype=float)
    h = np.asarray(h, dtype=float)
    # over the components of h that are not zero (each zero one's factor divides the sextic)
    terms = [i for i in range(3) if h[i] != 0.0]
    factors = {i: np.polynomial.Polynomial([1.0, -J[i]]) ** 2 for i in terms}
    sextic = -H * H * np.prod([factors[i] for i in terms])
    for i in terms:
        sextic = sextic + h[i] * h[i] * np.prod([factors[j] for j in terms if j != i] or [1.0])
    candidates = []
    for root in sextic.roots():
        if abs(root.imag) > 1e-6 * max(1.0, abs(root.real)):
            continue
        mu = float(root.real)
        for _ in range(8):  # Newton's method on sum h_i^2 / (1 - mu J_i)^2 - H^2
            gaps = 1.0 - mu * J
            if np.any(gaps == 0.0):
                break
            value = float(np.sum(h * h / gaps**2)) - H * H
            slope = float(np.sum(2.0 * J * h * h / gaps**3))
            if slope == 0.0:
                break
            mu -= value / slope
        gaps = 1.0 - mu * J
        if np.all(gaps != 0.0):
            candidates.append((mu, h / gaps))
    for i in range(3):
        others = [j for j in range(3) if j != i]
        if h[i] != 0.0 or any(J[j] == J[i] for j in others):
            continue  # (equal moments: a circle of equilibria or none, not listed)
        m = np.zeros(3)
        for j in others:
            m[j] = h[j] / (1.0 - J[j] / J[i])
        rest = H * H - float(m @ m)
        if rest > 0.0:
            for sign in (1.0, -1.0):
                pair = m.copy()
                pair[i] = sign * np.sqrt(rest)
                candidates.append((1.0 / J[i], pair))
    inverse = 1.0 / J
    equilibria = []
    for mu, m in candidates:
        if not H > 0.0 or abs(float(np.linalg.norm(m)) - H) > 1e-8 * H:
            continue  # (a root of a factor h_i = 0 cleared, off the sphere)
        w = (m - h) * inverse
        equilibria.append(_equilibrium(m, m / np.linalg.norm(m), w, J, inverse, mu))
    return tuple(sorted(equilibria, key=lambda e: e.energy))


def classify_oblique_gyrostat(moments, omega_P, h_P) -> GyrostatRegime:
    """
    Classify the free gyrostat's motion from ``omega_P`` with ``h_P`` oblique (principal frame).

    The closed form (:func:`.gyrostat_oblique.solve_oblique`) says whether the state is a relative
    equilibrium (``None``), exactly on a separatrix (``mc = 0``: no period) or a periodic
    motion, whose period (``2K / r``) is the rates'. What a periodic motion circles is not named
    (``gyrostat_oblique_polhode``); a state the closed form refuses otherwise is
    ``gyrostat_oblique``, unclassified. The equilibria and the distance to the nearest saddle's
    separatrix from :func:`oblique_equilibria`; ``|I w + h|`` and ``2T``, the conserved
    quantities, always.
    """
    J = np.asarray(moments, dtype=float)
    w = np.asarray(omega_P, dtype=float)
    h = np.asarray(h_P, dtype=float)
    m = J * w + h
    H = float(np.linalg.norm(m))
    two_T = float(w @ (J * w))
    equilibria = oblique_equilibria(J, h, H)
    saddles = [e.energy for e in equilibria if e.kind == 'saddle']
    distance = float('nan')
    if saddles:
        nearest = min(saddles, key=lambda energy: abs(two_T - energy))
        distance = two_T / nearest - 1.0 if nearest else float('nan')
    common = {
        'rotor_axis': -1,
        'rotor_momentum': float(np.linalg.norm(h)),
        'momentum': H,
        'separatrix_distance': distance,
        'equilibria': equilibria,
        'rotor_vector': tuple(h.tolist()),
        'energy': two_T,
    }
    try:
        motion = solve_oblique(J, w, h)
    except ValueError:
        return GyrostatRegime('gyrostat_oblique', **common)
    if motion is None:
        return GyrostatRegime('gyrostat_relative_equilibrium', **common)
    if motion.mc == 0.0:  # the motion tends to a saddle: no period
        return GyrostatRegime('gyrostat_separatrix', polhode_period=float('inf'), **common)
    return GyrostatRegime('gyrostat_oblique_polhode', polhode_period=motion.period, **common)
