"""lobe.distributed on a 2-worker LocalCluster (processes): renders, batch fits and the
study give the one-machine results; a worker killed mid-task changes nothing (Dask runs
the task again); a failing file is an error on the client naming it."""

import json
import os
import signal
import threading
import time
import warnings

import numpy as np
import pytest

import lobe

distributed = pytest.importorskip("distributed", reason="lobe.distributed needs dask[distributed] (tools/mitsuba/setup.sh installs it)")
import lobe.distributed as ld  # noqa: E402

SCENE = {
    "camera": {"type": "perspective", "fov": 40, "origin": [0, 0, 4], "target": [0, 0, 0]},
    "film": {"width": 48, "height": 40},
    "sampler": {"spp": 16, "seed": 3},
    "shapes": [{"type": "sphere", "material": {"type": "ward", "diffuse": 0.3, "specular": 0.2, "alpha": 0.1}}],
    "lights": [{"type": "envmap", "file": "builtin:studio"}],
}


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    try:
        cluster.close()
    except KeyError as e:
        # distributed's SpecCluster can race at close: the event that a worker left names one
        # its `scheduler_info` has not recorded (the one the nanny restarted after the
        # killed-worker test), and `_update_worker_status` raises KeyError. It surfaces after
        # the workers and the scheduler are closed, so the cluster is down all the same.
        warnings.warn(f"LocalCluster.close raced on worker {e}")


def write_binned(path, material, n=(10, 20)):
    """Coarse isotropic binned data of ``material`` (theta_i, theta_o, phi_d)."""
    axes = [(n[0], 0.0, 80.0), (n[0], 0.0, 80.0), (n[1], 0.0, 180.0)]
    th = (np.arange(n[0]) + 0.5) * 80.0 / n[0]
    ph = (np.arange(n[1]) + 0.5) * 180.0 / n[1]
    ti, to, pd = np.meshgrid(th, th, ph, indexing="ij")
    wi = lobe.directions(ti.ravel(), np.zeros(ti.size))
    wo = lobe.directions(to.ravel(), pd.ravel())
    values = lobe.Material(material).eval(wo, wi).reshape(n[0], n[0], n[1], 3)
    lobe.write_binned(path, lobe.Binned(values.astype(np.float32), axes, False))


def test_render_in_chunks_is_the_one_machine_render(client):
    whole, var = lobe.render(SCENE, spp=16, progress=False, variance=True)
    one, one_var = ld.render(SCENE, 16, client, chunks=1, variance=True, progress=False)
    assert np.array_equal(one.view(np.uint32), whole.view(np.uint32))
    assert np.array_equal(one_var.view(np.uint32), var.view(np.uint32))
    five = ld.render(SCENE, 16, client, chunks=5, progress=False)
    np.testing.assert_allclose(five, whole, rtol=1e-5, atol=0)
    # The differences are last-bit roundings of the f64 sums, in few pixels.
    assert np.mean(five == whole) > 0.9
    with pytest.raises(ValueError, match="chunks"):
        ld.render(SCENE, 4, client, chunks=5, progress=False)


def test_render_errors_are_raised_on_the_client(client, tmp_path):
    bad = dict(SCENE, shapes=[{"type": "sphere", "material": {"type": "ward", "alpha": -1}}])
    with pytest.raises(ValueError, match="alpha"):
        ld.render(bad, 4, client, chunks=2, progress=False)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("data")
    for k, alpha in enumerate([0.08, 0.15, 0.3]):
        write_binned(str(d / f"m{k}.bin"), {"type": "ward", "diffuse": 0.1, "specular": 0.2, "alpha": alpha})
    return d


def untimed(r):
    v = r.to_json()
    for m in v["models"].values():
        m.pop("seconds")
    return v


def test_fit_gives_the_reports_of_lobe_fit(client, data):
    files = sorted(str(p) for p in data.iterdir())
    opts = dict(models="ward,blinn-phong", resolution=2.0, max_evals=60)
    got = ld.fit(files, client, progress=False, **opts)
    for f, r in zip(files, got):
        want = lobe.fit(f, progress=False, **opts)
        assert untimed(r) == untimed(want)
        assert r.key is not None and len(r.key["data"]) == 64


def test_fit_into_a_folder_is_keyed_by_content_and_matches_the_cli(client, data, tmp_path, lobe_bin):
    files = sorted(str(p) for p in data.iterdir())
    out = tmp_path / "reports"
    ld.fit(files, client, models="ward", resolution=4.0, max_evals=40, out=out, progress=False)
    before = {p.name: p.stat().st_ino for p in out.iterdir()}
    # A rerun with another model adds it; the CLI then finds every report complete.
    again = ld.fit(files, client, models="ward,lafortune", resolution=4.0, max_evals=40, out=out, progress=False)
    assert all(set(r.models) == {"ward", "lafortune"} for r in again)
    import subprocess

    o = subprocess.run([lobe_bin, "fit", str(data), "-o", str(out), "--models", "lafortune,ward", "--resolution", "4", "--max-evals", "40"], capture_output=True, text=True)
    assert o.returncode == 0, o.stderr
    assert "fitted 0 materials, 3 already done" in o.stderr, o.stderr
    assert {p.name for p in out.iterdir()} == set(before)


def test_a_failing_file_is_an_error_on_the_client_naming_it(client, data, tmp_path):
    bad = tmp_path / "broken.bin"
    bad.write_bytes(b"not binned data")
    with pytest.raises(ValueError, match="broken.bin"):
        ld.fit([str(bad), str(data / "m0.bin")], client, models="ward", resolution=4.0, progress=False)


def kill_a_worker_once_busy(client, started):
    """Kills (SIGKILL) a worker process once a task has started on it."""

    def go():
        deadline = time.time() + 60
        while time.time() < deadline:
            busy = [w for w, ts in client.processing().items() if ts]
            if busy:
                time.sleep(0.3)
                pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                started.append(pid)
                return
            time.sleep(0.05)

    t = threading.Thread(target=go)
    t.start()
    return t


def test_a_worker_killed_mid_task_changes_nothing(client, data):
    files = sorted(str(p) for p in data.iterdir())
    opts = dict(models="ward,cook-torrance", resolution=2.0, max_evals=80)
    killed = []
    t = kill_a_worker_once_busy(client, killed)
    got = ld.fit(files, client, progress=False, **opts)
    t.join()
    assert killed, "no worker was killed"
    for f, r in zip(files, got):
        assert untimed(r) == untimed(lobe.fit(f, progress=False, **opts))
    client.wait_for_workers(2, timeout=60)
    # The same during a render.
    scene = dict(SCENE, film={"width": 160, "height": 120})
    whole = lobe.render(scene, spp=64, progress=False)
    killed.clear()
    t = kill_a_worker_once_busy(client, killed)
    got = ld.render(scene, 64, client, chunks=4, progress=False)
    t.join()
    assert killed, "no worker was killed"
    np.testing.assert_allclose(got, whole, rtol=1e-5, atol=0)
    client.wait_for_workers(2, timeout=60)


def untimed_results(path):
    """results.json without the timed values (equal-time errors and curves)."""

    def strip(v):
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items() if k not in ("equal_time", "curve", "equal_time_budget", "seconds", "costs", "eval_ns", "sample_ns")}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v

    with open(path) as f:
        return strip(json.load(f))


def test_the_study_as_dask_tasks_writes_the_one_machine_report(client, data, tmp_path):
    one = tmp_path / "one"
    many = tmp_path / "many"
    inputs = [str(data / "m0.bin")]
    a = lobe.study(inputs, one, quick=True, envs=["builtin:studio"], progress=False, error_spp=48)
    b = ld.study(inputs, many, client, quick=True, envs=["builtin:studio"], progress=False, error_spp=48)
    assert a["failures"] == b["failures"] == []
    for d in (one, many):
        with open(d / "study.json") as f:
            assert json.load(f)["settings"]["error_max_spp"] == 48
    assert (a["computed"], b["computed"]) == (4, 4)
    assert b["index"] == str(many / "index.html")
    ra, rb = untimed_results(one / "results.json"), untimed_results(many / "results.json")
    assert json.dumps(ra, sort_keys=True) == json.dumps(rb, sort_keys=True)
    # A rerun finds every step done.
    again = ld.study(inputs, many, client, quick=True, envs=["builtin:studio"], progress=False, error_spp=48)
    assert (again["computed"], again["skipped"]) == (0, 4)


def test_ctrl_c_on_the_client_cancels_the_futures(client, data, monkeypatch):
    """A KeyboardInterrupt while waiting (raised here from the first progress event, as
    Ctrl-C would arrive) cancels every submitted task and is raised."""
    import lobe._progress as progress

    def interrupt(self, n, note=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(progress.Progress, "update_to", interrupt)
    files = [str(data / f"m{k}.bin") for k in range(3)] * 4
    with pytest.raises(KeyboardInterrupt):
        ld.fit(files, client, models="ward,cook-torrance-2", resolution=2.0, progress=True)

    def tasks(dask_scheduler):
        return len(dask_scheduler.tasks)

    deadline = time.time() + 30
    while client.run_on_scheduler(tasks) and time.time() < deadline:
        time.sleep(0.1)
    assert client.run_on_scheduler(tasks) == 0
