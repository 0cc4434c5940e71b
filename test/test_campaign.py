"""Monte Carlo campaigns (issue 32): the campaign file's checks, the draws, the metrics against known
answers, and the engine's one promise: the same table, bit for bit, in-process, on Dask workers
(a LocalCluster, and a scheduler and workers started as separate processes) and with any chunking.

Every Dask cluster here listens on 127.0.0.1 only and is closed by the test or fixture that made it."""

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml

from torquefree_ros import RigidBody, propagate_batch
from torquefree_ros.campaigns import METRICS, CampaignError, load_campaign, metric, run_campaign
from torquefree_ros.campaigns.dispersions import run_generator
from torquefree_ros.campaigns.metrics import Samples
from torquefree_ros.cli import campaign as campaign_cli

VENV_BIN = Path(sys.executable).parent


# -- helpers ---------------------------------------------------------------------------------------------
def assert_same_table(a: pa.Table, b: pa.Table) -> None:
    """Bit for bit: the same columns, nulls, bytes of every float (NaN included) and metadata."""
    assert a.schema.equals(b.schema, check_metadata=True)
    assert a.num_rows == b.num_rows
    for name in a.column_names:
        x, y = a.column(name).combine_chunks(), b.column(name).combine_chunks()
        assert x.is_null().equals(y.is_null()), name
        if pa.types.is_floating(x.type):
            xs = x.fill_null(0.0).to_numpy(zero_copy_only=False).view(np.int64)
            ys = y.fill_null(0.0).to_numpy(zero_copy_only=False).view(np.int64)
            assert np.array_equal(xs, ys), name
        else:
            assert x.to_pylist() == y.to_pylist(), name


def torque_free_campaign(runs=600):
    """A triaxial body near its limit (redraws happen), rates and attitude dispersed, every metric."""
    return {"scene": "default", "runs": runs, "seed": 32, "duration": 12.0, "rate": 5.0,
            "dispersions": {"body.moments": {"relative": {"normal": {"sigma": 0.03}}},
                            "initial.angular_velocity": [{"absolute": {"uniform": {"low": -0.1, "high": 0.1}}},
                                                         {"replace": {"values": [0.0, 0.2, 0.4]}}, None],
                            "initial.orientation": {"small_rotation": {"sigma": 0.02}}},
            "metrics": ["final_rates", {"settle_time": {"threshold": 1.2}}, "cone_angle", "flips", "energy_drift",
                        "momentum_drift", "nominal_attitude_error"]}


def damper_campaign(runs=60):
    """explorer1 through the batched Plant; a damping dispersion so wide that some runs draw a negative
    coefficient, which the scene refuses: those rows fail with the reason, the others run."""
    return {"scene": "explorer1", "runs": runs, "seed": 7, "duration": 30.0, "rate": 1.0,
            "dispersions": {"effects[0].damper.damping": {"relative": {"normal": {"sigma": 1.0}}},
                            "initial.angular_velocity": {"absolute": {"normal": {"sigma": 0.05}}}},
            "metrics": ["final_rates", "cone_angle", "energy_drift", "nominal_attitude_error"]}


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes on loopback, started once for the module."""
    from torquefree_ros.campaigns.engine import local_cluster

    with np.errstate(all="ignore"):  # the module-scoped fixture runs outside the per-test errstate
        local = local_cluster(2)
    try:
        yield local
    finally:
        local.close()


# -- the engine: the same table everywhere ---------------------------------------------------------------
def test_same_table_in_process_on_two_workers_and_with_other_chunks(cluster):
    reference = run_campaign(torque_free_campaign(), scheduler="in-process")
    assert reference.num_rows == 600 and set(reference.column("status").to_pylist()) == {"ok"}
    assert max(reference.column("redraws").to_pylist()) > 0  # the dispersion does reach the limit
    assert_same_table(reference, run_campaign(torque_free_campaign(), scheduler="in-process", chunk_size=7))
    on_workers = run_campaign(torque_free_campaign(), scheduler=cluster.scheduler_address, chunk_size=64)
    assert_same_table(reference, on_workers)


def test_a_scene_with_effects_gives_the_same_table_on_workers_and_failed_runs_are_rows(cluster):
    reference = run_campaign(damper_campaign(), scheduler="in-process")
    status = reference.column("status").to_pylist()
    failed = [i for i, s in enumerate(status) if s != "ok"]
    assert 0 < len(failed) < len(status)
    for i in failed:  # the scene's own check, with the field path, and no metric for that run
        assert status[i] == "invalid_scene"
        assert reference.column("reason")[i].as_py().startswith("effects[0].damper.damping: must be > 0")
        assert reference.column("effects[0].damper.damping")[i].as_py() <= 0
        assert not reference.column("final_wx")[i].is_valid
    assert_same_table(reference, run_campaign(damper_campaign(), scheduler="in-process", chunk_size=11))
    assert_same_table(reference, run_campaign(damper_campaign(), scheduler=cluster.scheduler_address, chunk_size=8))


def test_a_scheduler_and_workers_started_as_separate_processes_are_used_by_address(tmp_path):
    """``dask scheduler`` and ``dask worker`` as subprocesses (what a cluster looks like), the campaign
    pointed at the scheduler's address; both processes are ended by their pids."""
    from distributed import Client

    scheduler_file = tmp_path / "scheduler.json"
    environment = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    started = []
    try:
        started.append(subprocess.Popen(
            [str(VENV_BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(scheduler_file)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env=environment))
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert scheduler_file.exists(), "the scheduler did not start in 60 s"
        started.append(subprocess.Popen(
            [str(VENV_BIN / "dask"), "worker", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
             "--nworkers", "2", "--nthreads", "1", "--no-dashboard"], stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, env=environment))
        with Client(scheduler_file=str(scheduler_file), timeout="60s") as client:
            client.wait_for_workers(2, timeout=60)
            address = client.scheduler.address
        table = run_campaign(torque_free_campaign(300), scheduler=address, chunk_size=50)
        assert_same_table(run_campaign(torque_free_campaign(300), scheduler="in-process"), table)
    finally:
        for process in reversed(started):
            process.terminate()
        for process in reversed(started):
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def test_a_run_draws_from_its_own_seed_only():
    """Run i's inputs depend on (seed, i): the first runs of a longer campaign are the shorter one's, and
    run i's generator is SeedSequence(seed).spawn(runs)[i]'s."""
    short = run_campaign(torque_free_campaign(20), scheduler="in-process")
    long = run_campaign(torque_free_campaign(60), scheduler="in-process").slice(0, 20)
    for name in short.column_names:
        assert short.column(name).to_pylist() == long.column(name).to_pylist()
    spawned = np.random.SeedSequence(32).spawn(60)[17]
    assert run_generator(32, 17).random() == np.random.Generator(np.random.PCG64(spawned)).random()


def test_the_inputs_in_the_table_reproduce_each_run():
    """The drawn inputs are what ran: propagating a row's body and initial state again gives its final rates."""
    table = run_campaign(torque_free_campaign(40), scheduler="in-process").to_pydict()
    moments = np.array([[table[f"body.moments[{k}]"][i] for k in range(3)] for i in range(40)])
    omega0 = np.array([[table[f"initial.angular_velocity[{k}]"][i] for k in range(3)] for i in range(40)])
    q0 = np.array([[table[f"initial.orientation[{k}]"][i] for k in range(4)] for i in range(40)])
    assert omega0[:, 1].tolist() == [[0.0, 0.2, 0.4][i % 3] for i in range(40)]  # the sweep: values[i % 3]
    assert np.all(np.abs(omega0[:, 2] - 1.0) == 0)  # not dispersed: the scene's own
    omega, _ = propagate_batch(moments, omega0, q0, np.arange(61) / 5.0)
    assert np.array_equal(omega[:, -1, 0], table["final_wx"]) and np.array_equal(omega[:, -1, 2], table["final_wz"])


# -- impossible bodies -----------------------------------------------------------------------------------
def limit_body(invalid_body, tmp_path):
    scene = tmp_path / "flat.yaml"
    scene.write_text("body: {inertia: [3.0, 2.0, 1.0]}\ninitial: {angular_velocity: [0.1, 1.0, 0.1]}\n")
    return {"scene": str(scene), "runs": 400, "seed": 3, "duration": 1.0, "rate": 2.0, "invalid_body": invalid_body,
            "dispersions": {"body.moments": {"relative": {"normal": {"sigma": 0.02}}}}, "metrics": ["final_rates"]}


def test_a_nominal_body_on_the_triangle_limit_redraws_or_fails_as_the_file_says(tmp_path):
    """[3, 2, 1] is a flat plate: about half the draws of independent moments are no body at all."""
    campaign = load_campaign(limit_body("fail", tmp_path))
    assert 0.4 < campaign.body_acceptance < 0.6  # measured when loaded, kept in the metadata
    failing = run_campaign(campaign, scheduler="in-process").to_pydict()
    bad = [i for i, s in enumerate(failing["status"]) if s != "ok"]
    assert 0.4 < len(bad) / 400 < 0.6 and set(failing["status"][i] for i in bad) == {"invalid_body"}
    assert all("triangle inequality" in failing["reason"][i] for i in bad)
    assert all(failing["final_wx"][i] is None for i in bad)
    redrawn = run_campaign(limit_body("redraw", tmp_path), scheduler="in-process").to_pydict()
    assert set(redrawn["status"]) == {"ok"} and max(redrawn["redraws"]) > 0
    m = np.array([[redrawn[f"body.moments[{k}]"][i] for k in range(3)] for i in range(400)])
    assert np.all(m.max(axis=1) <= (m.sum(axis=1) - m.max(axis=1)) * (1 + 1e-9))  # every kept body is physical
    # a run that drew a physical body first is the same run either way (the body draws last)
    for i in range(400):
        if failing["status"][i] == "ok":
            assert failing["body.moments[0]"][i] == redrawn["body.moments[0]"][i]


def test_a_run_that_runs_out_of_redraws_fails_with_the_count(tmp_path):
    data = limit_body("redraw", tmp_path)
    data["max_redraws"] = 0
    table = run_campaign(data, scheduler="in-process").to_pydict()
    reasons = [r for r in table["reason"] if r]
    assert reasons and all(r.endswith("(after 0 redraws)") for r in reasons)


# -- bad campaign files -----------------------------------------------------------------------------------
BAD_FILES = {
    "unknown distribution": ({"body.moments": {"relative": {"gaussian": {"sigma": 0.1}}}},
                             "dispersions.body.moments.relative: unknown distribution 'gaussian' (known: normal, truncated_normal"),
    "negative sigma": ({"initial.angular_velocity": {"absolute": {"normal": {"sigma": -0.1}}}},
                       "dispersions.initial.angular_velocity.absolute.normal.sigma: must be >= 0"),
    "no valid body": ({"body.moments": {"relative": {"uniform": {"low": -3.0, "high": -1.5}}}},
                      "dispersions.body.moments: gives no physical body"),
    "effect index outside the scene": ({"effects[5].damper.damping": {"relative": {"normal": {"sigma": 0.1}}}},
                                       "dispersions.effects[5].damper.damping: outside the scene: it has 3 effects"),
    "another effect": ({"effects[1].damper.damping": {"relative": {"normal": {"sigma": 0.1}}}},
                       "dispersions.effects[1].damper.damping: outside the scene: effects[1] is tf, not 'damper'"),
    "unknown parameter": ({"effects[0].damper.dampin": {"relative": {"normal": {"sigma": 0.1}}}},
                          "has no parameter 'dampin'; did you mean 'damping'?"),
    "unknown target": ({"body.mass": {"relative": {"normal": {"sigma": 0.1}}}}, "dispersions.body.mass: not a target"),
    "wrong component count": ({"initial.angular_velocity": [{"absolute": {"normal": {"sigma": 0.1}}}]},
                              "a list of 3 (one per component"),
    "empty truncation": ({"initial.angular_velocity": {"absolute": {"truncated_normal": {
        "sigma": 0.1, "low": 5.0, "high": 6.0}}}}, "holds no probability"),
    "unknown mode": ({"body.moments": {"relativ": {"normal": {"sigma": 0.1}}}}, "did you mean 'relative'?"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_campaign_file_names_the_file_and_the_field(case, tmp_path):
    dispersions, expected = BAD_FILES[case]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"scene": "explorer1", "runs": 10, "seed": 1, "duration": 1, "rate": 1,
                                    "dispersions": dispersions}))
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    assert str(error.value).startswith(f"{path}: ")
    assert expected in str(error.value)


@pytest.mark.parametrize("change, expected", [
    ({"metrics": ["final_rates", "settle_time"]}, "metrics[1].settle_time.threshold: missing"),
    ({"metrics": ["flipz"]}, "metrics[0]: unknown metric 'flipz'; did you mean 'flips'?"),
    ({"metrics": ["flips", "flips"]}, "metrics[1]: flips is already metrics[0]"),
    ({"runs": 0}, "runs: must lie in"),
    ({"scene": "no_such_scene"}, "scene: scene: 'no_such_scene' is neither a file nor a library scene"),
    ({"invalid_body": "retry"}, "invalid_body: expected one of redraw, fail"),
    ({"seeds": 1}, "seeds: unknown key; did you mean 'seed'?"),
])
def test_bad_top_level_fields(change, expected, tmp_path):
    data = {"scene": "dzhanibekov", "runs": 10, "seed": 1, "duration": 1, "rate": 1}
    data.update(change)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CampaignError, match="^" + str(path).replace(".", r"\.") + ": ") as error:
        load_campaign(path)
    assert expected in str(error.value)


# -- metrics against known answers ------------------------------------------------------------------------
def samples_of(inertia, omega0, times, q0=(0.0, 0.0, 0.0, 1.0)):
    omega, q = propagate_batch([inertia], [omega0], [q0], times)
    body = RigidBody.from_inertia(inertia)
    return Samples(times, omega, q, np.empty(omega.shape[:2] + (0,)), body.tensor[None], body.moments[None],
                   body.principal_axes[None])


def test_cone_angle_of_a_symmetric_top_is_its_closed_form():
    """An oblate top (I_T = 1, I_3 = 2): H keeps tan(theta) = I_T w_t / (I_3 w_3) from the symmetry axis."""
    samples = samples_of([1.0, 1.0, 2.0], [0.3, 0.4, 1.0], np.linspace(0.0, 20.0, 401))
    expected = math.atan2(1.0 * 0.5, 2.0 * 1.0)
    got = METRICS["cone_angle"].function(samples, axis="major")[0]
    assert abs(got - expected) < 1e-14  # a few ULPs of atan2 on exact rates (|H_B| constant)
    assert abs(METRICS["cone_angle"].function(samples, axis="z")[0] - expected) < 1e-14


def test_flips_of_a_dzhanibekov_body_over_a_known_number_of_flip_periods():
    """Spun about the intermediate axis, the nut reverses once a flip period (classify gives it); over
    K periods starting mid-dwell, K reversals, half a period clear of either end."""
    inertia, omega0 = [1.0, 2.0, 3.0], [0.001, 5.0, 0.001]
    period = RigidBody.from_inertia(inertia).classify(omega0).flip_period
    assert "flip period" in RigidBody.from_inertia(inertia).classify(omega0).summary()
    for K in (1, 4, 7):
        samples = samples_of(inertia, omega0, np.linspace(0.0, K * period, 200 * K + 1))
        assert METRICS["flips"].function(samples, margin=30.0)[0] == K
    stable = samples_of(inertia, [0.3, 0.2, 5.0], np.linspace(0.0, 60.0, 601))  # near the major axis: no flip
    assert METRICS["flips"].function(stable, margin=30.0)[0] == 0


def test_drifts_of_the_exact_solution_are_rounding():
    samples = samples_of([1.0, 2.0, 2.5], [0.3, 1.0, 0.2], np.linspace(0.0, 100.0, 1001), (0.1, 0.2, 0.3, 0.927))
    assert METRICS["energy_drift"].function(samples)[0] < 1e-13  # the exact solution conserves both to rounding
    assert METRICS["momentum_drift"].function(samples)[0] < 1e-13


def test_settle_time_and_drifts_under_a_constant_torque_against_the_closed_form(tmp_path):
    """A sphere (I = 1) spun at 1 rad/s about x under -0.1 N m about x: w_x = 1 - 0.1 t. |w| < 0.555 from
    t > 4.45 s, first sample 4.5 s at 10 Hz (0.005 rad/s clear of the threshold); at 8 s: T drops by 1 - 0.2^2 = 0.96 of T_0, H_N (along x,
    fixed) by 0.8 of |H_0|; the integrator's 1e-10 accuracy is far inside the 1e-8 allowed."""
    scene = tmp_path / "brake.yaml"
    scene.write_text("body: {inertia: [1.0, 1.0, 1.0]}\ninitial: {angular_velocity: [1.0, 0.0, 0.0]}\n"
                     "effects: [{external_torque: {torque: [-0.1, 0.0, 0.0]}}]\naccuracy: 1.0e-10\n")
    data = {"scene": str(scene), "runs": 1, "seed": 0, "duration": 8.0, "rate": 10.0,
            "metrics": [{"settle_time": {"threshold": 0.555}}, "energy_drift", "momentum_drift", "final_rates"]}
    row = run_campaign(data, scheduler="in-process").to_pylist()[0]
    assert row["settle_time"] == pytest.approx(4.5, abs=1e-12)
    assert row["energy_drift"] == pytest.approx(0.96, abs=1e-8)
    assert row["momentum_drift"] == pytest.approx(0.8, abs=1e-8)
    assert row["final_wx"] == pytest.approx(0.2, abs=1e-8)
    data["duration"] = 20.0  # w_x = -1 at the end: |w| is back over the threshold
    assert math.isnan(run_campaign(data, scheduler="in-process").to_pylist()[0]["settle_time"])


def test_attitude_error_from_the_nominal_run_is_the_drawn_inertial_rotation():
    """A torque-free motion turned by an inertial rotation r stays r ⊗ q_nominal(t): the error is the
    drawn rotation's angle at every sample."""
    data = {"scene": "dzhanibekov", "runs": 30, "seed": 5, "duration": 20.0, "rate": 10.0,
            "dispersions": {"initial.orientation": {"small_rotation": {"sigma": 0.05}}},
            "metrics": ["nominal_attitude_error"]}
    table = run_campaign(data, scheduler="in-process").to_pydict()
    q0 = np.array([[table[f"initial.orientation[{k}]"][i] for k in range(4)] for i in range(30)])
    drawn = 2.0 * np.arctan2(np.linalg.norm(q0[:, :3], axis=1), np.abs(q0[:, 3]))  # nominal q0 is identity
    assert np.max(np.abs(np.array(table["nominal_attitude_error"]) - drawn)) < 1e-12  # rounding over 200 samples


def test_a_metric_added_as_a_python_function():
    @metric("peak_rate_test", unit="rad/s")
    def peak_rate(samples):
        """The largest |w| of the run."""
        return samples.rate_norm().max(axis=1)

    try:
        data = {"scene": "dzhanibekov", "runs": 5, "seed": 1, "duration": 2.0, "rate": 10.0,
                "dispersions": {"initial.angular_velocity": {"absolute": {"normal": {"sigma": 0.1}}}},
                "metrics": ["peak_rate_test", "final_rates"]}
        table = run_campaign(data, scheduler="in-process")
        assert table.column_names[-4:] == ["peak_rate_test", "final_wx", "final_wy", "final_wz"]
        assert all(v >= 4.5 for v in table.column("peak_rate_test").to_pylist())
    finally:
        del METRICS["peak_rate_test"]


# -- results, library, command line ----------------------------------------------------------------------
def test_the_parquet_file_holds_the_table_the_campaign_and_the_versions(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(torque_free_campaign(30)))
    table = run_campaign(path, scheduler="in-process", output=tmp_path / "out")
    back = pq.read_table(tmp_path / "out" / "runs.parquet")
    assert_same_table(table, back)
    meta = back.schema.metadata
    assert meta[b"torquefree_ros.campaign"].decode() == path.read_text()
    assert b'"numpy": "' + np.__version__.encode() in meta[b"torquefree_ros.versions"]
    with pytest.raises(FileExistsError, match="--overwrite"):
        run_campaign(path, scheduler="in-process", output=tmp_path / "out")


def test_the_library_campaigns_load_and_run_shortened():
    for name in ("explorer1_damper", "dzhanibekov_rates"):
        campaign = load_campaign(name)
        data = yaml.safe_load(campaign.text)
        data.update(runs=12, duration=min(data["duration"], 30.0))
        table = run_campaign(data, scheduler="in-process")
        assert table.num_rows == 12 and set(table.column("status").to_pylist()) == {"ok"}


def test_the_command_line_runs_a_file_and_refuses_a_bad_one_with_status_2(tmp_path, capsys):
    good = tmp_path / "good.yaml"
    good.write_text(yaml.safe_dump(torque_free_campaign(20)))
    assert campaign_cli.main(["run", str(good), "--output", str(tmp_path / "out"), "--scheduler", "in-process"]) == 0
    assert "20 runs (20 ok, 0 failed)" in capsys.readouterr().out
    assert pq.read_table(tmp_path / "out" / "runs.parquet").num_rows == 20
    bad = tmp_path / "bad.yaml"
    bad.write_text("scene: explorer1\nruns: 3\nseed: 1\nduration: 1\nrate: 1\n"
                   "dispersions:\n  effects[0].damper.damping: {relative: {normal: {sigma: -1}}}\n")
    assert campaign_cli.main(["run", str(bad), "--output", str(tmp_path / "o2")]) == 2
    assert f"{bad}: dispersions.effects[0].damper.damping.relative.normal.sigma: must be >= 0" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        campaign_cli.main(["run", str(good), "--output", str(tmp_path / "o3"), "--workers", "0"])
    assert exit_.value.code == 2
