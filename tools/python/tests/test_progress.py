"""Progress and Ctrl-C of lobe.render and lobe.fit: the reports a callable receives are
in order and reach the total, the tqdm bar (or, without tqdm, plain lines) is shown,
showing progress changes no pixel, an exception from the callable and a Ctrl-C
(SIGINT) stop the work and are raised as Python exceptions, without a panic."""

import os
import resource
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


def cpu_seconds():
    """This process's CPU time: a count of the work done, which a loaded machine does not
    inflate as it does wall time."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def interrupt_on_first(cpu):
    """A progress callable that, at its first report, has another thread send this process
    SIGINT (what Ctrl-C and a notebook's interrupt do), and notes the CPU time spent then in
    `cpu`. The interrupt is driven by the work's own progress, not by a clock."""
    def on_progress(*report):
        if not cpu:
            cpu.append(cpu_seconds())
            threading.Thread(target=os.kill, args=(os.getpid(), signal.SIGINT)).start()
    return on_progress


def work_after_interrupt(call):
    """Runs `call(progress)`, which must raise KeyboardInterrupt; returns the CPU time spent
    after the interrupt relative to the time spent before it (setup and the first unit of
    work)."""
    cpu = [cpu_seconds()]
    progress = interrupt_on_first(cpu_after := [])
    with pytest.raises(KeyboardInterrupt):
        call(progress)
    assert cpu_after, "no progress was reported"
    return (cpu_seconds() - cpu_after[0]) / (cpu_after[0] - cpu[0])


# A render of 256 tiles and a fit of seven models, each more than ten seconds of work on two
# idle cores, that report their first progress after a small share of it. Ctrl-C must stop
# them within a few units of work (before, the work ran to its end, and only then was the
# KeyboardInterrupt raised: a ratio of about 100 for the render and 30 for the fit).
def test_ctrl_c_stops_a_render():
    ratio = work_after_interrupt(
        lambda progress: lobe.render(scene(256, 256), spp=1 << 12, threads=2, progress=progress))
    assert ratio < 8, ratio


def test_ctrl_c_stops_a_fit():
    ratio = work_after_interrupt(
        lambda progress: lobe.fit(lobe.Material(MODELS["cook-torrance"]), resolution=1.0,
                                  progress=progress))
    assert ratio < 4, ratio


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

    pid = None

    def kernel_cpu():
        """The kernel process's CPU seconds (Linux's /proc; 0 before its pid is known)."""
        if pid is None:
            return 0.0
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def run(code, interrupt=False):
        """Runs `code` in the kernel; with `interrupt`, interrupts it when the progress bar
        first moves and measures the kernel's CPU time before and after the interrupt."""
        msg_id, start = kc.execute(code), time.perf_counter()
        seen = {"widgets": 0, "updates": 0, "text": "", "error": None, "cpu": [kernel_cpu()]}
        while True:
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
                value = c["data"].get("state", {}).get("value")  # the bar's (not a label's)
                moved = isinstance(value, (int, float)) and value > 0
                if interrupt and moved and len(seen["cpu"]) == 1:
                    seen["cpu"].append(kernel_cpu())
                    km.interrupt_kernel()
            elif kind == "stream":
                seen["text"] += c["text"]
            elif kind == "error":
                seen["error"] = c["ename"]
            elif kind == "status" and c["execution_state"] == "idle":
                seen["cpu"].append(kernel_cpu())
                return seen

    def work_after_interrupt(seen, unit):
        """The kernel's CPU time after the interrupt, relative to that of `unit`, which
        measures the CPU time of a known share of the work in the kernel and prints it."""
        _, at, end = seen["cpu"]
        return (end - at) / float(run(unit)["text"])

    try:
        tests = os.path.dirname(os.path.abspath(__file__))
        pid = int(run("import os; print(os.getpid())")["text"])
        assert run(f"import sys, lobe; sys.path.insert(0, {tests!r}); from test_progress import scene; from conftest import MODELS")["error"] is None
        r = run("print(lobe.render(scene(64, 64), spp=64).shape)")
        assert r["error"] is None and r["widgets"] == 1 and r["updates"] >= 2 and "(64, 64, 3)" in r["text"], r
        r = run('print(list(lobe.fit(lobe.Material(MODELS["blinn-phong"]), models="blinn-phong,ward", resolution=5, max_evals=40).models))')
        assert r["error"] is None and r["widgets"] == 1 and r["updates"] >= 2 and "['blinn-phong', 'ward']" in r["text"], r
        # Both would run for more than ten seconds (see the Ctrl-C tests above); interrupted at
        # the bar's first move, they stop within a small share of their work: the render
        # within 16/64 of it (the unit renders 1/64), the fit within 4 of its seven models.
        measure = "import resource; c = resource.getrusage(resource.RUSAGE_SELF); {}; " \
            "d = resource.getrusage(resource.RUSAGE_SELF); " \
            "print(d.ru_utime + d.ru_stime - c.ru_utime - c.ru_stime)"
        r = run("lobe.render(scene(256, 256), spp=1 << 12)", interrupt=True)
        unit = measure.format("lobe.render(scene(256, 256), spp=1 << 6, progress=False)")
        assert r["error"] == "KeyboardInterrupt" and work_after_interrupt(r, unit) < 16, r
        r = run('lobe.fit(lobe.Material(MODELS["cook-torrance"]), resolution=1.0)', interrupt=True)
        unit = measure.format('lobe.fit(lobe.Material(MODELS["cook-torrance"]), models="ward", '
                              'resolution=1.0, progress=False)')
        assert r["error"] == "KeyboardInterrupt" and work_after_interrupt(r, unit) < 4, r
        assert run("print(1 + 1)")["text"] == "2\n"
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)
