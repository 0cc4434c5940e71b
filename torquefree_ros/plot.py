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
The pictures of seed 000 for a run, as PNG files (``torquefree_plot``, ``cli.plot``).

* ``NAME_rates.png``: the body rates ``w_i(t)``;
* ``NAME_polhode.png``: the path of ``H`` in body axes on the momentum sphere ``|H| = const``, with
  the energy ellipsoid ``H . I^-1 H = 2T`` it also lies on (one path per member of an energy
  sweep);
* ``NAME_phase.png``: the phase planes ``(w_i, w_i')`` of the Duffing analog
  ``w_i'' + A_i w_i + B_i w_i^3 = 0`` in principal axes.

A scene is simulated (``--duration``, ``--rate``); a bag's ``angular_velocity`` is read as
recorded, with the inertia the bag stores (``torquefree_bag`` writes it) or ``--inertia``.
matplotlib is an optional extra: ``pip install 'torquefree_ros[plot]'``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .bag.cdr import decode_stamped_doubles
from .bag.reader import bag_information, BagReader
from .bag.samples import INERTIA_KEY
from .core.body.rigid_body import RigidBody
from .core.run.simulation import Simulation

MAX_SAMPLES = 200_000


class PlotError(ValueError):
    pass


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise PlotError(
            "plots need matplotlib, an optional extra: pip install 'torquefree_ros[plot]'"
        ) from None
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def runs_from_scene(scene, duration: float | None, rate: float):
    """
    Simulate a scene's members: ``(label, times, omega_B)`` per member.

    The default duration is the scene's ``watch`` (how long its story takes, e.g. a damper's), else
    two polhode periods.
    """
    runs = []
    for index, member in enumerate(scene.members()):
        simulation = Simulation(member.propagator(), rate)
        span = duration if duration is not None else scene.watch
        if span is None:
            period = simulation.regime.polhode_period
            span = 2.0 * period if math.isfinite(period) and period > 0 else 20.0
        count = min(MAX_SAMPLES, int(span * rate) + 1)
        block = simulation.samples(0, count)
        label = f'2T = {2 * simulation.kinetic_energy0:.4g} J' if scene.sweep_members else 'w'
        runs.append((label, block.times, block.omega_B))
    return runs


def runs_from_bag(path: Path):
    reader = BagReader(path)
    topics = [
        t.name
        for t in reader.topics
        if t.name.endswith('angular_velocity')
        and t.type_name == 'geometry_msgs/msg/Vector3Stamped'
    ]
    if not topics:
        raise PlotError(
            f"bag '{path}': no angular_velocity topic (geometry_msgs/msg/Vector3Stamped)"
        )
    stamps, omega = [], []
    for message in reader.messages(topics[:1]):
        stamp, _, values = decode_stamped_doubles(message.data, 3)
        stamps.append(stamp)
        omega.append(values)
    if len(stamps) < 3:
        raise PlotError(
            f"bag '{path}': {topics[0]} has {len(stamps)} messages, 3 or more are needed"
        )
    stamps = np.array(stamps, dtype=np.int64)
    return [(topics[0], (stamps - stamps[0]) * 1e-9, np.array(omega))]


def bag_inertia(path: Path):
    """Return the inertia ``torquefree_bag`` stores in the bag, or None."""
    text = (bag_information(path).get('custom_data') or {}).get(INERTIA_KEY)
    return None if text is None else [float(x) for x in text.split()]


def draw(runs, body: RigidBody, name: str, output_dir: Path) -> list[Path]:
    """
    Draw the rates, polhode and phase-plane PNG files of the runs; return their paths.

    One run: its three rates, its path with its energy ellipsoid. A family (an energy sweep): one
    colour per member by its energy ``2T``, with a colour bar instead of a legend.
    """
    plt = _pyplot()
    output_dir.mkdir(parents=True, exist_ok=True)
    two_T = [float(2.0 * body.kinetic_energy(omega[0])) for _, _, omega in runs]
    colour = _energy_colours(plt, two_T)
    written = []

    if len(runs) == 1:
        figure, axes = plt.subplots(figsize=(9, 4.5))
        _, times, omega = runs[0]
        for i, style in zip(range(3), ('-', '--', ':')):
            axes.plot(times, omega[:, i], style, lw=1, label=f'w{i + 1}')
        axes.set(xlabel='t (s)', ylabel='body rate (rad/s)', title=f'{name}: body rates')
        axes.legend(fontsize=8)
    else:
        figure, all_axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
        for (_, times, omega), energy in zip(runs, two_T):
            for i, axes in enumerate(all_axes):
                axes.plot(times, omega[:, i], lw=1, color=colour.to_rgba(energy))
        for i, axes in enumerate(all_axes):
            axes.set(ylabel=f'w{i + 1} (rad/s)')
        all_axes[0].set_title(f'{name}: body rates, one colour per energy')
        all_axes[-1].set(xlabel='t (s)')
        figure.colorbar(colour, ax=all_axes, label='2T (J)')
    written.append(_save(figure, plt, output_dir / f'{name}_rates.png', tight=len(runs) == 1))

    figure = plt.figure(figsize=(7.5, 7))
    axes = figure.add_subplot(projection='3d')
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
    unit_sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    radius = float(np.linalg.norm(body.angular_momentum(runs[0][2][0])))
    axes.plot_wireframe(*(radius * unit_sphere), color='0.75', lw=0.4)
    handles = [plt.Line2D([], [], color='0.75', lw=1, label=f'momentum sphere |H| = {radius:.4g}')]
    reach = radius
    if len(runs) == 1:  # one energy: its ellipsoid H . I^-1 H = 2T, semi-axes sqrt(2T I_i)
        semi_axes = np.sqrt(two_T[0] * body.moments)
        axes.plot_wireframe(*(semi_axes[:, None, None] * unit_sphere), color='tab:orange', lw=0.3)
        handles.append(
            plt.Line2D(
                [], [], color='tab:orange', lw=1, label=f'energy ellipsoid 2T = {two_T[0]:.4g} J'
            )
        )
        reach = max(reach, float(semi_axes.max()))
    for (_, _, omega), energy in zip(runs, two_T):
        H_P = body.angular_momentum(omega) @ body.principal_axes
        axes.plot(*H_P.T, lw=1.6, color='tab:blue' if len(runs) == 1 else colour.to_rgba(energy))
    if len(runs) == 1:
        handles.append(plt.Line2D([], [], color='tab:blue', lw=1.6, label='path of H (polhode)'))
    else:
        figure.colorbar(colour, ax=axes, shrink=0.6, label='2T (J) of each path of H')
    # equal scales: a sphere looks round
    for set_limits in (axes.set_xlim, axes.set_ylim, axes.set_zlim):
        set_limits(-reach, reach)
    axes.set_box_aspect((1, 1, 1))
    axes.set(
        xlabel='H1',
        ylabel='H2',
        zlabel='H3',
        title=f'{name}: polhode on the momentum sphere (principal axes)',
    )
    axes.legend(handles=handles, loc='upper left', fontsize=8)
    written.append(_save(figure, plt, output_dir / f'{name}_polhode.png', tight=False))

    figure, axes = plt.subplots(1, 3, figsize=(12, 4))
    for (_, times, omega), energy in zip(runs, two_T):
        omega_P = body.to_principal(omega)
        rates = np.gradient(omega_P, times, axis=0)
        for i in range(3):
            axes[i].plot(
                omega_P[:, i],
                rates[:, i],
                lw=1,
                color=None if len(runs) == 1 else colour.to_rgba(energy),
            )
    for i in range(3):
        axes[i].set(
            xlabel=f'w{i + 1} (rad/s)',
            ylabel=f'dw{i + 1}/dt (rad/s^2)',
            title=f'I{i + 1} = {body.moments[i]:.4g} kg m^2',
        )
    figure.suptitle(f'{name}: phase planes of the Duffing analog (principal axes)')
    if len(runs) > 1:
        figure.colorbar(colour, ax=axes, label='2T (J)')
    written.append(_save(figure, plt, output_dir / f'{name}_phase.png', tight=len(runs) == 1))
    return written


def _energy_colours(plt, two_T):
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    low, high = min(two_T), max(two_T)
    return ScalarMappable(
        Normalize(low, high if high > low else low + 1.0), plt.get_cmap('viridis')
    )


def _save(figure, plt, path: Path, tight: bool = True) -> Path:
    if tight:  # (figures with a colour bar or a 3-D legend lay themselves out)
        figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
