"""Shared fixtures of the lobe package's tests: the repository, the `lobe` binary the
package is compared with (target/release/lobe, built by scripts/test.sh's cargo test, or
$LOBE_BIN), the shared data folder, and one description per model."""

import os
import subprocess

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))

# One description of every model the registry builds from parameters alone, with
# non-default values (measured materials, fits and Ngan fits need files: see test_material).
MODELS = {
    "lambert": {"type": "lambert", "reflectance": [0.6, 0.4, 0.2]},
    "ward": {"type": "ward", "diffuse": [0.2, 0.1, 0.05], "specular": 0.1, "alpha": 0.2},
    "ward-duer": {"type": "ward-duer", "specular": [0.1, 0.2, 0.3], "alpha": 0.12},
    "ward-anisotropic": {"type": "ward-anisotropic", "specular": 0.2, "alpha_x": 0.08, "alpha_y": 0.3},
    "blinn-phong": {"type": "blinn-phong", "diffuse": 0.3, "specular": 0.2, "n": 80},
    "cook-torrance": {"type": "cook-torrance", "specular": 0.5, "m": 0.25, "f0": 0.1},
    "lafortune": {"type": "lafortune", "specular": 0.3, "cx": -0.6, "cy": -0.6, "cz": 0.5, "n": 20},
    "ashikhmin-shirley": {"type": "ashikhmin-shirley", "diffuse": 0.1, "specular": 0.4, "n": 60, "f0": 0.2},
    "ashikhmin-shirley-anisotropic": {"type": "ashikhmin-shirley-anisotropic", "specular": 0.4, "nu": 20, "nv": 300},
    "he": {"type": "he", "specular": 0.5, "sigma0": 0.3, "tau": 4.0, "eta": 1.6},
    "poulin-fournier": {"type": "poulin-fournier", "specular": 0.3, "n": 40, "d": 0.4, "h": 0.3},
    "sampled-microfacet": {"type": "sampled-microfacet", "distribution": "satin", "specular": 0.5},
    "composite": {"type": "composite", "diffuse": 0.2, "lobes": [{"type": "ward", "alpha": 0.1, "specular": 0.1}, {"type": "blinn-phong", "n": 20, "specular": 0.1}]},
}


@pytest.fixture(scope="session")
def lobe_bin():
    path = os.environ.get("LOBE_BIN", os.path.join(ROOT, "target", "release", "lobe"))
    if not os.access(path, os.X_OK):
        pytest.fail(f"{path}: the lobe binary is missing; build it (cargo build --release) or set LOBE_BIN")
    return path


REQUIRE_DATA = os.environ.get("LOBE_REQUIRE_DATA") == "1"


def record_skip(what):
    """Records a check that could not run (listed in target/skipped-checks.log, which
    scripts/test.sh summarises). A check skipped for want of ../shared/data fails instead
    when LOBE_REQUIRE_DATA=1 (CI, which has the data)."""
    if REQUIRE_DATA and "shared data" in what:
        pytest.fail(f"LOBE_REQUIRE_DATA=1 but {what}")
    log = os.path.join(ROOT, "target", "skipped-checks.log")
    os.makedirs(os.path.dirname(log), exist_ok=True)
    with open(log, "a") as f:
        f.write(f"(python) {what}\n")


@pytest.fixture(scope="session")
def data_dir():
    d = os.environ.get("LOBE_DATA", os.path.join(ROOT, "..", "shared", "data"))
    if os.path.isdir(d):
        return d
    if REQUIRE_DATA:
        pytest.fail(f"LOBE_REQUIRE_DATA=1 but the shared data folder {d} is absent")
    return None


def sphere_scene(material, width, height=None):
    """A unit sphere of ``material`` seen from 4 units away under a constant sky and a
    directional light, on a ``width`` x ``height`` film (square by default)."""
    return {
        "camera": {"type": "perspective", "fov": 32, "origin": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0]},
        "film": {"width": width, "height": height or width},
        "sampler": {"spp": 16},
        "integrator": {"type": "path", "max_depth": 3},
        "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": material}],
        "lights": [
            {"type": "constant", "radiance": [0.6, 0.7, 0.8]},
            {"type": "directional", "direction": [-0.5, -0.4, -1.0], "irradiance": [3.0, 2.8, 2.5]},
        ],
    }


def run(args, **kw):
    """Runs the lobe binary, returning stdout; a failure shows its stderr."""
    p = subprocess.run(args, capture_output=True, text=True, **kw)
    assert p.returncode == 0, f"{' '.join(args)}: {p.stderr}"
    return p.stdout
