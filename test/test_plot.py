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
The torquefree_plot command: three PNG files for a scene, an energy sweep or a bag.

Anything else gets a clear error.
"""

import sys

import numpy as np
import pytest
from torquefree_ros import load_scene, RigidBody
from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.cli.plot import main as plot_main

pytest.importorskip('matplotlib')  # the optional extra; requirements-test.txt installs it
DPI = 110  # torquefree_ros.plot._save's
KINDS = ('rates', 'polhode', 'phase')


@pytest.fixture
def drawn(monkeypatch):
    """
    Record what each saved figure draws, by file name, just before it is written.

    Per axes, the (x, y) or (x, y, z) data of its lines; and the figure's size in pixels.
    """
    from torquefree_ros import plot

    figures = {}
    save = plot._save

    def recording(figure, plt, path, tight=True):
        lines = [
            [
                line.get_data_3d() if hasattr(line, 'get_data_3d') else line.get_data()
                for line in axes.lines
            ]
            for axes in figure.axes
        ]
        figures[path.name] = (
            lines,
            tuple(np.round(figure.get_size_inches()[::-1] * DPI).astype(int)),
        )
        return save(figure, plt, path, tight)

    monkeypatch.setattr(plot, '_save', recording)
    return figures


def assert_pngs(directory, name, drawn, one_run=True):
    """
    Assert that each PNG reads back as a picture of its figure, not blank.

    Each PNG reads back as an image of its figure's size, not blank (an empty figure is all white;
    axes, ticks and text alone cover ~2 %). One run draws its lines in matplotlib's first colour
    (tab:blue): they cover >= 2e-4 of the pixels of each picture (measured 4e-4 to 5e-3 with the
    lines, 0 to 9e-5 without them: only a legend's swatch then).
    """
    from matplotlib.image import imread

    for kind in KINDS:
        image = imread(directory / f'{name}_{kind}.png')[..., :3]
        assert image.shape[:2] == drawn[f'{name}_{kind}.png'][1], kind
        coloured = np.any(image < 0.95, axis=-1).mean()
        assert coloured > 0.01, (kind, coloured)
        if one_run:
            tab_blue = np.array([0x1F, 0x77, 0xB4]) / 255
            # 0.06: antialiased edges excluded
            share = (np.abs(image - tab_blue).max(axis=-1) < 0.06).mean()
            assert share >= 2e-4, (kind, share)


def assert_draws_the_run(drawn, name, body, times, omega):
    """
    Assert that the figures draw one run's rates, polhode and phase planes.

    The rates are its three w_i(t); the polhode its H in principal axes, on the sphere |H| = |H0|
    (the exact solution conserves it to rounding: 1e-12); the phase planes its w_i(t).
    """
    (rates,) = drawn[f'{name}_rates.png'][0]  # one axes
    assert len(rates) == 3
    for i, (t, w) in enumerate(rates):
        np.testing.assert_array_equal(t, times)
        np.testing.assert_array_equal(w, omega[:, i])
    (polhode,) = drawn[f'{name}_polhode.png'][0]
    H_P = body.angular_momentum(omega) @ body.principal_axes
    path = np.array(polhode[-1]).T  # the path is drawn last, after the sphere and the ellipsoid
    np.testing.assert_array_equal(path, H_P)
    radius = np.linalg.norm(H_P[0])
    np.testing.assert_allclose(np.linalg.norm(path, axis=1), radius, rtol=1e-12)
    phase = drawn[f'{name}_phase.png'][0]
    assert len(phase) == 3
    for i, ((x, _),) in enumerate(phase):
        np.testing.assert_array_equal(x, body.to_principal(omega)[:, i])


def test_plots_of_a_library_scene_and_an_energy_sweep(tmp_path, capsys, drawn):
    from torquefree_ros.plot import runs_from_scene

    assert plot_main(['default', '--output-dir', str(tmp_path), '--duration', '12']) == 0
    assert_pngs(tmp_path, 'default', drawn)
    scene = load_scene('default')
    ((_, times, omega),) = runs_from_scene(scene, 12.0, 100.0)
    assert times[-1] == 12.0
    assert_draws_the_run(drawn, 'default', RigidBody.from_inertia(scene.inertia), times, omega)

    assert (
        plot_main(
            ['energy_sweep', '--output-dir', str(tmp_path), '--duration', '10', '--rate', '20']
        )
        == 0
    )
    assert_pngs(tmp_path, 'energy_sweep', drawn, one_run=False)
    assert str(tmp_path / 'energy_sweep_polhode.png') in capsys.readouterr().out
    members = runs_from_scene(load_scene('energy_sweep'), 10.0, 20.0)
    assert len(members) == 9
    rates = drawn['energy_sweep_rates.png'][0]
    # w1, w2, w3: a line per member; the colour bar
    assert [len(lines) for lines in rates] == [9, 9, 9, 0]
    for i, lines in enumerate(rates[:3]):
        for (_, w), (_, _, omega) in zip(lines, members):
            np.testing.assert_array_equal(w, omega[:, i])
    assert len(drawn['energy_sweep_polhode.png'][0][0]) == 9  # a path of H per member


def test_plots_of_a_bag_use_the_inertia_it_stores(tmp_path, drawn):
    from torquefree_ros.plot import runs_from_bag

    bag = tmp_path / 'tumble'
    assert bag_main(['dzhanibekov', '--duration', '8', '--rate', '50', '--output', str(bag)]) == 0
    assert plot_main([str(bag), '--output-dir', str(tmp_path / 'out')]) == 0
    assert_pngs(tmp_path / 'out', 'tumble', drawn)
    ((_, times, omega),) = runs_from_bag(bag)
    assert len(times) == 401  # 8 s at 50 Hz, both ends
    assert_draws_the_run(
        drawn, 'tumble', RigidBody.from_inertia(load_scene('dzhanibekov').inertia), times, omega
    )
    (bag / 'metadata.yaml').write_text(
        (bag / 'metadata.yaml').read_text().replace('torquefree_ros.inertia', 'x')
    )
    assert plot_main([str(bag), '--output-dir', str(tmp_path / 'out')]) == 2
    assert (
        plot_main([str(bag), '--inertia', '1', '2', '3', '--output-dir', str(tmp_path / 'again')])
        == 0
    )


def test_a_scene_is_plotted_for_as_long_as_it_says_it_must_be_watched():
    from torquefree_ros import load_scene
    from torquefree_ros.plot import runs_from_scene

    explorer1 = load_scene('explorer1')
    assert explorer1.watch == 900.0  # the damper's story takes about 15 minutes
    ((_, times, omega),) = runs_from_scene(explorer1, None, 2.0)
    assert times[-1] == 900.0
    spin = omega[-200:]  # the last 100 s: the spin about the minor axis (x, I = 0.4) has died away
    assert abs(spin[:, 0]).max() < 0.05 * abs(omega[0, 0])
    ((_, times, _),) = runs_from_scene(load_scene('dzhanibekov'), None, 10.0)
    period = (
        load_scene('dzhanibekov')
        .propagator()
        .body.classify(load_scene('dzhanibekov').angular_velocity)
    )
    # no watch: two polhode periods
    assert times[-1] == pytest.approx(2 * period.polhode_period, abs=0.1)


def test_plot_errors_are_named(tmp_path, capsys, monkeypatch):
    assert plot_main(['no_such_scene', '--output-dir', str(tmp_path)]) == 2
    assert "'no_such_scene' is neither a file nor a library scene" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        plot_main(['default', '--duration', '-1'])
    assert '--duration: must be a positive number' in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, 'matplotlib', None)
    assert plot_main(['default', '--output-dir', str(tmp_path)]) == 2
    assert "pip install 'torquefree_ros[plot]'" in capsys.readouterr().err
