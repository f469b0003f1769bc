#!/usr/bin/env python3
"""Inputs of the benchmark suite (scenes/bench/) that are generated, not committed.

    python3 tools/mitsuba/bench_assets.py [--out out/bench] [--lobe target/release/lobe]

- `displaced-sphere.gltf` (+ `.bin`): a unit sphere displaced by a sum of sinusoids,
  1,046,528 triangles (512 rings of 1024 segments; no normals in the file, so lobe and the
  Mitsuba conversion both compute angle-weighted vertex normals). The users' "large scanned
  mesh" workload: a BVH of a million small, irregularly oriented triangles traversed by
  incoherent rays.
- `cc_ibiza_sunset.binary` (MERL) and `cc_ibiza_sunset.lobebin` (the study's binned 4D data, isotropic 1-degree bins):
  the RGL `cc_ibiza_sunset` measurement tabulated by `lobe tabulate`, so the measured-table
  workloads render real reflectance.

Each file is written to a temporary name and renamed; existing files are kept (delete
them to regenerate). Needs numpy (the tools/mitsuba venv has it).
"""

import argparse
import json
import os
import subprocess
import sys

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", ".."))

RINGS = 512  # latitude rings, poles included
SEGMENTS = 1024  # longitude segments


def displaced_sphere(rings=RINGS, segments=SEGMENTS):
    """Positions (n, 3) float32 and triangles (m, 3) uint32 of the displaced sphere."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]  # interior rings
    phi = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    r = (1.0 + 0.04 * np.sin(7 * t) * np.cos(9 * p) + 0.02 * np.sin(23 * t + 1.0) * np.sin(17 * p)
         + 0.008 * np.sin(61 * t) * np.cos(47 * p + 2.0))
    ring = np.stack([r * np.sin(t) * np.cos(p), r * np.cos(t), r * np.sin(t) * np.sin(p)], axis=-1)
    pos = np.concatenate([[[0.0, 1.0, 0.0]], ring.reshape(-1, 3), [[0.0, -1.0, 0.0]]]).astype(np.float32)
    n_int = rings - 1
    south = 1 + n_int * segments

    def vid(i, j):
        return 1 + i * segments + (j % segments)

    j = np.arange(segments)
    tris = [np.stack([np.zeros(segments, dtype=np.int64), vid(0, j + 1), vid(0, j)], axis=1)]
    for i in range(n_int - 1):
        a, b, c, d = vid(i, j), vid(i, j + 1), vid(i + 1, j), vid(i + 1, j + 1)
        tris.append(np.stack([a, b, d], axis=1))
        tris.append(np.stack([a, d, c], axis=1))
    tris.append(np.stack([vid(n_int - 1, j), vid(n_int - 1, j + 1), np.full(segments, south)], axis=1))
    return pos, np.concatenate(tris).astype(np.uint32)


def write_gltf(path, pos, tris):
    """A glTF 2.0 file of one indexed triangle primitive (positions and uint32 indices)."""
    stem = os.path.splitext(os.path.basename(path))[0]
    binary = pos.tobytes() + tris.tobytes()
    doc = {
        "asset": {"version": "2.0", "generator": "lobe tools/mitsuba/bench_assets.py"},
        "buffers": [{"uri": stem + ".bin", "byteLength": len(binary)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos.nbytes, "target": 34962},
            {"buffer": 0, "byteOffset": pos.nbytes, "byteLength": tris.nbytes, "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3",
             "min": pos.min(axis=0).tolist(), "max": pos.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": tris.size, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    folder = os.path.dirname(path)
    bin_path = os.path.join(folder, stem + ".bin")
    with open(bin_path + ".tmp", "wb") as f:
        f.write(binary)
    os.replace(bin_path + ".tmp", bin_path)
    with open(path + ".tmp", "w") as f:
        json.dump(doc, f)
    os.replace(path + ".tmp", path)


def tabulate(lobe, material, fmt, out):
    subprocess.run([lobe, "tabulate", "--material", json.dumps(material), "--format", fmt, "-o", out],
                   check=True, stdout=subprocess.DEVNULL)


def make(out, lobe):
    os.makedirs(out, exist_ok=True)
    mesh = os.path.join(out, "displaced-sphere.gltf")
    if not os.path.exists(mesh):
        pos, tris = displaced_sphere()
        write_gltf(mesh, pos, tris)
        print(f"wrote {mesh} ({len(tris)} triangles)", file=sys.stderr)
    rgl = os.path.join(root, "..", "shared", "data", "rgl", "cc_ibiza_sunset_rgb.bsdf")
    rgl = os.path.join(os.environ["LOBE_DATA"], "rgl", "cc_ibiza_sunset_rgb.bsdf") if "LOBE_DATA" in os.environ else rgl
    for ext, fmt in (("binary", "merl"), ("lobebin", "binned")):
        table = os.path.join(out, f"cc_ibiza_sunset.{ext}")
        if not os.path.exists(table):
            if not os.path.exists(rgl):
                print(f"bench_assets: {rgl} not found; the MERL and binned scenes will fail", file=sys.stderr)
                continue
            tabulate(lobe, {"type": "rgl", "file": os.path.abspath(rgl)}, fmt, table)
            print(f"wrote {table}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(root, "out", "bench"))
    ap.add_argument("--lobe", default=os.path.join(root, "target", "release", "lobe"))
    a = ap.parse_args()
    make(a.out, a.lobe)


if __name__ == "__main__":
    main()
