"""tools/mitsuba/bench.py's control of Dr.Jit's LLVM target (`--mitsuba-vector-width`):
the lane count it reports, and that setting 8 lanes takes effect and still computes
right. Each check runs in a fresh interpreter: the target is process-wide state."""

import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("mitsuba")
pytest.importorskip("drjit")

TOOLS = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "mitsuba"))


def run(code):
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          env=dict(os.environ, LOBE_BENCH_TOOLS=TOOLS))


def test_llvm_target_sets_the_vector_width():
    probe = run("""
        import mitsuba as mi
        try:
            mi.set_variant("llvm_ad_rgb")
        except Exception:
            print("no-llvm")
    """)
    if "no-llvm" in probe.stdout:
        pytest.skip("Mitsuba's llvm_ad_rgb variant is unavailable here (libllvm missing)")
    r = run("""
        import math, os, sys
        sys.path.insert(0, os.environ["LOBE_BENCH_TOOLS"])
        import bench
        import drjit as dr
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        cpu, width = bench.llvm_target()
        assert width in (4, 8, 16), width
        assert bench.llvm_target(8) == (cpu, 8)
        x = dr.arange(dr.llvm.Float, 1000)
        y = dr.sin(x) * 2.0
        dr.eval(y)
        assert abs(float(y[999]) - 2.0 * math.sin(999.0)) < 1e-4, float(y[999])
        print("ok", cpu, width)
    """)
    assert r.returncode == 0 and r.stdout.startswith("ok"), r.stdout + r.stderr
