"""Triangle meshes for the Mitsuba conversion: Wavefront OBJ and glTF 2.0 read with numpy,
smooth vertex normals weighted by corner angle when a file has none (the rule lobe
documents in docs/scene-format.md), written as binary PLY for Mitsuba's `ply` shape."""

import json
import os
import struct

import numpy as np


def read_obj(path):
    """Positions (n, 3), normals (n, 3) or None, triangles (m, 3) of an OBJ (all groups,
    polygons fanned into triangles, one index per position/normal pair)."""
    vs, vns, keys, tris = [], [], {}, []
    pos, nrm = [], []
    has_normals = True
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                vs.append([float(x) for x in p[1:4]])
            elif p[0] == "vn":
                vns.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = []
                for tok in p[1:]:
                    parts = tok.split("/")
                    vi = int(parts[0])
                    vi = vi - 1 if vi > 0 else len(vs) + vi
                    ni = None
                    if len(parts) >= 3 and parts[2]:
                        ni = int(parts[2])
                        ni = ni - 1 if ni > 0 else len(vns) + ni
                    key = (vi, ni)
                    if key not in keys:
                        keys[key] = len(pos)
                        pos.append(vs[vi])
                        if ni is None:
                            has_normals = False
                            nrm.append([0.0, 0.0, 0.0])
                        else:
                            nrm.append(vns[ni])
                    idx.append(keys[key])
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    pos = np.array(pos, dtype=np.float64)
    normals = np.array(nrm, dtype=np.float64) if has_normals and nrm else None
    return pos, normals, np.array(tris, dtype=np.int64)


_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    t = np.array(node.get("translation", [0, 0, 0]), dtype=np.float64)
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = np.array(node.get("scale", [1, 1, 1]), dtype=np.float64)
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


def read_gltf(path):
    """World-space triangles of the default scene of a .gltf (with external or data-URI
    buffers) and its first camera (depth-first), as (positions, normals or None, triangles,
    camera) with camera = (world matrix, yfov radians) or None."""
    with open(path) as f:
        doc = json.load(f)
    base = os.path.dirname(path)
    buffers = []
    for b in doc.get("buffers", []):
        uri = b["uri"]
        if uri.startswith("data:"):
            import base64
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(base, uri), "rb") as bf:
                buffers.append(bf.read())

    def accessor(i):
        a = doc["accessors"][i]
        v = doc["bufferViews"][a["bufferView"]]
        dt = np.dtype(_COMPONENTS[a["componentType"]])
        n = _SIZES[a["type"]]
        start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
        stride = v.get("byteStride", 0) or dt.itemsize * n
        raw = buffers[v["buffer"]]
        out = np.empty((a["count"], n), dtype=dt)
        for k in range(a["count"]):
            out[k] = np.frombuffer(raw, dtype=dt, count=n, offset=start + k * stride)
        return out

    scene = doc["scenes"][doc.get("scene", 0)]
    pos_all, nrm_all, tri_all = [], [], []
    all_normals = True
    camera = None
    stack = [(n, np.eye(4)) for n in reversed(scene["nodes"])]
    while stack:
        ni, parent = stack.pop()
        node = doc["nodes"][ni]
        world = parent @ _node_matrix(node)
        if "camera" in node and camera is None:
            cam = doc["cameras"][node["camera"]]
            if cam["type"] == "perspective":
                camera = (world, cam["perspective"]["yfov"])
        if "mesh" in node:
            nm = np.linalg.inv(world).T
            mirror = np.linalg.det(world[:3, :3]) < 0
            for prim in doc["meshes"][node["mesh"]]["primitives"]:
                if prim.get("mode", 4) != 4:
                    continue
                p = accessor(prim["attributes"]["POSITION"]).astype(np.float64)
                p = (world[:3, :3] @ p.T).T + world[:3, 3]
                base_idx = sum(len(x) for x in pos_all)
                if "NORMAL" in prim["attributes"]:
                    n = accessor(prim["attributes"]["NORMAL"]).astype(np.float64)
                    n = (nm[:3, :3] @ n.T).T
                    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
                    nrm_all.append(n)
                else:
                    all_normals = False
                    nrm_all.append(np.zeros_like(p))
                if "indices" in prim:
                    t = accessor(prim["indices"]).reshape(-1, 3).astype(np.int64)
                else:
                    t = np.arange(len(p)).reshape(-1, 3)
                if mirror:
                    t = t[:, [0, 2, 1]]
                pos_all.append(p)
                tri_all.append(t + base_idx)
        for c in reversed(node.get("children", [])):
            stack.append((c, world))
    if not pos_all:
        return None, None, None, camera
    normals = np.concatenate(nrm_all) if all_normals else None
    return np.concatenate(pos_all), normals, np.concatenate(tri_all), camera


def angle_weighted_normals(pos, tris):
    """Vertex normals: face normals weighted by each corner's angle, normalized."""
    acc = np.zeros_like(pos)
    p = pos[tris]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(fn, axis=1)
    ok = ln > 0
    fn[ok] /= ln[ok, None]
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        a /= np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)
        b /= np.maximum(np.linalg.norm(b, axis=1, keepdims=True), 1e-300)
        ang = np.arccos(np.clip(np.sum(a * b, axis=1), -1, 1))
        np.add.at(acc, tris[ok, k], fn[ok] * ang[ok, None])
    n = np.linalg.norm(acc, axis=1, keepdims=True)
    return acc / np.maximum(n, 1e-300)


def write_ply(path, pos, normals, tris):
    """Binary little-endian PLY with float positions and normals, int triangle indices."""
    with open(path, "wb") as f:
        header = (
            "ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(pos)}\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n"
        )
        f.write(header.encode("ascii"))
        v = np.concatenate([pos, normals], axis=1).astype("<f4")
        f.write(v.tobytes())
        faces = np.empty(len(tris), dtype=[("n", "u1"), ("i", "<i4", 3)])
        faces["n"] = 3
        faces["i"] = tris
        f.write(faces.tobytes())
