"""torquefree_plot: three PNG files for a scene, an energy sweep or a bag; clear errors otherwise."""

import sys

import pytest

from torquefree_ros.cli.bag import main as bag_main
from torquefree_ros.cli.plot import main as plot_main

pytest.importorskip("matplotlib")  # the optional extra; requirements-test.txt installs it
PNG = b"\x89PNG\r\n\x1a\n"


def assert_pngs(directory, name):
    for kind in ("rates", "polhode", "phase"):
        data = (directory / f"{name}_{kind}.png").read_bytes()
        assert data.startswith(PNG) and len(data) > 10_000, kind


def test_plots_of_a_library_scene_and_an_energy_sweep(tmp_path, capsys):
    assert plot_main(["default", "--output-dir", str(tmp_path), "--duration", "12"]) == 0
    assert_pngs(tmp_path, "default")
    assert plot_main(["energy_sweep", "--output-dir", str(tmp_path), "--duration", "10", "--rate", "20"]) == 0
    assert_pngs(tmp_path, "energy_sweep")
    assert str(tmp_path / "energy_sweep_polhode.png") in capsys.readouterr().out


def test_plots_of_a_bag_use_the_inertia_it_stores(tmp_path):
    bag = tmp_path / "tumble"
    assert bag_main(["dzhanibekov", "--duration", "8", "--rate", "50", "--output", str(bag)]) == 0
    assert plot_main([str(bag), "--output-dir", str(tmp_path / "out")]) == 0
    assert_pngs(tmp_path / "out", "tumble")
    (bag / "metadata.yaml").write_text((bag / "metadata.yaml").read_text().replace("torquefree_ros.inertia", "x"))
    assert plot_main([str(bag), "--output-dir", str(tmp_path / "out")]) == 2
    assert plot_main([str(bag), "--inertia", "1", "2", "3", "--output-dir", str(tmp_path / "again")]) == 0


def test_a_scene_is_plotted_for_as_long_as_it_says_it_must_be_watched():
    from torquefree_ros import load_scene
    from torquefree_ros.plot import runs_from_scene

    explorer1 = load_scene("explorer1")
    assert explorer1.watch == 900.0  # the damper's story takes about 15 minutes
    ((_, times, omega),) = runs_from_scene(explorer1, None, 2.0)
    assert times[-1] == 900.0
    spin = omega[-200:]  # the last 100 s: the spin about the minor axis (x, I = 0.4) has died away
    assert abs(spin[:, 0]).max() < 0.05 * abs(omega[0, 0])
    ((_, times, _),) = runs_from_scene(load_scene("dzhanibekov"), None, 10.0)
    period = load_scene("dzhanibekov").propagator().body.classify(load_scene("dzhanibekov").angular_velocity)
    assert times[-1] == pytest.approx(2 * period.polhode_period, abs=0.1)  # no watch: two polhode periods


def test_plot_errors_are_named(tmp_path, capsys, monkeypatch):
    assert plot_main(["no_such_scene", "--output-dir", str(tmp_path)]) == 2
    assert "'no_such_scene' is neither a file nor a library scene" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        plot_main(["default", "--duration", "-1"])
    assert "--duration: must be a positive number" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert plot_main(["default", "--output-dir", str(tmp_path)]) == 2
    assert "pip install 'torquefree_ros[plot]'" in capsys.readouterr().err
