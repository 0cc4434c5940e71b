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
Compiled equations of motion and integrators for scenes with effects (numba, loaded on first use).

The right-hand side of :class:`~..propagators.dynamics.Dynamics` and the steps of the ``dop853``,
``rk4`` and ``lie_rk4`` propagators as scalar loops over one flat state ``y = (w, q, x)``, without
allocating per step: the caller owns every array (stages, dense-output coefficients, scratch).

A scene's motion is one float64 array, the *model* (built by :mod:`.compiled`)::

    [0:9]   inertia tensor, body frame, row by row     [9:18]  its inverse
    [18]    number of effect entries, then per entry: code, offset of its state in x (an
            effect with a slot: the slot's index in held), parameters

The tensor is the one Euler's equations are integrated with: the body's less the inertia effects
carry in their own states (reaction wheels' spin, ``Dynamics.tensor``). An effect packs one entry
or several of its code (a wheel each): its parameters are then a whole number of the code's
``PARAMETER_COUNTS``, and its state splits evenly among them.

Torques that are piecewise constant (``external_torque``, ``torque_command``'s hold) are not
entries: the driver resolves them where each smooth piece starts and passes them as ``held`` (the
sum held in the body frame, then the sum held in the inertial frame: ``HELD_TORQUES`` floats), as
the Python effects read theirs at ``segment_start``. After them ``held`` has one float per
component of the effects' flat state: the input an effect holds on the piece for that component
(a wheel's motor torque, ``MotionEffect.held_inputs``), zero where none. Each effect with a kernel
of its own has one section below, under its code; its Python definition (``core/effects``) names
the code and packs its parameters, and test_motion_kernels.py holds the two together on random
states.

A scene with an orbit has the *environment section* (``ENV_*``) after the held inputs: the
position and the magnetic field in the inertial frame on the piece's environment window, as
Chebyshev coefficients the driver copies from ``environment.place.Place`` where the piece starts
(window ends are breakpoints), which ``_environment`` sums at a stage's time. The environment
reaches the kernels as numbers, never as code: nothing here calls
``environment/environment_kernels.py``.

``held`` ends with the *slots*: the inputs an effect without a state of its own holds on the piece
(``held_slot_size`` floats, ``held_slot(segment_start)``: magnetorquers' applied dipole), effect
after effect in scene order. Such an effect's entry carries, in place of a state offset, the index
of its slot in ``held`` (the driver lays it out: ``drivers.held_slots``), so the slots need no
offset arithmetic here and the sections before them keep their places. Speed-mode reaction wheels
have a slot too, their drives' torque errors (scale, bias) a wheel, each wheel's entry keeping its
state offset and naming its pair's index as its last parameter::

    held = [body torque (3), inertial torque (3) | an input per state component (n_x)
            | the environment section (when the scene has an orbit) | the slots]

Every compiled function is in this one file on purpose: numba rebuilds a function's cache when its
own file changes, not when a file it calls into does (a stale kernel would survive an edit).

DOP853 is scipy's: its tableau (``scipy.integrate._ivp.dop853_coefficients``, passed in as arrays),
its error norm, step-size control (safety 0.9, factors 0.2 to 10, exponent -1/8), initial step
(Hairer, Nørsett & Wanner, II.4) and 7th-order dense output, operation for operation but for the
order of a few sums; ``rtol`` and ``atol`` mean what they mean there. The tableau's zeros are
skipped (34 of the 108 stage coefficients, 4 of 12 solution weights, 5 of 13 in each error
estimate, 16 of 64 interpolant weights): which coefficients are zero is read from scipy's tableau
and compiled in as a constant, so each sum is unrolled with only its terms, in the same order, and
the values still come from the arrays passed in. Adding ``K[j] * 0.0`` changed a sum by nothing
but, at most, the sign of an exact zero (and a NaN for an infinite K[j], where an overflowed step
is rejected either way).

Speed (figures: docs/bench/effects.md): every kernel is compiled without numba's runtime
(``_nrt=False``): they allocate nothing, so no reference is counted when an array is handed to an
inlined helper or sliced. The right-hand side and the effects are inlined by LLVM
(``forceinline``), not by numba's IR inliner, which re-types a callee at every call. The stages'
states are rows of the scratch arrays, by index: a slice is a new array struct.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.kernels import KernelFamily

# -- effect codes (a literal each: compiled code keeps what it read when it compiled) -------------
GRAVITY_GRADIENT = 1  # parameters: mean motion n, argument of latitude u0, the inertia tensor (9)
DAMPER = 2  # parameters: rotor inertia J, damping c; state: the rotor's rate nu (3)
ROTOR = 3  # parameters: the wheel's momentum h_B (3)
# a wheel each; parameters: spin axis g (3), Js, max torque, max speed, speed band, viscous b,
# Coulomb Fc, Coulomb band, Stribeck excess Fs - Fc, Stribeck speed, speed-loop gain (0: the
# held input is a motor torque), the index in held of the drive's torque error (scale, bias: the
# speed loop's output turned into scale u + bias, its effect's slot; 0: none); state: Js (Omega +
# g . w), then the wheel's angle. Wheels held at constant speed (mode hold) are a ROTOR entry.
REACTION_WHEEL = 4
# on the scene's orbit, reading the environment section of held; parameters: GM, the tensor (9)
ORBIT_GRAVITY_GRADIENT = 5
# parameters: the dipole m_B (3), the field's slot in the environment section (1: IGRF, 2: dipole)
RESIDUAL_DIPOLE = 6
# no state; its entry's offset is the index of its slot in held, the applied dipole m_B (3);
# parameters: the field's slot in the environment section (1: IGRF, 2: dipole)
MAGNETORQUERS = 7
#: parameters each code reads (per entry)
PARAMETER_COUNTS = {
    GRAVITY_GRADIENT: 11,
    DAMPER: 2,
    ROTOR: 3,
    REACTION_WHEEL: 14,
    ORBIT_GRAVITY_GRADIENT: 10,
    RESIDUAL_DIPOLE: 4,
    MAGNETORQUERS: 1,
}
MODEL_HEADER = 19  # tensor, inverse, entry count
HELD_TORQUES = 6  # held: the body-frame torque, the inertial-frame torque, then the held inputs
# the environment section, after the held inputs (at HELD_TORQUES + state size) when the scene has
# an orbit: the window's start (s), 2 / its length, the Chebyshev coefficients per quantity, then
# the coefficients, quantity by quantity (position, IGRF's field, the dipole's), axis by axis
ENV_START, ENV_SCALE, ENV_NODES, ENV_COEFFICIENTS = 0, 1, 2, 3

# -- solver state of a DOP853 run (a float64 array, kept by the caller between calls) -------------
T, H_ABS, T_OLD, H_PREVIOUS, T_BOUND, RTOL, ATOL, DENSE_READY, MIN_STEP = range(9)
SOLVER_WIDTH = 9
# what dop853_outputs returns
DONE, SEGMENT_END, RESTART, BUDGET, TOO_SMALL, STIFF = range(6)
SAFETY, MIN_FACTOR, MAX_FACTOR, ERROR_EXPONENT = 0.9, 0.2, 10.0, -1.0 / 8.0
STAGES, STAGES_EXTENDED, INTERPOLATOR_POWER = 12, 16, 7

# -- fixed-step methods ---------------------------------------------------------------------------
RK4, LIE_RK4 = 0, 1


# ==== effects ====================================================================================
# Each takes the state's scalars and returns scalars: the right-hand side reads the state once.


def _gravity_gradient(t, qx, qy, qz, qw, model, p):
    """
    Return the gravity-gradient torque ``3 n^2 e_B x (I e_B)`` (GravityGradient).

    ``e_B = R(q)^T (cos u, sin u, 0)``, ``u = u0 + n t``.
    """
    n = model[p]
    u = model[p + 1] + n * t
    e1, e2, e3 = _rotate_inverse(qx, qy, qz, qw, math.cos(u), math.sin(u), 0.0)
    i1 = model[p + 2] * e1 + model[p + 3] * e2 + model[p + 4] * e3
    i2 = model[p + 5] * e1 + model[p + 6] * e2 + model[p + 7] * e3
    i3 = model[p + 8] * e1 + model[p + 9] * e2 + model[p + 10] * e3
    k = 3.0 * n * n
    return k * (e2 * i3 - e3 * i2), k * (e3 * i1 - e1 * i3), k * (e1 * i2 - e2 * i1)


def _chebyshev(held, at, n, x):
    """
    Return ``sum_k c_k T_k(x)``, ``c_k = held[at + k]``, ``k < n`` (Clenshaw's recurrence).

    The operations of ``environment.place.clenshaw``, in its order.
    """
    b1 = 0.0
    b2 = 0.0
    for k in range(n - 1, 0, -1):
        b1, b2 = held[at + k] + 2.0 * x * b1 - b2, b1
    return held[at] + x * b1 - b2


def _environment(t, held, e, quantity):
    """
    Return a held quantity (``environment.place.QUANTITIES``) at ``t``: three scalars, inertial.

    ``e``: where the environment section begins in ``held``; its window's interpolant, as
    ``Place.evaluate`` sums it.
    """
    n = int(held[e + ENV_NODES])
    x = (t - held[e + ENV_START]) * held[e + ENV_SCALE] - 1.0
    at = e + ENV_COEFFICIENTS + 3 * n * quantity
    return _chebyshev(held, at, n, x), _chebyshev(held, at + n, n, x), _chebyshev(
        held, at + 2 * n, n, x
    )


def _orbit_gravity_gradient(t, qx, qy, qz, qw, model, p, held, e):
    """
    Return the gravity-gradient torque ``3 mu / r^5 r_B x (I r_B)`` on the scene's orbit.

    ``r_N`` held per window (GravityGradient on an orbit, the same operations).
    """
    x, y, z = _environment(t, held, e, 0)
    b1, b2, b3 = _rotate_inverse(qx, qy, qz, qw, x, y, z)
    r2 = x * x + y * y + z * z
    k = 3.0 * model[p] / (r2 * r2 * math.sqrt(r2))
    i1 = model[p + 1] * b1 + model[p + 2] * b2 + model[p + 3] * b3
    i2 = model[p + 4] * b1 + model[p + 5] * b2 + model[p + 6] * b3
    i3 = model[p + 7] * b1 + model[p + 8] * b2 + model[p + 9] * b3
    return k * (b2 * i3 - b3 * i2), k * (b3 * i1 - b1 * i3), k * (b1 * i2 - b2 * i1)


def _residual_dipole(t, qx, qy, qz, qw, model, p, held, e):
    """Return ``m x B_B`` of a dipole fixed in the body (ResidualDipole, the same operations)."""
    f1, f2, f3 = _environment(t, held, e, int(model[p + 3]))
    b1, b2, b3 = _rotate_inverse(qx, qy, qz, qw, f1, f2, f3)
    m1, m2, m3 = model[p], model[p + 1], model[p + 2]
    return m2 * b3 - m3 * b2, m3 * b1 - m1 * b3, m1 * b2 - m2 * b1


def _magnetorquers(t, qx, qy, qz, qw, model, p, held, e, slot):
    """
    Return ``m x B_B`` of the rods' applied dipole ``m = held[slot:slot + 3]`` (Magnetorquers).

    The same operations as its Python torque.
    """
    m1, m2, m3 = held[slot], held[slot + 1], held[slot + 2]
    f1, f2, f3 = _environment(t, held, e, int(model[p]))
    b1, b2, b3 = _rotate_inverse(qx, qy, qz, qw, f1, f2, f3)
    return m2 * b3 - m3 * b2, m3 * b1 - m1 * b3, m1 * b2 - m2 * b1


def _damper(w1, w2, w3, n1, n2, n3, model, p):
    """
    Return the torque ``c (nu - w)`` on the body and the rotor's ``nu'`` (Damper).

    ``nu' = -c/J (nu - w) - w x nu``.
    """
    J, c = model[p], model[p + 1]
    d1, d2, d3 = n1 - w1, n2 - w2, n3 - w3
    r = -c / J
    rate = (
        r * d1 - (w2 * n3 - w3 * n2),
        r * d2 - (w3 * n1 - w1 * n3),
        r * d3 - (w1 * n2 - w2 * n1),
    )
    return (c * d1, c * d2, c * d3), rate


def _rotor(w1, w2, w3, model, p):
    """Torque ``h_B x w`` of a wheel of constant relative momentum (Rotor)."""
    h1, h2, h3 = model[p], model[p + 1], model[p + 2]
    return h2 * w3 - h3 * w2, h3 * w1 - h1 * w3, h1 * w2 - h2 * w1


def _reaction_wheel(w1, w2, w3, h, command, model, p, held):
    """
    Return a wheel's torque on the body, ``h'`` and its speed (ReactionWheels, same operations).

    ``h = Js (Omega + g . w)``; the net axial torque on the wheel is ``u - f`` (the motor's,
    limited, less friction), the body's ``(h g) x w - g (u - f)``; the speed ``Omega`` is the
    wheel angle's rate. A speed drive's torque error, when the wheel has one, is read from
    ``held`` at the index its 14th parameter gives.
    """
    g1, g2, g3, Js = model[p], model[p + 1], model[p + 2], model[p + 3]
    speed = h / Js - (g1 * w1 + g2 * w2 + g3 * w3)
    scale, bias = 1.0, 0.0
    e = int(model[p + 13])
    if e > 0:
        scale, bias = held[e], held[e + 1]
    u = _wheel_motor(
        speed, command, model[p + 4], model[p + 5], model[p + 6], model[p + 12], scale, bias
    )
    f = _wheel_friction(
        speed, model[p + 7], model[p + 8], model[p + 9], model[p + 10], model[p + 11]
    )
    net = u - f
    torque = (
        h * (g2 * w3 - g3 * w2) - g1 * net,
        h * (g3 * w1 - g1 * w3) - g2 * net,
        h * (g1 * w2 - g2 * w1) - g3 * net,
    )
    return torque, net, speed


def _wheel_motor(speed, command, max_torque, max_speed, band, gain, scale, bias):
    """
    Return the motor torque a wheel applies (ReactionWheels.motor_torque).

    With a speed-loop ``gain`` the command is a speed set-point (NaN: the drive is off, asking
    zero) and the drive asks ``gain (command - Omega)``, or under a torque error ``scale`` times
    that plus ``bias``. Clipped to ``+-max_torque``; a torque that speeds the wheel up (``u Omega >
    0``) is scaled by ``(max_speed - |Omega|) / band`` in the last ``band`` below ``max_speed``,
    zero at and beyond it.
    """
    if gain > 0.0:
        command = 0.0 if math.isnan(command) else gain * (command - speed)
        if scale != 1.0 or bias != 0.0:
            command = scale * command + bias
    u = min(max(command, -max_torque), max_torque)
    if u * speed > 0.0:
        room = (max_speed - abs(speed)) / band
        if room < 1.0:
            u *= max(room, 0.0)
    return u


def _wheel_friction(speed, viscous, coulomb, band, excess, stribeck_speed):
    """
    Return a wheel's friction torque ``f(Omega)`` (ReactionWheels.friction_torque).

    ``b Omega + sign(Omega) (Fc + (Fs - Fc) exp(-(Omega / w_s)^2))``, linear in ``Omega`` inside
    ``|Omega| < band`` (continuous at its edges).
    """
    a = abs(speed)
    level = coulomb
    if excess != 0.0:
        x = max(a, band) / stribeck_speed
        level += excess * math.exp(-(x * x))
    dry = math.copysign(level, speed) if a >= band else level * (speed / band)
    return viscous * speed + dry


def _rotate_inverse(qx, qy, qz, qw, vx, vy, vz):
    """``R(q)^T v`` (quaternion.rotate by the conjugate, the same operations)."""
    ux, uy, uz, w = -qx, -qy, -qz, qw
    tx, ty, tz = 2.0 * (uy * vz - uz * vy), 2.0 * (uz * vx - ux * vz), 2.0 * (ux * vy - uy * vx)
    return (
        vx + w * tx + uy * tz - uz * ty,
        vy + w * ty + uz * tx - ux * tz,
        vz + w * tz + ux * ty - uy * tx,
    )


# ==== the right-hand side ========================================================================


def _rhs(t, Y, r, model, held, OUT, o):
    """
    Set ``OUT[o] = y'`` of the state ``y = Y[r] = (w, q, x)`` (Dynamics.derivative).

    Rows of 2-D arrays, by index (the steps' stages are rows of their scratch). The torque is
    summed in scalars, not in a scratch array: stores and reloads through memory cost ~10x the
    arithmetic here.
    """
    w1, w2, w3 = Y[r, 0], Y[r, 1], Y[r, 2]
    qx, qy, qz, qw = Y[r, 3], Y[r, 4], Y[r, 5], Y[r, 6]
    h1 = model[0] * w1 + model[1] * w2 + model[2] * w3
    h2 = model[3] * w1 + model[4] * w2 + model[5] * w3
    h3 = model[6] * w1 + model[7] * w2 + model[8] * w3
    m1 = (h2 * w3 - h3 * w2) + held[0]  # (I w) x w, then the held torques
    m2 = (h3 * w1 - h1 * w3) + held[1]
    m3 = (h1 * w2 - h2 * w1) + held[2]
    if held[3] != 0.0 or held[4] != 0.0 or held[5] != 0.0:
        r1, r2, r3 = _rotate_inverse(qx, qy, qz, qw, held[3], held[4], held[5])
        m1, m2, m3 = m1 + r1, m2 + r2, m3 + r3
    at = MODEL_HEADER
    for _ in range(int(model[18])):
        code = int(model[at])
        p = at + 2
        if code == GRAVITY_GRADIENT:
            e1, e2, e3 = _gravity_gradient(t, qx, qy, qz, qw, model, p)
            at = p + 11
        elif code == DAMPER:
            s = 7 + int(model[at + 1])
            (e1, e2, e3), (v1, v2, v3) = _damper(
                w1, w2, w3, Y[r, s], Y[r, s + 1], Y[r, s + 2], model, p
            )
            OUT[o, s], OUT[o, s + 1], OUT[o, s + 2] = v1, v2, v3
            at = p + 2
        elif code == ROTOR:
            e1, e2, e3 = _rotor(w1, w2, w3, model, p)
            at = p + 3
        elif code == ORBIT_GRAVITY_GRADIENT:  # the environment after the held inputs
            e1, e2, e3 = _orbit_gravity_gradient(
                t, qx, qy, qz, qw, model, p, held, HELD_TORQUES + Y.shape[1] - 7
            )
            at = p + 10
        elif code == RESIDUAL_DIPOLE:
            e1, e2, e3 = _residual_dipole(
                t, qx, qy, qz, qw, model, p, held, HELD_TORQUES + Y.shape[1] - 7
            )
            at = p + 4
        elif code == MAGNETORQUERS:  # the applied dipole in its slot, at held[model[at + 1]]
            e1, e2, e3 = _magnetorquers(
                t,
                qx,
                qy,
                qz,
                qw,
                model,
                p,
                held,
                HELD_TORQUES + Y.shape[1] - 7,
                int(model[at + 1]),
            )
            at = p + 1
        else:  # REACTION_WHEEL, its input (motor torque or set-point) held at its state's index
            s = 7 + int(model[at + 1])
            (e1, e2, e3), v1, v2 = _reaction_wheel(
                w1, w2, w3, Y[r, s], held[HELD_TORQUES + s - 7], model, p, held
            )
            OUT[o, s], OUT[o, s + 1] = v1, v2
            at = p + 14
        m1, m2, m3 = m1 + e1, m2 + e2, m3 + e3
    OUT[o, 0] = model[9] * m1 + model[10] * m2 + model[11] * m3
    OUT[o, 1] = model[12] * m1 + model[13] * m2 + model[14] * m3
    OUT[o, 2] = model[15] * m1 + model[16] * m2 + model[17] * m3
    OUT[o, 3] = 0.5 * (qw * w1 + qy * w3 - qz * w2)  # q' = 1/2 q ⊗ (w, 0)
    OUT[o, 4] = 0.5 * (qw * w2 - qx * w3 + qz * w1)
    OUT[o, 5] = 0.5 * (qw * w3 + qx * w2 - qy * w1)
    OUT[o, 6] = -0.5 * (qx * w1 + qy * w2 + qz * w3)


def derivative(t, y, model, held, out):
    """``out = y'`` of one state ``y = (w, q, x)`` (1-D arrays; Dynamics.derivative)."""
    # (reshape calls a helper each time)
    _rhs(t, y[np.newaxis, :], 0, model, held, out[np.newaxis, :], 0)


def derivatives(t, y, model, held, out):
    """``y'`` at many states ``y (N, n)`` (the tests' and the benchmarks' entry point)."""
    for i in range(y.shape[0]):
        _rhs(t[i], y, i, model, held, out, i)


# ==== DOP853 =====================================================================================
# Which of the tableau's coefficients are not zero: scipy's, read by compile_kernels (numba
# compiles module arrays in as constants, so in a stage's sum, unrolled for a constant stage, the
# zero terms vanish)
_A_USED = _B_USED = _E3_USED = _E5_USED = _D_USED = None
# rows of the scratch ``work`` (3, n) during a step
Y_NEW, STAGE, SCALE = 0, 1, 2


def _rms_scaled(values, work):
    total = 0.0
    for i in range(values.size):
        v = values[i] / work[SCALE, i]
        total += v * v
    return math.sqrt(total / values.size)


def dop853_begin(t0, t_bound, rtol, atol, min_step, solver, y, f, work, model, held):
    """
    Begin a new smooth piece from ``(t0, y)`` to ``t_bound`` (inf: none).

    ``f = y'(t0)`` and the initial step (scipy's select_initial_step with order 7); ``work`` is (3,
    n) of scratch.
    """
    derivative(t0, y, model, held, f)
    solver[T], solver[T_BOUND], solver[RTOL], solver[ATOL] = t0, t_bound, rtol, atol
    solver[T_OLD], solver[H_PREVIOUS], solver[DENSE_READY], solver[MIN_STEP] = (
        t0,
        0.0,
        0.0,
        min_step,
    )
    n = y.size
    interval = abs(t_bound - t0)
    if interval == 0.0:
        solver[H_ABS] = 0.0
        return
    for i in range(n):
        work[SCALE, i] = atol + abs(y[i]) * rtol
    d0 = _rms_scaled(y, work)
    d1 = _rms_scaled(f, work)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        work[0, i] = y[i] + h0 * f[i]
    _rhs(t0 + h0, work, 0, model, held, work, 1)
    for i in range(n):
        work[0, i] = work[1, i] - f[i]
    d2 = _rms_scaled(work[0], work) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    solver[H_ABS] = min(100.0 * h0, h1, interval)


def _stage_sum(K, A, s, y, h, work):
    """
    Set ``work[STAGE] = y + h sum_j A[s, j] K[j]`` over the stages before ``s``.

    As scipy's ``np.dot(K[:s].T, a[:s]) * h``, with the sum over stages innermost, in a register,
    in the order of ``j``, the zero coefficients left out (``s`` is a constant where this is
    inlined: the loop over ``j`` unrolls).
    """
    for i in range(y.size):
        total = 0.0
        for j in range(s):
            if _A_USED[s, j]:
                total += K[j, i] * A[s, j]
        work[STAGE, i] = y[i] + total * h


def _stage_state(K, A, s, y, h, work):
    """:func:`_stage_sum` of stage ``s`` (1 to 11), each with its ``s`` a constant."""
    if s == 1:
        _stage_sum(K, A, 1, y, h, work)
    elif s == 2:
        _stage_sum(K, A, 2, y, h, work)
    elif s == 3:
        _stage_sum(K, A, 3, y, h, work)
    elif s == 4:
        _stage_sum(K, A, 4, y, h, work)
    elif s == 5:
        _stage_sum(K, A, 5, y, h, work)
    elif s == 6:
        _stage_sum(K, A, 6, y, h, work)
    elif s == 7:
        _stage_sum(K, A, 7, y, h, work)
    elif s == 8:
        _stage_sum(K, A, 8, y, h, work)
    elif s == 9:
        _stage_sum(K, A, 9, y, h, work)
    elif s == 10:
        _stage_sum(K, A, 10, y, h, work)
    else:
        _stage_sum(K, A, 11, y, h, work)


def _extra_stage_state(K, A, s, y, h, work):
    """
    Do :func:`_stage_sum` of the interpolant's stage ``s`` (13 to 15).

    Each with its ``s`` a constant.
    """
    if s == 13:
        _stage_sum(K, A, 13, y, h, work)
    elif s == 14:
        _stage_sum(K, A, 14, y, h, work)
    else:
        _stage_sum(K, A, 15, y, h, work)


def _dop853_step(solver, y, y_old, f, K, work, model, held, A, B, C, E3, E5):
    """
    Take one accepted step (scipy's RungeKutta._step_impl).

    False when the step fell below scipy's floor. The sums run over stages innermost, in a register
    (faster here than rows of K at a time).
    """
    t = solver[T]
    n = y.size
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    h_abs = solver[H_ABS]
    if h_abs < min_step:
        h_abs = min_step
    rejected = False
    rtol, atol = solver[RTOL], solver[ATOL]
    while True:
        if h_abs < min_step:
            return False
        t_new = t + h_abs
        if t_new > solver[T_BOUND]:
            t_new = solver[T_BOUND]
        h = t_new - t
        h_abs = abs(h)
        for i in range(n):
            K[0, i] = f[i]
        for s in range(1, STAGES):
            _stage_state(K, A, s, y, h, work)
            _rhs(t + C[s] * h, work, STAGE, model, held, K, s)
        for i in range(n):
            total = 0.0
            for j in range(STAGES):
                if _B_USED[j]:
                    total += K[j, i] * B[j]
            work[Y_NEW, i] = y[i] + h * total
        _rhs(t + h, work, Y_NEW, model, held, K, STAGES)
        err5, err3 = 0.0, 0.0
        for i in range(n):
            scale_i = atol + max(abs(y[i]), abs(work[Y_NEW, i])) * rtol
            e5, e3 = 0.0, 0.0
            for j in range(STAGES + 1):
                if _E5_USED[j]:
                    e5 += K[j, i] * E5[j]
                if _E3_USED[j]:
                    e3 += K[j, i] * E3[j]
            e5 /= scale_i
            e3 /= scale_i
            err5 += e5 * e5
            err3 += e3 * e3
        if err5 == 0.0 and err3 == 0.0:
            error = 0.0
        else:
            error = abs(h) * err5 / math.sqrt((err5 + 0.01 * err3) * n)
        if error < 1.0:
            if error == 0.0:
                factor = MAX_FACTOR
            else:
                factor = min(MAX_FACTOR, SAFETY * error**ERROR_EXPONENT)
            if rejected:
                factor = min(1.0, factor)
            h_abs *= factor
            break
        shrink = SAFETY * error**ERROR_EXPONENT
        # also a NaN error (an overflowed stage): scipy's max() gives 0.2 there
        if not shrink > MIN_FACTOR:
            shrink = MIN_FACTOR
        h_abs *= shrink
        rejected = True
    for i in range(n):
        y_old[i] = y[i]
        y[i] = work[Y_NEW, i]
        f[i] = K[STAGES, i]
    solver[H_PREVIOUS] = h
    solver[T_OLD] = t
    solver[T] = t_new
    solver[H_ABS] = h_abs
    solver[DENSE_READY] = 0.0
    return True


def _dop853_dense(solver, y, y_old, f, K, F, work, model, held, A, C, D):
    """
    Compute the last step's interpolant coefficients ``F``.

    As scipy's DOP853._dense_output_impl.
    """
    n = y.size
    h = solver[H_PREVIOUS]
    t_old = solver[T_OLD]
    for s in range(STAGES + 1, STAGES_EXTENDED):
        _extra_stage_state(K, A, s, y_old, h, work)
        _rhs(t_old + C[s] * h, work, STAGE, model, held, K, s)
    for i in range(n):
        delta = y[i] - y_old[i]
        F[0, i] = delta
        F[1, i] = h * K[0, i] - delta
        F[2, i] = 2.0 * delta - h * (f[i] + K[0, i])
        # the four sums of D K side by side, each in the order of j: each K[j, i] read once
        t3, t4, t5, t6 = 0.0, 0.0, 0.0, 0.0
        for j in range(STAGES_EXTENDED):
            k = K[j, i]
            if _D_USED[0, j]:
                t3 += D[0, j] * k
            if _D_USED[1, j]:
                t4 += D[1, j] * k
            if _D_USED[2, j]:
                t5 += D[2, j] * k
            if _D_USED[3, j]:
                t6 += D[3, j] * k
        F[3, i], F[4, i], F[5, i], F[6, i] = h * t3, h * t4, h * t5, h * t6
    solver[DENSE_READY] = 1.0


def dop853_outputs(
    times, first, out, max_steps, solver, y, y_old, f, K, F, work, model, held, A, B, C, E3, E5, D
):
    """
    Fill ``out[first:]`` with the states at ``times[first:]`` (sorted), stepping as needed.

    Returns ``(index, status)`` (``q`` normalised in each output row): the first time not filled,
    and why it stopped: DONE; SEGMENT_END (the piece ended at ``t_bound`` before ``times[index]``:
    the caller begins the next); RESTART (``times[index]`` lies before the last step); BUDGET (more
    than ``max_steps`` steps for one time; < 0: no bound); TOO_SMALL (the step fell below scipy's
    floor); STIFF (an accepted step under ``solver[MIN_STEP]``).
    """
    n = y.size
    i = first
    while i < times.size:
        target = times[i]
        if target < solver[T_OLD]:
            return i, RESTART
        steps = 0
        while solver[T] < target:
            if solver[T] >= solver[T_BOUND]:
                return i, SEGMENT_END
            steps += 1
            if 0 <= max_steps < steps:
                return i, BUDGET
            if not _dop853_step(solver, y, y_old, f, K, work, model, held, A, B, C, E3, E5):
                return i, TOO_SMALL
            if abs(solver[H_PREVIOUS]) < solver[MIN_STEP] and solver[T] < solver[T_BOUND]:
                return i, STIFF
        # every time up to the step's end: its state, or the dense output inside it
        t_end = solver[T]
        h = solver[H_PREVIOUS]
        t_old = solver[T_OLD]
        while i < times.size and times[i] <= t_end:
            t = times[i]
            if t == t_end:
                for k in range(n):
                    out[i, k] = y[k]
            else:
                if solver[DENSE_READY] == 0.0:
                    _dop853_dense(solver, y, y_old, f, K, F, work, model, held, A, C, D)
                x = (t - t_old) / h
                for k in range(n):
                    value = 0.0
                    for r in range(INTERPOLATOR_POWER):
                        value += F[INTERPOLATOR_POWER - 1 - r, k]
                        value *= x if r % 2 == 0 else 1.0 - x
                    out[i, k] = value + y_old[k]
            # q normalised on output, as the reference path does with numpy afterwards
            norm = math.sqrt(
                out[i, 3] * out[i, 3]
                + out[i, 4] * out[i, 4]
                + out[i, 5] * out[i, 5]
                + out[i, 6] * out[i, 6]
            )
            for k in range(3, 7):
                out[i, k] /= norm
            i += 1
    return i, DONE


def next_sample_time(t, rate):
    """
    Return the first sample time ``k / rate`` after ``t``.

    Dynamics.next_breakpoint's rule for a torque held from sample to sample, the same operations.
    """
    k = math.floor(t * rate) + 1
    while k > 1 and (k - 1) / rate > t:
        k -= 1
    while k / rate <= t:
        k += 1
    return k / rate


def dop853_outputs_batch(
    times,
    out,
    max_steps,
    sample_rate,
    breaks,
    piece_helds,
    command_helds,
    solvers,
    ys,
    y_olds,
    fs,
    Ks,
    Fs,
    works,
    models,
    helds,
    rtols,
    atols,
    min_steps,
    A,
    B,
    C,
    E3,
    E5,
    D,
    status,
    reached,
):
    """
    Run :func:`dop853_outputs` for each body ``b`` of a batch (row ``b`` of every array).

    ``out`` is ``(N, M, n)``. A new smooth piece is begun where one ends, as the single-body driver
    begins it: at body ``b``'s next breakpoint (``breaks[b]``, ascending, padded with ``inf``) or,
    when ``sample_rate > 0``, the next sample time, whichever comes first. A piece beginning at
    ``t0`` holds the torque of the scene's own piece containing it (``piece_helds[b, j]``, ``j``
    the breakpoints at or before ``t0``) plus the commanded one (``command_helds[b]``, over this
    call), in ``helds[b]``; ``command_helds`` may be narrower than ``helds`` (the torques alone:
    no input past its width is commanded). ``status[b]`` and ``reached[b]``: what dop853_outputs
    returned last for body ``b``.
    """
    for b in range(solvers.shape[0]):
        i = 0
        while True:
            i, st = dop853_outputs(
                times,
                i,
                out[b],
                max_steps,
                solvers[b],
                ys[b],
                y_olds[b],
                fs[b],
                Ks[b],
                Fs[b],
                works[b],
                models[b],
                helds[b],
                A,
                B,
                C,
                E3,
                E5,
                D,
            )
            if st == SEGMENT_END:
                t0 = solvers[b, T]
                j = np.searchsorted(breaks[b], t0, side='right')
                bound = breaks[b, j] if j < breaks.shape[1] else np.inf
                if sample_rate > 0.0:
                    bound = min(bound, next_sample_time(t0, sample_rate))
                for c in range(helds.shape[1]):
                    commanded = command_helds[b, c] if c < command_helds.shape[1] else 0.0
                    helds[b, c] = piece_helds[b, j, c] + commanded
                dop853_begin(
                    t0,
                    bound,
                    rtols[b],
                    atols[b],
                    min_steps[b],
                    solvers[b],
                    ys[b],
                    fs[b],
                    works[b],
                    models[b],
                    helds[b],
                )
                continue
            status[b] = st
            reached[b] = i
            break


# ==== fixed-step methods =========================================================================


def _exp_times(q, vx, vy, vz, out):
    """``out = q ⊗ exp(v)`` (quaternion.exp_rotation of ``v``, then the Hamilton product)."""
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    scale = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(0.5 * angle) / angle
    ex, ey, ez, ew = vx * scale, vy * scale, vz * scale, math.cos(0.5 * angle)
    px, py, pz, pw = q[0], q[1], q[2], q[3]
    out[0] = pw * ex + px * ew + py * ez - pz * ey
    out[1] = pw * ey - px * ez + py * ew + pz * ex
    out[2] = pw * ez + px * ey - py * ex + pz * ew
    out[3] = pw * ew - px * ex - py * ey - pz * ez


def fixed_step(method, t, y, h, model, held, work):
    """
    Take one step of ``method`` (RK4 or LIE_RK4, numerical.py's ``advance``) over ``[t, t + h]``.

    In place; ``work`` is (9, n) of scratch (n >= 7).
    """
    n = y.size
    k1, k2, k3, k4, y2, y3, y4 = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    q_new, first = work[7], work[8]
    half = t + 0.5 * h
    lie = method == LIE_RK4
    derivative(t, y, model, held, k1)
    for i in range(n):
        y2[i] = y[i] + (0.5 * h) * k1[i]
    if lie:  # the stage attitudes (numerical.py's LieRK4Propagator), exact rotations of q
        _exp_times(y[3:7], (0.5 * h) * y[0], (0.5 * h) * y[1], (0.5 * h) * y[2], y2[3:7])
    derivative(half, y2, model, held, k2)
    for i in range(n):
        y3[i] = y[i] + (0.5 * h) * k2[i]
    if lie:
        _exp_times(y[3:7], (0.5 * h) * y2[0], (0.5 * h) * y2[1], (0.5 * h) * y2[2], y3[3:7])
    derivative(half, y3, model, held, k3)
    for i in range(n):
        y4[i] = y[i] + h * k3[i]
    if lie:
        _exp_times(
            y2[3:7],
            h * (y3[0] - 0.5 * y[0]),
            h * (y3[1] - 0.5 * y[1]),
            h * (y3[2] - 0.5 * y[2]),
            y4[3:7],
        )
    derivative(t + h, y4, model, held, k4)
    if lie:
        a = h / 12.0
        m1, m2, m3 = 2.0 * (y2[0] + y3[0]), 2.0 * (y2[1] + y3[1]), 2.0 * (y2[2] + y3[2])
        _exp_times(
            y[3:7],
            a * (3.0 * y[0] + m1 - y4[0]),
            a * (3.0 * y[1] + m2 - y4[1]),
            a * (3.0 * y[2] + m3 - y4[2]),
            first,
        )
        _exp_times(
            first,
            a * (m1 - y[0] + 3.0 * y4[0]),
            a * (m2 - y[1] + 3.0 * y4[1]),
            a * (m3 - y[2] + 3.0 * y4[2]),
            q_new,
        )
    for i in range(n):
        y[i] = y[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
    if lie:
        norm = math.sqrt(
            q_new[0] * q_new[0] + q_new[1] * q_new[1] + q_new[2] * q_new[2] + q_new[3] * q_new[3]
        )
        for i in range(4):
            y[3 + i] = q_new[i] / norm


def fixed_outputs(method, times, first, out, max_steps, step, grid, y, partial, model, held, work):
    """
    Run a fixed-step propagator's whole loop over sorted ``times`` (numerical.py's ``_evaluate``).

    For a scene without breakpoints: the grid point at or below each time (a time within 4 rounding
    units of a grid point is on it), whole steps up to it, one partial step from a copy.
    ``grid[0]``: the grid index reached, kept between calls. Returns ``(index, status)``: DONE,
    RESTART (a time before the grid index) or BUDGET (more than ``max_steps`` steps for one time; <
    0: no bound).
    """
    n = y.size
    i = first
    while i < times.size:
        t = times[i]
        j = int(np.rint(t / step))  # Python's round: half to even
        if abs(t - j * step) <= 4.0 * (np.nextafter(t, np.inf) - t):  # math.ulp(t), t >= 0
            h = 0.0
        else:
            j = math.floor(t / step)
            if (j + 1) * step <= t:
                j += 1
            elif j * step > t:
                j -= 1
            h = t - j * step
        index = int(grid[0])
        if j < index:
            return i, RESTART
        if 0 <= max_steps < j - index:
            return i, BUDGET
        while index < j:
            fixed_step(method, index * step, y, step, model, held, work)
            index += 1
        grid[0] = index
        if h > 0.0:
            for k in range(n):
                partial[k] = y[k]
            fixed_step(method, j * step, partial, h, model, held, work)
            for k in range(n):
                out[i, k] = partial[k]
        else:
            for k in range(n):
                out[i, k] = y[k]
        i += 1
    return i, DONE


def fixed_steps(method, j, j_end, step, bound, y, model, held, work):
    """
    Take whole grid steps ``[j step, (j + 1) step]`` from ``j`` while ``j < j_end``.

    Only while no breakpoint lies inside the step (``bound``: the first breakpoint after
    ``j step``); returns the ``j`` reached.
    """
    while j < j_end:
        t = j * step
        if bound < t + step:
            break
        fixed_step(method, t, y, step, model, held, work)
        j += 1
    return j


# ==== loading ====================================================================================

# Inlined where called, by LLVM (``forceinline``): the effects and the right-hand side into the
# steps, a DOP853 step and its interpolant into the loop over the outputs (numba's own inliner
# re-types the callee at every call, which costs compile time).
_INLINED = {
    '_gravity_gradient',
    '_chebyshev',
    '_environment',
    '_orbit_gravity_gradient',
    '_residual_dipole',
    '_magnetorquers',
    '_damper',
    '_rotor',
    '_reaction_wheel',
    '_wheel_motor',
    '_wheel_friction',
    '_rotate_inverse',
    '_rhs',
    'derivative',
    '_dop853_step',
    '_dop853_dense',
    '_exp_times',
}
# Inlined by numba (``inline="always"``), small: the stage sums, so that each is typed with its
# stage a literal (the loop over j unrolled, the zeros gone) without compiling a function per
# stage.
_INLINED_BY_NUMBA = {'_stage_sum', '_stage_state', '_extra_stage_state'}
# The entry points that can run long (a block of samples, up to the step budget a sample) release
# the GIL, so that the node's other threads (its executor: services, parameters, Ctrl-C) run
# meanwhile. The exact solution's kernels keep it: their calls are short.
_RELEASING_THE_GIL = {'dop853_outputs', 'dop853_outputs_batch', 'fixed_outputs', 'fixed_steps'}


def _read_tableau(numba) -> None:
    """Read which of scipy's DOP853 coefficients are zero: the kernels skip those terms."""
    global _A_USED, _B_USED, _E3_USED, _E5_USED, _D_USED
    from scipy.integrate._ivp import dop853_coefficients as tableau

    _A_USED, _B_USED = (
        np.ascontiguousarray(tableau.A != 0.0),
        np.ascontiguousarray(tableau.B != 0.0),
    )
    _E3_USED, _E5_USED = (
        np.ascontiguousarray(tableau.E3 != 0.0),
        np.ascontiguousarray(tableau.E5 != 0.0),
    )
    _D_USED = np.ascontiguousarray(tableau.D != 0.0)


def _options(name: str) -> dict:
    # _nrt=False: no kernel allocates, and without numba's runtime no reference is counted (an
    # array handed to an inlined helper, or sliced, would cost an atomic increment and decrement);
    # forceinline set on every kernel, True or False, so that none inherits it from its caller
    options = {'_nrt': False, 'forceinline': name in _INLINED}
    if name in _INLINED_BY_NUMBA:
        options['inline'] = 'always'
    if name in _RELEASING_THE_GIL:
        options['nogil'] = True
    return options


_FAMILY = KernelFamily(
    globals(),
    (
        '_gravity_gradient',
        '_chebyshev',
        '_environment',
        '_orbit_gravity_gradient',
        '_residual_dipole',
        '_magnetorquers',
        '_damper',
        '_rotor',
        '_reaction_wheel',
        '_wheel_motor',
        '_wheel_friction',
        '_rotate_inverse',
        '_rhs',
        'derivative',
        'derivatives',
        '_rms_scaled',
        'dop853_begin',
        '_stage_sum',
        '_stage_state',
        '_extra_stage_state',
        '_dop853_step',
        '_dop853_dense',
        'dop853_outputs',
        'next_sample_time',
        'dop853_outputs_batch',
        '_exp_times',
        'fixed_step',
        'fixed_outputs',
        'fixed_steps',
    ),
    _options,
    _read_tableau,
)
#: compile every kernel of this file, once (thread-safe)
compile_kernels = _FAMILY.load
