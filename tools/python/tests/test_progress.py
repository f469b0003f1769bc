"""Progress and Ctrl-C of lobe.render and lobe.fit: the reports a callable receives are
in order and reach the total, the tqdm bar (or, without tqdm, plain lines) is shown,
showing progress changes no pixel, an exception from the callable and a Ctrl-C
(SIGINT) stop the work and are raised as Python exceptions, without a panic."""

import os
import signal
import sys
import threading
import time

import numpy as np
import pytest

import lobe
from conftest import MODELS, sphere_scene


def scene(width, height):
    return sphere_scene(MODELS["ward"], width, height)


def test_render_progress_is_in_order_reaches_the_total_and_changes_no_pixel(capsys):
    sc = scene(117, 69)  # 8 x 5 tiles, the last row and column partial
    calls = []
    # One worker thread, so that the calling thread has a core to take the reports as the
    # tiles finish (reports that arrive while it is busy come together, as the last one).
    img = lobe.render(sc, seed=5, threads=1,
                      progress=lambda done, total: calls.append((done, total)))
    dones = [d for d, _ in calls]
    assert len(calls) >= 2 and all(b > a for a, b in zip(dones, dones[1:])), calls
    assert {t for _, t in calls} == {117 * 69} and dones[-1] == 117 * 69
    quiet = lobe.render(sc, seed=5, progress=False)
    bar = lobe.render(sc, seed=5, progress=True)
    assert img.tobytes() == quiet.tobytes() == bar.tobytes()
    err = capsys.readouterr().err
    assert "100%" in err and "lobe.render: 117x69 at 16 spp" in err, err


def test_render_progress_without_tqdm_prints_lines(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # `from tqdm.auto import tqdm` fails
    lobe.render(scene(64, 64), progress=True)
    lines = capsys.readouterr().err.splitlines()
    # Not a terminal: one line when done, not one per tenth.
    assert [l for l in lines if l.startswith("rendering:")] == ["rendering: 100% (4096 of 4096)"], lines
    assert lines[-1].startswith("lobe.render: 64x64 at 16 spp")


def test_an_exception_in_the_render_callback_stops_the_render_and_is_raised():
    seen = []

    def fail(done, total):
        seen.append(done)
        raise ZeroDivisionError("the callback's own error")

    with pytest.raises(ZeroDivisionError, match="the callback's own error"):
        lobe.render(scene(96, 96), spp=2048, progress=fail)
    # Called once: the render stopped instead of reporting its other tiles.
    assert len(seen) == 1 and seen[0] < 96 * 96


def interrupt_after(seconds):
    """Sends this process SIGINT (what Ctrl-C and a notebook's interrupt do) later."""
    t = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    t.start()
    return t


# A render and a fit that take more than ten seconds each on two idle cores; Ctrl-C must
# stop them in a fraction of that (before, the work ran to its end, and only then was the
# KeyboardInterrupt raised).
def test_ctrl_c_stops_a_render():
    start = time.perf_counter()
    timer = interrupt_after(0.3)
    with pytest.raises(KeyboardInterrupt):
        lobe.render(scene(32, 32), spp=1 << 18, progress=False)  # 268 M samples: > 10 s
    timer.join()
    assert time.perf_counter() - start < 3.0


def test_ctrl_c_stops_a_fit():
    start = time.perf_counter()
    timer = interrupt_after(1.0)  # after binning the data (0.3 s), in the second model
    with pytest.raises(KeyboardInterrupt):
        lobe.fit(lobe.Material(MODELS["cook-torrance"]), resolution=1.0, progress=False)  # 14 s
    timer.join()
    assert time.perf_counter() - start < 4.0


def test_fit_progress_reports_each_model_and_callback_errors_are_raised(capsys):
    m = lobe.Material(MODELS["blinn-phong"])
    calls = []
    r = lobe.fit(m, models="blinn-phong,ward", resolution=5, max_evals=40, progress=lambda *a: calls.append(a))
    assert [c[0] for c in calls] == ["blinn-phong", "ward"]
    assert calls[0][1] == r.models["blinn-phong"].error_normalized
    lobe.fit(m, models="blinn-phong,ward", resolution=5, max_evals=40, progress=True)
    assert "2/2" in capsys.readouterr().err

    def fail(label, error, seconds):
        raise RuntimeError(f"stop after {label}")

    with pytest.raises(RuntimeError, match="stop after blinn-phong"):
        lobe.fit(m, models="blinn-phong,ward", resolution=5, max_evals=40, progress=fail)


def test_progress_and_interrupt_in_a_jupyter_kernel():
    """In a real notebook kernel (ipykernel, as Jupyter runs it): lobe.render and lobe.fit
    show tqdm's notebook widget and update it, and the notebook's interrupt (SIGINT to the
    kernel) stops a long render and a long fit with KeyboardInterrupt, leaving the kernel
    usable."""
    pytest.importorskip("ipykernel")
    pytest.importorskip("ipywidgets")
    manager = pytest.importorskip("jupyter_client.manager")
    import queue

    km, kc = manager.start_new_kernel(kernel_name="python3")

    def run(code, interrupt_after=None):
        msg_id, start, interrupted = kc.execute(code), time.perf_counter(), False
        seen = {"widgets": 0, "updates": 0, "text": "", "error": None}
        while True:
            if interrupt_after is not None and not interrupted and time.perf_counter() - start > interrupt_after:
                km.interrupt_kernel()
                interrupted = True
            try:
                m = kc.get_iopub_msg(timeout=0.2)
            except queue.Empty:
                assert time.perf_counter() - start < 120, f"{code}: no reply"
                continue
            if m["parent_header"].get("msg_id") != msg_id:
                continue
            kind, c = m["msg_type"], m["content"]
            if kind == "display_data" and "application/vnd.jupyter.widget-view+json" in c["data"]:
                seen["widgets"] += 1
            elif kind == "comm_msg":
                seen["updates"] += 1
            elif kind == "stream":
                seen["text"] += c["text"]
            elif kind == "error":
                seen["error"] = c["ename"]
            elif kind == "status" and c["execution_state"] == "idle":
                seen["seconds"] = time.perf_counter() - start
                return seen

    try:
        tests = os.path.dirname(os.path.abspath(__file__))
        assert run(f"import sys, lobe; sys.path.insert(0, {tests!r}); from test_progress import scene; from conftest import MODELS")["error"] is None
        r = run("print(lobe.render(scene(64, 64), spp=64).shape)")
        assert r["error"] is None and r["widgets"] == 1 and r["updates"] >= 2 and "(64, 64, 3)" in r["text"], r
        r = run('print(list(lobe.fit(lobe.Material(MODELS["blinn-phong"]), models="blinn-phong,ward", resolution=5, max_evals=40).models))')
        assert r["error"] is None and r["widgets"] == 1 and r["updates"] >= 2 and "['blinn-phong', 'ward']" in r["text"], r
        # Both would run for more than ten seconds (see the Ctrl-C tests above).
        r = run("lobe.render(scene(32, 32), spp=1 << 18)", interrupt_after=1.0)
        assert r["error"] == "KeyboardInterrupt" and r["seconds"] < 4.0, r
        r = run('lobe.fit(lobe.Material(MODELS["cook-torrance"]), resolution=1.0)', interrupt_after=1.0)
        assert r["error"] == "KeyboardInterrupt" and r["seconds"] < 4.0, r
        assert run("print(1 + 1)")["text"] == "2\n"
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)
