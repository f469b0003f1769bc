#!/usr/bin/env python3
"""lobe against Mitsuba 3 on the same scenes, in the same run.

    tools/mitsuba/bench.sh --suite [MANIFEST] [--runs 11]     # the users' workloads
    tools/mitsuba/bench.sh [SCENE.json ...] [--spp 64] [--reference-spp 2048] [--runs 3]

`--suite` runs the scenes of scenes/bench/suite.json (measured materials of every kind on a
sphere, the study's analytic fits, a million-triangle mesh, a mesh on a floor, the Cornell
box's area light, the env-map sphere scenes), after making the generated inputs
(bench_assets.py). Without it, the named scenes (default: scenes/sphere-envmap.json and
scenes/spheres-envmap.json).

For each scene it renders with lobe (`lobe render`, release build), Mitsuba `llvm_ad_rgb`
(after one untimed run that compiles the kernel) and Mitsuba `scalar_rgb`, all at the same
spp on all cores, and reports times, Msamples/s, the RMSE against a high-spp lobe reference
rendered with another seed, and two ratios per Mitsuba configuration, both above 1 when lobe
is faster: lobe's speed over Mitsuba's, and the equal-error time ratio

    (t_X RMSE_X^2) / (t_lobe RMSE_lobe^2)

i.e. how much longer renderer X needs than lobe to reach the same error (RMSE^2 falls as
1/spp for these unbiased renderers, and about so for the low-discrepancy samplers at these
spp). Each renderer's RMSE is that of all its renders of the rounds (the mean of their
squared errors, then the root): one render's error varies by several percent from seed
to seed, which the equal-error ratio would carry twice. lobe's padded, XOR-scrambled
Sobol' sampler has less variance per sample than Mitsuba's default `independent`
sampler, so `llvm_ad_rgb` is also run with Mitsuba's `ldsampler` (the same construction:
XOR-scrambled (0,2)-sequences per dimension pair): that column is the like-for-like
equal-error comparison. Materials Mitsuba cannot load
(MERL tables, binned data) are compared with Mitsuba's render of the suite's `mitsuba_peer`
scene (the same RGL measurement that the tables tabulate), each against its own reference.
A suite entry's `mitsuba_native` (lobe material type -> Mitsuba BSDF dict) makes Mitsuba
render those materials with its own plugins (`roughconductor`, `roughplastic`), so that its
sampling is its own and not lobe's Dr.Jit twin. The models then differ (lobe's
Cook-Torrance has V-groove G, Mitsuba's Smith G; the suite's scenes set `specular` pi / 4,
which cancels Ngan's 1 / pi against Mitsuba's 1 / 4), so each renderer's error is its
relative MSE, mean((img - ref)^2 / (ref^2 + 0.01)), against its
own reference at the reference spp.
Prints a Markdown table (with the machine) and writes it to --out if given; the per-renderer
details go to stderr as each scene finishes and follow the table.

The machine may be shared and its speed drift over a run, so lobe and each `llvm_ad_rgb`
configuration run in rounds: each round renders once with lobe and once with Mitsuba, one
after the other, and the speed and equal-error ratios are the medians of the per-round
ratios (paired), not ratios of medians taken minutes apart. One Mitsuba scene is alive at
a time, as when a user renders a scene: with a second copy of the scene loaded in the same
process, Dr.Jit compiles a different kernel for it that runs 1.3-1.4x faster on
sphere-envmap (measured: 15-17 against 20-24 Msamples/s), a state no single-scene render
reaches. `scalar_rgb`, tens of times slower, runs after the rounds.

Dr.Jit compiles Mitsuba's kernels for the CPU it runs on: on an AVX-512 CPU with 16 f32
lanes. lobe is built for the CPU that builds it (.cargo/config.toml), so its kernels are
16 lanes wide there too (`lobe_materials::simd::LANES`; 8 on AVX2 CPUs). The table's header
names both; `--mitsuba-vector-width 8` makes Mitsuba AVX2-class code of 8 lanes, a
diagnostic of how much of its speed is the wider vectors (the targets are set against
the default).
"""

import argparse
import gc
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", ".."))
sys.path.insert(0, here)

import mitsuba as mi  # noqa: E402
import drjit as dr  # noqa: E402
import numpy as np  # noqa: E402


def lobe_bin():
    exe = os.path.join(root, "target", "release", "lobe")
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "lobe-cli"], cwd=root, check=True)
    return exe


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


# What lobe's renders report of its build (the SIMD lane count), for the table's header.
LOBE_BUILD = {}


def lobe_render(exe, scene, spp, seed, out):
    subprocess.run([exe, "render", scene, "--spp", str(spp), "--seed", str(seed), "-o", out, "--no-png", "-q"],
                   check=True)
    stats = out[:-4] + ".stats.json"
    with open(stats) as f:
        s = json.load(f)
    if "simd_lanes" in s:
        LOBE_BUILD["simd_lanes"] = s["simd_lanes"]
    return read_exr(out), float(s["seconds"])


class MitsubaScene:
    """A scene converted and loaded for one Mitsuba variant and sampler, its LLVM kernel
    compiled by an untimed render; `render` times one more render."""

    def __init__(self, variant, scene, spp, sampler="independent", native=None):
        mi.set_variant(variant)
        # Mitsuba warns once per negative sample of measured data (RGL tables hold small
        # negative values); thousands of lines per render would drown the table.
        mi.set_log_level(mi.LogLevel.Error)
        import lobe.mitsuba
        from lobe.mitsuba.convert import Converter
        lobe.mitsuba.register()  # the plugin class of this variant
        self.variant, self.spp = variant, spp
        conv = Converter(scene)
        if native:
            # Materials of these lobe types become the given native Mitsuba BSDFs, so that
            # the peer samples with its own plugin (not lobe's Dr.Jit twin).
            own = conv.material
            conv.material = lambda m: (native[m["type"]] if isinstance(m, dict) and m.get("type") in native
                                       else own(m))
        d = conv.convert(spp, sampler)
        if not variant.startswith("llvm") and uses_python_plugin(d):
            # Under scalar_rgb Mitsuba calls a Python BSDF once per query: the timing
            # would measure the interpreter, and a 64 spp render takes hours.
            raise RuntimeError("the material runs as lobe's Python BSDF plugin, called once "
                               "per query under scalar_rgb; not timed")
        self.scene = mi.load_dict(d)
        if variant.startswith("llvm"):
            dr.eval(mi.render(self.scene, spp=spp, seed=99))  # compile the kernel (untimed)

    def render(self, seed):
        mi.set_variant(self.variant)
        t = time.perf_counter()
        img = mi.render(self.scene, spp=self.spp, seed=seed)
        dr.eval(img)
        arr = np.array(img, dtype=np.float64)[..., :3]
        # Reading the image waits for the (asynchronous) kernel: it is in the timed span.
        return arr, time.perf_counter() - t


def uses_python_plugin(d):
    """Whether a converted Mitsuba scene dict holds a `lobe` BSDF (lobe's Python plugin)."""
    if isinstance(d, dict):
        return d.get("type") == "lobe" or any(uses_python_plugin(v) for v in d.values())
    return False


def llvm_target(vector_width=None):
    """Dr.Jit's LLVM code generation target: (CPU name, vector width), or None when the
    library does not expose it. With `vector_width`, first sets it: below 16 also turns off
    the AVX-512 features, so that 8 makes Mitsuba AVX2-class code of the lane width of an
    AVX2 build of lobe; 16 is what Dr.Jit picks on an AVX-512 CPU. Must
    be called before a kernel is compiled (Dr.Jit's C++ API, `jit_llvm_set_target`)."""
    import ctypes
    try:
        lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
        cpu_of, features_of = lib._Z19jit_llvm_target_cpuv, lib._Z24jit_llvm_target_featuresv
        width_of, set_target = lib._Z21jit_llvm_vector_widthv, lib._Z19jit_llvm_set_targetPKcS0_j
    except (OSError, AttributeError):
        return None
    cpu_of.restype = features_of.restype = ctypes.c_char_p
    width_of.restype = ctypes.c_uint32
    if vector_width is not None:
        features = features_of().split(b",")
        if vector_width < 16:
            features = [f.replace(b"+avx512", b"-avx512") for f in features]
        set_target(cpu_of(), b",".join(features), ctypes.c_uint32(vector_width))
    return cpu_of().decode(), int(width_of())


def mse(a, b):
    return float(np.mean((a - b) ** 2))


def rmse_of(errors):
    """RMSE from the squared errors of several renders: their mean, then the root."""
    return float(np.sqrt(np.mean(errors)))


def suite_scenes(path):
    """(scene, Mitsuba peer or None) pairs of a suite manifest (scenes/bench/suite.json)."""
    with open(path) as f:
        m = json.load(f)
    base = os.path.dirname(os.path.abspath(path))
    out = []
    for e in m["scenes"]:
        peer = e.get("mitsuba_peer")
        out.append((os.path.normpath(os.path.join(base, e["scene"])),
                    os.path.normpath(os.path.join(base, peer)) if peer else None,
                    e.get("mitsuba_native")))
    return out


def rel_mse(img, ref):
    """Relative MSE, mean((img - ref)^2 / (ref^2 + 1e-2)): the brightness taken out, for a
    renderer compared with its own reference."""
    return float(np.mean((img - ref) ** 2 / (ref * ref + 1e-2)))


class Measure:
    """One scene's figures: lobe's paired times, each Mitsuba configuration's (time pairs,
    RMSE), all against a high-spp lobe reference."""

    def __init__(self, name, samples):
        self.name, self.samples = name, samples
        self.lobe_times, self.lobe_errors = [], []  # per lobe render: time, squared error
        self.rows = {}  # config -> (pairs [(t_lobe, t_mitsuba)], RMSE over its renders)
        self.peer = None  # name of the scene Mitsuba rendered instead, if any
        self.native = False  # Mitsuba's own plugins: errors are relative MSEs

    def ratios(self, config):
        """(Mitsuba time, speed of lobe over Mitsuba, equal-error time Mitsuba over lobe)."""
        pairs, e = self.rows[config]
        t = statistics.median(tm for _, tm in pairs)
        speed = statistics.median(tm / tl for tl, tm in pairs)
        return t, speed, speed * (e * e) / (self.lobe_rmse() ** 2)

    def lobe_rmse(self):
        return rmse_of(self.lobe_errors)


def measure(exe, scene, a, peer=None, native=None):
    """Renders `scene` with lobe and, in paired rounds, with Mitsuba (the scene itself, or
    `peer` when Mitsuba cannot load this one's material). With `native` (lobe material type
    -> Mitsuba BSDF dict), Mitsuba renders its own plugins, whose images differ from lobe's
    (another model): each renderer's error is then its relative MSE against its own
    reference at the reference spp."""
    name = os.path.splitext(os.path.basename(scene))[0]
    tmp = tempfile.mkdtemp(prefix="lobe-bench-")
    ref, _ = lobe_render(exe, scene, a.reference_spp, 1000, os.path.join(tmp, "ref.exr"))
    h, w = ref.shape[:2]
    m = Measure(name, w * h * a.spp)
    err = rel_mse if native else mse
    m.native = bool(native)
    mts = scene
    peer_ref = ref
    if peer is not None:
        m.peer = os.path.splitext(os.path.basename(peer))[0]
        mts = peer
        peer_ref, _ = lobe_render(exe, peer, a.reference_spp, 1000, os.path.join(tmp, "peer-ref.exr"))
    for smp in ("independent", "ldsampler"):
        try:
            ms = MitsubaScene("llvm_ad_rgb", mts, a.spp, smp, native)
            if native:
                refs = MitsubaScene("llvm_ad_rgb", mts, a.reference_spp, "independent", native)
                peer_ref, _ = refs.render(1000)
                del refs
        except Exception as e:  # noqa: BLE001 - a missing variant or plugin is reported, not fatal
            print(f"{name}: Mitsuba llvm_ad_rgb ({smp}) unavailable: {e}", file=sys.stderr)
            break
        pairs, errors = [], []
        for k in range(a.runs):
            lobe_img, tl = lobe_render(exe, scene, a.spp, k, os.path.join(tmp, f"lobe{k}.exr"))
            img, tm = ms.render(k)
            m.lobe_times.append(tl)
            m.lobe_errors.append(err(lobe_img, ref))
            pairs.append((tl, tm))
            errors.append(err(img, peer_ref))
        m.rows[f"llvm_ad_rgb ({smp})"] = (pairs, rmse_of(errors))
        del ms
        gc.collect()
    if not m.lobe_times:
        for k in range(a.runs):
            lobe_img, tl = lobe_render(exe, scene, a.spp, k, os.path.join(tmp, f"lobe{k}.exr"))
            m.lobe_times.append(tl)
            m.lobe_errors.append(err(lobe_img, ref))
    if a.scalar_runs > 0 and not native:
        try:
            ms = MitsubaScene("scalar_rgb", mts, a.spp)
            ts, errors = [], []
            for k in range(a.scalar_runs):
                img, t = ms.render(k)
                ts.append(t)
                errors.append(mse(img, peer_ref))
            tl = statistics.median(m.lobe_times)
            m.rows["scalar_rgb (independent)"] = ([(tl, t) for t in ts], rmse_of(errors))
        except Exception as e:  # noqa: BLE001
            print(f"{name}: Mitsuba scalar_rgb unavailable: {e}", file=sys.stderr)
    return m


CONFIGS = ("llvm_ad_rgb (independent)", "llvm_ad_rgb (ldsampler)", "scalar_rgb (independent)")


def detail_lines(m):
    lines = []
    tl = statistics.median(m.lobe_times)
    lines.append(f"| {m.name} | lobe | {tl:.3f} | {m.samples / tl / 1e6:.2f} | {m.lobe_rmse():.4e} | 1 | 1 |")
    for c in CONFIGS:
        if c in m.rows:
            t, speed, eq = m.ratios(c)
            who = f"Mitsuba {c}" + (f" on {m.peer}" if m.peer else "") + (" (native BSDF)" if m.native else "")
            lines.append(f"| {m.name} | {who} | {t:.3f} | {m.samples / t / 1e6:.2f} | "
                         f"{m.rows[c][1]:.4e} | {speed:.2f} | {eq:.2f} |")
    return lines


def summary_line(m):
    tl = statistics.median(m.lobe_times)
    cells = []
    for c in CONFIGS:
        if c in m.rows:
            _, speed, eq = m.ratios(c)
            cells.append(f"{speed:.2f} / {eq:.2f}")
        else:
            cells.append("n/a")
    name = m.name + (f" (Mitsuba: {m.peer})" if m.peer else "") + (
        " (Mitsuba's native BSDF; relative MSE, each against its own reference)" if m.native else "")
    return f"| {name} | {m.samples / tl / 1e6:.2f} | " + " | ".join(cells) + " |"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--suite", nargs="?", const=os.path.join(root, "scenes", "bench", "suite.json"),
                    help="run the scenes of a suite manifest (default scenes/bench/suite.json)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--reference-spp", type=int, default=2048)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--scalar-runs", type=int, default=None,
                    help="scalar_rgb renders per scene (default min(runs, 3); 0 skips scalar_rgb)")
    ap.add_argument("--mitsuba-vector-width", type=int, choices=(4, 8, 16), default=None,
                    help="Dr.Jit LLVM lanes (default: Dr.Jit's choice for this CPU, 16 with "
                         "AVX-512); below 16 without AVX-512 instructions: a diagnostic of "
                         "how much of Mitsuba's speed is its vector width")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    if a.scalar_runs is None:
        a.scalar_runs = min(a.runs, 3)
    exe = lobe_bin()
    if a.suite:
        subprocess.run([sys.executable, os.path.join(here, "bench_assets.py"), "--lobe", exe], check=True)
        scenes = suite_scenes(a.suite)
    else:
        scenes = [(s, None, None) for s in (a.scenes or [os.path.join(root, "scenes", "sphere-envmap.json"),
                                                    os.path.join(root, "scenes", "spheres-envmap.json")])]
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        mi.set_variant("llvm_ad_rgb")
        target = llvm_target(a.mitsuba_vector_width)
    except Exception:  # noqa: BLE001 - no LLVM: the llvm rows report it per scene
        target = None
    if target is None and a.mitsuba_vector_width is not None:
        sys.exit("bench.py: --mitsuba-vector-width: this Dr.Jit does not expose jit_llvm_set_target")
    target_text = f"Dr.Jit LLVM target {target[0]}, {target[1]} lanes" if target else "Dr.Jit LLVM target unknown"
    results = []
    for scene, peer, native in scenes:
        results.append(measure(exe, scene, a, peer, native))
        print("\n".join(detail_lines(results[-1])), file=sys.stderr)
    lines = [f"Machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
             f"lobe {LOBE_BUILD.get('simd_lanes', 'unknown')} SIMD lanes; "
             f"Mitsuba {mi.__version__} ({target_text}); {a.spp} spp, medians of {a.runs} rounds (lobe and each "
             f"llvm_ad_rgb configuration alternating, ratios paired per round; scalar_rgb: "
             f"{a.scalar_runs} renders against lobe's median), RMSE (over every render of the rounds) against lobe at "
             f"{a.reference_spp} spp with another seed; {time.strftime('%Y-%m-%d')}.", "",
             "Per scene: lobe's Msamples/s, then for each Mitsuba configuration `speed / "
             "equal-error`: lobe's speed over Mitsuba's (above 1: lobe is faster) and the "
             "time Mitsuba needs to reach lobe's error, over lobe's (above 1: lobe is faster).", "",
             "| scene | lobe Msamples/s | llvm_ad_rgb independent | llvm_ad_rgb ldsampler | scalar_rgb |",
             "|---|---|---|---|---|"]
    lines += [summary_line(m) for m in results]
    lines += ["", "| scene | renderer | seconds | Msamples/s | RMSE | lobe speed over it | its equal-error time over lobe's |",
              "|---|---|---|---|---|---|---|"]
    for m in results:
        lines += detail_lines(m)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        with open(a.out + ".tmp", "w") as f:
            f.write(text)
        os.replace(a.out + ".tmp", a.out)


if __name__ == "__main__":
    main()
