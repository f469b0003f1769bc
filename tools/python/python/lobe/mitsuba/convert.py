"""Converts a lobe scene JSON file (docs/scene-format.md) into a Mitsuba 3 scene
dictionary. Written from the documented format with Mitsuba's own constructs (look_at,
sphere, rectangle, obj/ply, envmap, constant, point, directional, area, path, direct), so
that conventions are checked, not copied, when the two renderers are compared."""

import atexit
import json
import math
import os
import shutil
import tempfile

import mitsuba as mi
import numpy as np

from . import meshes, ngan


class SceneError(Exception):
    pass


def _op(op):
    T = mi.ScalarTransform4f()
    if "translate" in op:
        return T.translate(op["translate"])
    if "scale" in op:
        s = op["scale"]
        return T.scale([s, s, s] if isinstance(s, (int, float)) else s)
    if "rotate" in op:
        return T.rotate(op["rotate"]["axis"], op["rotate"]["angle"])
    if "matrix" in op:
        return mi.ScalarTransform4f(np.array(op["matrix"], dtype=np.float64).reshape(4, 4))
    if "look_at" in op:
        la = op["look_at"]
        return T.look_at(origin=la["origin"], target=la["target"], up=la["up"])
    raise SceneError(f"unknown transform operation {op}")


def transform(v):
    """Mitsuba's semantics: operations applied in order, each later one on the left."""
    ops = v if isinstance(v, list) else [v]
    M = mi.ScalarTransform4f()
    for op in ops:
        M = _op(op) @ M
    return M


def _rgb(v, default):
    if v is None:
        v = default
    if isinstance(v, (int, float)):
        v = [v, v, v]
    return {"type": "rgb", "value": [float(x) for x in v]}


class Converter:
    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.base = os.path.dirname(self.path)
        with open(self.path) as f:
            self.scene = json.load(f)
        self._tmp = None
        self.gltf_camera = None

    @property
    def tmp(self):
        """The folder of the PLY meshes this conversion writes: made on the first mesh,
        removed when the interpreter exits (Mitsuba reads the files when the scene loads,
        after `convert` returns)."""
        if self._tmp is None:
            self._tmp = tempfile.mkdtemp(prefix="lobe-mitsuba-")
            atexit.register(shutil.rmtree, self._tmp, ignore_errors=True)
        return self._tmp

    def resolve(self, p):
        return p if os.path.isabs(p) else os.path.join(self.base, p)

    def material(self, m):
        if m is None:
            return {"type": "diffuse", "reflectance": _rgb(0.5, 0.5)}
        if isinstance(m, str):
            return self.material(self.scene["materials"][m])
        t = m["type"]
        if t == "lambert":
            return {"type": "diffuse", "reflectance": _rgb(m.get("reflectance"), 0.5)}
        if t == "ngan-fit":
            folder = ngan.locate(m.get("fits", ""), self.base)
            d = ngan.description(m["material"], m.get("model", "cook-torrance"), folder, m.get("channel_scale", "merl"))
            return {"type": "lobe", "desc": json.dumps(d)}
        if t == "fit":  # the report's path resolves against the scene file's folder
            return {"type": "lobe", "model": m["model"], "report": self.resolve(m["file"])}
        if t == "rgl":
            return {"type": "measured", "filename": self.resolve(m["file"])}
        if t in ("composite", "merl", "binned"):
            raise SceneError(f"{t} materials have no Mitsuba counterpart in this converter")
        return {"type": "lobe", "desc": json.dumps(m)}

    def mesh_shape(self, s):
        kind = s["type"]
        path = self.resolve(s["file"])
        if kind == "obj":
            pos, normals, tris = meshes.read_obj(path)
        else:
            pos, normals, tris, cam = meshes.read_gltf(path)
            if self.gltf_camera is None:
                self.gltf_camera = cam
        if "to_world" in s:
            M = np.array(transform(s["to_world"]).matrix, dtype=np.float64)
            pos = (M[:3, :3] @ pos.T).T + M[:3, 3]
            if normals is not None:
                N = np.linalg.inv(M[:3, :3]).T
                normals = (N @ normals.T).T
                normals /= np.linalg.norm(normals, axis=1, keepdims=True)
            if np.linalg.det(M[:3, :3]) < 0:
                tris = tris[:, [0, 2, 1]]
        if normals is None or np.any(np.linalg.norm(normals, axis=1) == 0):
            normals = meshes.angle_weighted_normals(pos, tris)
        out = os.path.join(self.tmp, f"mesh{len(os.listdir(self.tmp))}.ply")
        meshes.write_ply(out, pos, normals, tris)
        return {"type": "ply", "filename": out, "face_normals": bool(s.get("face_normals", False))}

    def shape(self, s):
        t = s["type"]
        if t == "sphere":
            d = {"type": "sphere", "center": s.get("center", [0, 0, 0]), "radius": s.get("radius", 1.0)}
        elif t == "rectangle":
            d = {"type": "rectangle", "to_world": transform(s.get("to_world", []))}
        elif t in ("obj", "gltf"):
            d = self.mesh_shape(s)
        else:
            raise SceneError(f"unknown shape type {t}")
        d["flip_normals"] = bool(s.get("flip_normals", False))
        d["bsdf"] = self.material(s.get("material"))
        if "emitter" in s:
            d["emitter"] = {"type": "area", "radiance": _rgb(s["emitter"].get("radiance"), 1.0)}
        return d

    def light(self, l):
        t = l["type"]
        if t == "envmap":
            f = l["file"]
            if f.startswith("builtin:"):
                raise SceneError("built-in environment maps have no file Mitsuba could read")
            d = {"type": "envmap", "filename": self.resolve(f), "scale": float(l.get("scale", 1.0))}
            if l.get("mis_compensation"):
                d["mis_compensation"] = True
            if "to_world" in l:
                d["to_world"] = transform(l["to_world"])
            return d
        if t == "constant":
            return {"type": "constant", "radiance": _rgb(l.get("radiance"), 1.0)}
        if t == "point":
            return {"type": "point", "position": l["position"], "intensity": _rgb(l["intensity"], 1.0)}
        if t == "directional":
            return {"type": "directional", "direction": l["direction"], "irradiance": _rgb(l["irradiance"], 1.0)}
        raise SceneError(f"unknown light type {t}")

    def camera(self, film, sampler):
        c = self.scene.get("camera")
        if c is None:
            if self.gltf_camera is None:
                raise SceneError("no camera")
            world, yfov = self.gltf_camera
            o = world[:3, 3]
            fwd = world[:3, :3] @ np.array([0, 0, -1.0])
            up = world[:3, :3] @ np.array([0, 1.0, 0])
            return {"type": "perspective", "fov": math.degrees(yfov), "fov_axis": "y", "near_clip": 0.01,
                    "to_world": mi.ScalarTransform4f().look_at(origin=o.tolist(), target=(o + fwd).tolist(), up=up.tolist()),
                    "film": film, "sampler": sampler}
        if "to_world" in c:
            M = transform(c["to_world"])
        else:
            M = mi.ScalarTransform4f().look_at(origin=c.get("origin", [0, 0, 0]), target=c.get("target", [0, 0, 1]), up=c.get("up", [0, 1, 0]))
        if c["type"] == "perspective":
            return {"type": "perspective", "fov": float(c.get("fov", 39.3077)), "fov_axis": c.get("fov_axis", "x"),
                    "near_clip": float(c.get("near_clip", 0.01)), "to_world": M, "film": film, "sampler": sampler}
        s = float(c.get("scale", 1.0))
        # Mitsuba requires near_clip > 0; lobe's orthographic default is 0.01 like Mitsuba's.
        return {"type": "orthographic", "near_clip": max(float(c.get("near_clip", 0.01)), 1e-6),
                "to_world": M @ mi.ScalarTransform4f().scale([s, s, 1.0]), "film": film, "sampler": sampler}

    def integrator(self):
        i = self.scene.get("integrator", {"type": "path"})
        if i["type"] == "path":
            return {"type": "path", "max_depth": int(i.get("max_depth", -1)), "rr_depth": int(i.get("rr_depth", 5))}
        return {"type": "direct", "emitter_samples": int(i.get("emitter_samples", 1)), "bsdf_samples": int(i.get("bsdf_samples", 1))}

    def convert(self, spp=None, sampler_type="independent"):
        """The Mitsuba scene dict; `sampler_type` is a Mitsuba sampler plugin name."""
        s = self.scene
        film_d = s.get("film", {})
        film = {"type": "hdrfilm", "width": int(film_d.get("width", 256)), "height": int(film_d.get("height", 256)),
                "rfilter": {"type": "box"}, "pixel_format": "rgb", "component_format": "float32"}
        spp = spp or int(s.get("sampler", {}).get("spp", 16))
        sampler = {"type": sampler_type, "sample_count": spp}
        d = {"type": "scene", "integrator": self.integrator()}
        for k, sh in enumerate(s.get("shapes", [])):
            d[f"shape{k}"] = self.shape(sh)
        for k, l in enumerate(s.get("lights", [])):
            d[f"light{k}"] = self.light(l)
        d["sensor"] = self.camera(film, sampler)
        return d
