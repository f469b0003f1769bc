//! Scene files: JSON descriptions (docs/scene-format.md) loaded into a [`Scene`].
//!
//! Loading validates every value (unknown keys, wrong types and out-of-range values are
//! errors naming the file, the JSON path and what was expected), resolves relative paths
//! against the scene file's folder, asks the materials registry for each material (named
//! materials are built once, only if a shape uses them, and shared), reads meshes and
//! environment maps, and builds one BVH over all primitives.

pub mod gltf_check;
pub mod inputs;
pub mod json;
pub mod mesh_io;
pub mod transform;

use crate::camera::{Camera, FovAxis, fov_x_degrees, look_at};
use crate::error::{Error, Result};
use crate::geometry::bvh::{PrimKind, Primitive, ShapeGeom};
use crate::geometry::{Geometry, Mesh, Rectangle, Sphere, Triangle};
use crate::integrators::Integrator;
use crate::lights::envmap::{EnvMap, RgbImage, load_rgb_image};
use crate::lights::{AreaShape, Light};
use crate::sampler::Scramble;
use glam::{Mat3, Mat4, Vec3};
use json::{Obj, describe};
use lobe_materials::Bsdf;
use lobe_materials::registry::{BuildContext, Registry};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A shape's material and, if it emits, its light.
#[derive(Clone, Debug)]
pub struct ShapeInfo {
    pub material: Arc<dyn Bsdf>,
    /// Index into [`Scene::lights`] of this shape's area light.
    pub light: Option<u32>,
}

/// A loaded scene, ready to render.
pub struct Scene {
    /// The scene file (for messages and the statistics sidecar).
    pub file: String,
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    /// How the sampler randomizes its points (`sampler.scramble`).
    pub scramble: Scramble,
    /// Exposure (stops) for the PNG output.
    pub exposure: f32,
    pub integrator: Integrator,
    pub geometry: Geometry,
    pub shapes: Vec<ShapeInfo>,
    pub lights: Vec<Light>,
    /// Indices of environment-like lights (env maps, constant), evaluated on escape.
    pub infinite_lights: Vec<u32>,
}

/// A procedural image, made only when a scene refers to it.
pub type ImageMaker = fn() -> RgbImage;

/// Options of scene loading.
#[derive(Default)]
pub struct LoadOptions {
    /// Built-in images that `"file": "builtin:<name>"` refers to.
    pub builtin_images: BTreeMap<String, ImageMaker>,
    /// The models materials are built with (a caller may register its own).
    pub registry: Arc<Registry>,
}

impl LoadOptions {
    /// The built-in procedural images (`builtin:studio`).
    pub fn with_builtins() -> Self {
        let mut b: BTreeMap<String, ImageMaker> = BTreeMap::new();
        b.insert("studio".to_string(), || {
            crate::showcase::studio_environment(512, 256)
        });
        Self {
            builtin_images: b,
            registry: Arc::new(Registry::builtin()),
        }
    }
}

/// Loads a scene file.
pub fn load(path: &Path) -> Result<Scene> {
    load_with(path, &LoadOptions::with_builtins())
}

/// Loads a scene file with the caller's options (its registry, its built-in images).
pub fn load_with(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let value = read_json(path)?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    from_value(&value, &path.display().to_string(), &base, opts)
}

/// Reads a scene file's JSON (strictly: duplicate keys, such as two materials of one name,
/// and non-finite numbers are errors naming the file, line and column).
pub fn read_json(path: &Path) -> Result<Value> {
    if !path.exists() {
        return Err(Error::file(
            path.display(),
            "cannot read: the file does not exist; expected a scene JSON file",
        ));
    }
    Ok(lobe_materials::json::read(path)?)
}

const TOP_KEYS: &[&str] = &[
    "camera",
    "film",
    "sampler",
    "integrator",
    "materials",
    "shapes",
    "lights",
];

struct Loader<'a> {
    file: &'a str,
    base: &'a Path,
    opts: &'a LoadOptions,
    registry: &'a Registry,
    named: BTreeMap<String, &'a Value>,
    built: BTreeMap<String, Arc<dyn Bsdf>>,
    /// Shared by every material of the scene: measured tables are loaded once.
    ctx: BuildContext<'a>,
}

impl<'a> Loader<'a> {
    fn resolve(&self, p: &str) -> PathBuf {
        let pb = PathBuf::from(p);
        if pb.is_absolute() {
            pb
        } else {
            self.base.join(pb)
        }
    }

    fn material(&mut self, v: Option<&'a Value>, path: &str) -> Result<Arc<dyn Bsdf>> {
        let ctx = self.ctx.clone();
        match v {
            // Mitsuba's default material: diffuse, reflectance 0.5.
            None => Ok(Arc::new(lobe_materials::analytic::lambert::Lambert::new(
                lobe_materials::Rgb::splat(0.5),
            ))),
            Some(Value::String(name)) => {
                if let Some(m) = self.built.get(name) {
                    return Ok(m.clone());
                }
                let desc = *self.named.get(name).ok_or_else(|| {
                    Error::scene(
                        self.file,
                        path,
                        format!(
                            "unknown material \"{name}\"; expected one of the names under \"materials\": {}",
                            if self.named.is_empty() { "(none defined)".to_string() } else { self.named.keys().cloned().collect::<Vec<_>>().join(", ") }
                        ),
                    )
                })?;
                let m = self
                    .registry
                    .create_with(desc, &format!("materials.{name}"), &ctx)
                    .map_err(|e| Error::scene(self.file, e.path, e.message))?;
                self.built.insert(name.clone(), m.clone());
                Ok(m)
            }
            Some(desc @ Value::Object(_)) => self
                .registry
                .create_with(desc, path, &ctx)
                .map_err(|e| Error::scene(self.file, e.path, e.message)),
            Some(other) => Err(Error::scene(
                self.file,
                path,
                format!(
                    "expected a material name or a material object, found {}",
                    describe(other)
                ),
            )),
        }
    }

    fn image(&self, o: &Obj, key: &str) -> Result<RgbImage> {
        let f = o.str_req(key, "an image file path (.exr or .hdr)")?;
        if let Some(name) = f.strip_prefix("builtin:") {
            return self
                .opts
                .builtin_images
                .get(name)
                .map(|make| make())
                .ok_or_else(|| {
                    o.err(
                        key,
                        format!(
                            "unknown built-in image \"{name}\"; expected one of: {}",
                            self.opts
                                .builtin_images
                                .keys()
                                .cloned()
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                });
        }
        let path = self.resolve(f);
        if !path.exists() {
            return Err(o.err(key, format!("file {} does not exist", path.display())));
        }
        load_rgb_image(&path)
    }
}

fn positive(x: f64) -> bool {
    x > 0.0
}
fn non_negative(x: f64) -> bool {
    x >= 0.0
}

/// Builds a scene from a parsed JSON description. `file` names it in errors; relative
/// paths resolve against `base`.
pub fn from_value(v: &Value, file: &str, base: &Path, opts: &LoadOptions) -> Result<Scene> {
    let top = Obj::new(file, "", v, TOP_KEYS)?;
    let mut ld = Loader {
        file,
        base,
        opts,
        registry: &opts.registry,
        named: BTreeMap::new(),
        built: BTreeMap::new(),
        ctx: BuildContext::new(base, &opts.registry),
    };

    // Film and sampler.
    let (width, height, exposure) = match top.get("film") {
        None => (256, 256, 0.0),
        Some(fv) => {
            let f = Obj::new(file, "film", fv, &["width", "height", "exposure"])?;
            (
                f.int_opt("width", 1, 16384)?.unwrap_or(256) as u32,
                f.int_opt("height", 1, 16384)?.unwrap_or(256) as u32,
                f.f32_or("exposure", 0.0, "a number of stops", |x| x.abs() <= 64.0)?,
            )
        }
    };
    let (spp, seed, scramble) = match top.get("sampler") {
        None => (16, 0, Scramble::default()),
        Some(sv) => {
            let s = Obj::new(file, "sampler", sv, &["spp", "seed", "scramble"])?;
            let scramble = s
                .name_opt("scramble", &Scramble::NAMES, Scramble::parse)?
                .unwrap_or_default();
            (
                s.int_opt("spp", 1, 1 << 24)?.unwrap_or(16) as u32,
                s.int_opt("seed", 0, i64::MAX)?.unwrap_or(0) as u64,
                scramble,
            )
        }
    };
    let integrator = parse_integrator(file, top.get("integrator"))?;

    // Materials: validated now, built when a shape uses them.
    if let Some(mv) = top.get("materials") {
        let m = mv.as_object().ok_or_else(|| {
            Error::scene(
                file,
                "materials",
                format!(
                    "expected an object of named materials, found {}",
                    describe(mv)
                ),
            )
        })?;
        for (name, desc) in m {
            ld.registry
                .check(desc, &format!("materials.{name}"))
                .map_err(|e| Error::scene(file, e.path, e.message))?;
            ld.named.insert(name.clone(), desc);
        }
    }

    // Shapes.
    let mut prims: Vec<Primitive> = Vec::new();
    let mut meshes: Vec<Mesh> = Vec::new();
    let mut shape_geom: Vec<ShapeGeom> = Vec::new();
    let mut shapes: Vec<ShapeInfo> = Vec::new();
    let mut lights: Vec<Light> = Vec::new();
    let mut gltf_camera = None;
    let shape_list = match top.get("shapes") {
        None => &[][..],
        Some(Value::Array(a)) => &a[..],
        Some(other) => {
            return Err(Error::scene(
                file,
                "shapes",
                format!("expected an array of shapes, found {}", describe(other)),
            ));
        }
    };
    for (i, sv) in shape_list.iter().enumerate() {
        let path = format!("shapes[{i}]");
        let kind = sv.get("type").and_then(Value::as_str).unwrap_or("");
        let allowed: &[&str] = match kind {
            "sphere" => &[
                "type",
                "center",
                "radius",
                "material",
                "emitter",
                "flip_normals",
            ],
            "rectangle" => &["type", "to_world", "material", "emitter", "flip_normals"],
            "obj" | "gltf" => &[
                "type",
                "file",
                "to_world",
                "material",
                "emitter",
                "flip_normals",
                "face_normals",
            ],
            _ => {
                let found = sv
                    .get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into());
                return Err(Error::scene(
                    file,
                    format!("{path}.type"),
                    format!(
                        "expected one of \"sphere\", \"rectangle\", \"obj\", \"gltf\", found {found}"
                    ),
                ));
            }
        };
        let o = Obj::new(file, &path, sv, allowed)?;
        let shape_id = shapes.len() as u32;
        let flip = o.bool_or("flip_normals", false)?;
        let face_normals = o.bool_or("face_normals", false)?;
        let to_world = match o.get("to_world") {
            Some(t) => transform::parse(file, &o.key_path("to_world"), t)?,
            None => Mat4::IDENTITY,
        };
        let area: Option<AreaShape>;
        match kind {
            "sphere" => {
                let center = o.vec3_opt("center")?.unwrap_or(Vec3::ZERO);
                let radius = o.f32_or("radius", 1.0, "a positive radius", positive)?;
                let s = Sphere { center, radius };
                prims.push(Primitive {
                    kind: PrimKind::Sphere(s),
                    shape: shape_id,
                });
                area = Some(AreaShape::Sphere { sphere: s, flip });
            }
            "rectangle" => {
                let r = Rectangle::from_transform(&to_world).ok_or_else(|| {
                    o.err(
                        "to_world",
                        "maps the rectangle to a degenerate (zero-area) shape",
                    )
                })?;
                prims.push(Primitive {
                    kind: PrimKind::Rectangle(r),
                    shape: shape_id,
                });
                area = Some(AreaShape::Rectangle { rect: r, flip });
            }
            _ => {
                let fname = o.str_req("file", "a mesh file path")?;
                let fpath = ld.resolve(fname);
                if !fpath.exists() {
                    return Err(o.err("file", format!("file {} does not exist", fpath.display())));
                }
                let mut mesh = if kind == "obj" {
                    mesh_io::load_obj(&fpath)?
                } else {
                    let g = mesh_io::load_gltf(&fpath)?;
                    if gltf_camera.is_none() {
                        gltf_camera = g.camera;
                    }
                    g.mesh
                };
                if prims.len() + mesh.indices.len() > crate::limits::MAX_TRIANGLES {
                    return Err(o.err(
                        "file",
                        format!(
                            "brings the scene to {} primitives; expected at most {} triangles in all",
                            prims.len() + mesh.indices.len(),
                            crate::limits::MAX_TRIANGLES
                        ),
                    ));
                }
                mesh.transform(&to_world);
                mesh_io::check_positions(&mesh, &fpath.display().to_string())?;
                let mesh_id = meshes.len() as u32;
                let mut emit_tris = Vec::new();
                for t in 0..mesh.indices.len() as u32 {
                    let tri = Triangle::new(mesh_id, &mesh, t);
                    if !(tri.area() > 0.0) {
                        continue; // degenerate triangles can never be hit
                    }
                    prims.push(Primitive {
                        kind: PrimKind::Triangle(tri),
                        shape: shape_id,
                    });
                    if o.has("emitter") {
                        let mut n = tri.normal();
                        if !face_normals && !mesh.normals.is_empty() {
                            let avg: Vec3 = mesh.indices[t as usize]
                                .iter()
                                .map(|&k| mesh.normals[k as usize])
                                .sum();
                            if avg.dot(n) < 0.0 {
                                n = -n;
                            }
                        }
                        emit_tris.push((tri, if flip { -n } else { n }));
                    }
                }
                meshes.push(mesh);
                area = if o.has("emitter") {
                    AreaShape::mesh(emit_tris)
                } else {
                    None
                };
            }
        }
        let material = ld.material(o.get("material"), &o.key_path("material"))?;
        let light = match o.get("emitter") {
            None => None,
            Some(ev) => {
                let e = Obj::new(file, o.key_path("emitter"), ev, &["type", "radiance"])?;
                match e.str_opt("type")? {
                    Some("area") | None => {}
                    Some(other) => {
                        return Err(e.err("type", format!("expected \"area\", found \"{other}\"")));
                    }
                }
                let radiance = e.rgb_req("radiance")?;
                let shape =
                    area.ok_or_else(|| o.err("emitter", "the shape has no area to emit from"))?;
                lights.push(Light::Area { shape, radiance });
                Some(lights.len() as u32 - 1)
            }
        };
        shape_geom.push(ShapeGeom {
            flip_normals: flip,
            face_normals,
        });
        shapes.push(ShapeInfo { material, light });
    }

    // Lights.
    if let Some(lv) = top.get("lights") {
        let list = lv.as_array().ok_or_else(|| {
            Error::scene(
                file,
                "lights",
                format!("expected an array of lights, found {}", describe(lv)),
            )
        })?;
        for (i, l) in list.iter().enumerate() {
            lights.push(parse_light(&ld, &format!("lights[{i}]"), l, &integrator)?);
        }
    }
    let infinite_lights = lights
        .iter()
        .enumerate()
        .filter(|(_, l)| matches!(l, Light::Env(_) | Light::Constant { .. }))
        .map(|(i, _)| i as u32)
        .collect();

    // Camera (or the first glTF camera).
    let camera = match top.get("camera") {
        Some(cv) => parse_camera(file, cv, width, height)?,
        None => match gltf_camera {
            Some(c) => c.build(width, height),
            None => {
                return Err(Error::scene(
                    file,
                    "camera",
                    "missing; expected a camera object (or a glTF shape whose file has a camera)",
                ));
            }
        },
    };

    let geometry =
        Geometry::build(prims, meshes, shape_geom).map_err(|e| Error::scene(file, "shapes", e))?;
    Ok(Scene {
        file: file.to_string(),
        camera,
        width,
        height,
        spp,
        seed,
        scramble,
        exposure,
        integrator,
        geometry,
        shapes,
        lights,
        infinite_lights,
    })
}

fn parse_integrator(file: &str, v: Option<&Value>) -> Result<Integrator> {
    let Some(v) = v else {
        return Ok(Integrator::Path {
            max_depth: None,
            rr_depth: 5,
        });
    };
    let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
    match kind {
        "path" => {
            let o = Obj::new(file, "integrator", v, &["type", "max_depth", "rr_depth"])?;
            let md = o.int_opt("max_depth", -1, 1 << 16)?.unwrap_or(-1);
            if md == 0 {
                return Err(o.err(
                    "max_depth",
                    "expected -1 (unbounded) or a depth >= 1, found 0",
                ));
            }
            Ok(Integrator::Path {
                max_depth: if md < 0 { None } else { Some(md as u32) },
                rr_depth: o.int_opt("rr_depth", 1, 1 << 16)?.unwrap_or(5) as u32,
            })
        }
        "direct" => {
            let o = Obj::new(
                file,
                "integrator",
                v,
                &["type", "emitter_samples", "bsdf_samples"],
            )?;
            let e = o.int_opt("emitter_samples", 0, 1024)?.unwrap_or(1) as u32;
            let b = o.int_opt("bsdf_samples", 0, 1024)?.unwrap_or(1) as u32;
            if e + b == 0 {
                return Err(o.err(
                    "bsdf_samples",
                    "expected emitter_samples + bsdf_samples >= 1",
                ));
            }
            Ok(Integrator::Direct {
                emitter_samples: e,
                bsdf_samples: b,
            })
        }
        _ => Err(Error::scene(
            file,
            "integrator.type",
            format!(
                "expected \"path\" or \"direct\", found {}",
                v.get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into())
            ),
        )),
    }
}

fn camera_frame(o: &Obj, file: &str) -> Result<Mat4> {
    if let Some(t) = o.get("to_world") {
        if o.has("origin") || o.has("target") || o.has("up") {
            return Err(o.err(
                "to_world",
                "give either to_world or origin/target/up, not both",
            ));
        }
        return transform::parse(file, &o.key_path("to_world"), t);
    }
    let origin = o.vec3_opt("origin")?.unwrap_or(Vec3::ZERO);
    let target = o.vec3_opt("target")?.unwrap_or(Vec3::Z);
    let up = o.vec3_opt("up")?.unwrap_or(Vec3::Y);
    look_at(origin, target, up).ok_or_else(|| {
        Error::scene(
            file,
            &o.path,
            "degenerate look-at: target equals origin or up is parallel to the view direction",
        )
    })
}

fn parse_camera(file: &str, v: &Value, width: u32, height: u32) -> Result<Camera> {
    let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
    match kind {
        "perspective" => {
            let o = Obj::new(
                file,
                "camera",
                v,
                &[
                    "type",
                    "fov",
                    "fov_axis",
                    "origin",
                    "target",
                    "up",
                    "to_world",
                    "near_clip",
                ],
            )?;
            let fov = o.f32_or(
                "fov",
                39.3077,
                "a field of view in degrees in (0, 180)",
                |x| x > 0.0 && x < 180.0,
            )?;
            let axis = o
                .name_opt("fov_axis", FovAxis::NAMES, FovAxis::parse)?
                .unwrap_or(FovAxis::X);
            let near = o.f32_or("near_clip", 0.01, "a non-negative distance", non_negative)?;
            let m = camera_frame(&o, file)?;
            Ok(Camera::perspective(
                m,
                fov_x_degrees(fov, axis, width, height),
                width,
                height,
                near,
            ))
        }
        "orthographic" => {
            let o = Obj::new(
                file,
                "camera",
                v,
                &[
                    "type",
                    "scale",
                    "origin",
                    "target",
                    "up",
                    "to_world",
                    "near_clip",
                ],
            )?;
            let scale = o.f32_or("scale", 1.0, "a positive half-width", positive)?;
            let near = o.f32_or("near_clip", 0.01, "a non-negative distance", non_negative)?;
            Ok(Camera::Orthographic {
                to_world: camera_frame(&o, file)?,
                scale,
                aspect: width as f32 / height as f32,
                near_clip: near,
            })
        }
        _ => Err(Error::scene(
            file,
            "camera.type",
            format!(
                "expected \"perspective\" or \"orthographic\", found {}",
                v.get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into())
            ),
        )),
    }
}

fn parse_light(ld: &Loader, path: &str, v: &Value, integrator: &Integrator) -> Result<Light> {
    let file = ld.file;
    let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
    match kind {
        "envmap" => {
            let o = Obj::new(
                file,
                path,
                v,
                &["type", "file", "scale", "to_world", "mis_compensation"],
            )?;
            let scale = o.f32_or("scale", 1.0, "a non-negative scale", non_negative)?;
            let compensate = o.bool_or("mis_compensation", false)?;
            let bsdf_sampling = match integrator {
                Integrator::Path { .. } => true,
                Integrator::Direct { bsdf_samples, .. } => *bsdf_samples > 0,
            };
            if compensate && !bsdf_sampling {
                // Without BSDF samples, directions darker than the map's mean would never
                // be sampled: the image would be too dark.
                return Err(o.err(
                    "mis_compensation",
                    "expected false with this integrator: compensation needs BSDF sampling (the path integrator, or direct with bsdf_samples >= 1)",
                ));
            }
            let rot = match o.get("to_world") {
                Some(t) => {
                    let m = transform::parse(file, &o.key_path("to_world"), t)?;
                    transform::rotation(file, &o.key_path("to_world"), &m)?
                }
                None => Mat3::IDENTITY,
            };
            let img = ld.image(&o, "file")?;
            Ok(Light::Env(Box::new(EnvMap::with_mis_compensation(
                &img, scale, rot, compensate,
            ))))
        }
        "constant" => {
            let o = Obj::new(file, path, v, &["type", "radiance"])?;
            Ok(Light::Constant {
                radiance: o.rgb_opt("radiance")?.unwrap_or(lobe_materials::Rgb::ONE),
            })
        }
        "point" => {
            let o = Obj::new(file, path, v, &["type", "position", "intensity"])?;
            Ok(Light::Point {
                position: o.vec3_req("position")?,
                intensity: o.rgb_req("intensity")?,
            })
        }
        "directional" => {
            let o = Obj::new(file, path, v, &["type", "direction", "irradiance"])?;
            let d = o.vec3_req("direction")?;
            if d.length_squared() == 0.0 {
                return Err(o.err("direction", "expected a non-zero direction of propagation"));
            }
            Ok(Light::Directional {
                direction: d.normalize(),
                irradiance: o.rgb_req("irradiance")?,
            })
        }
        _ => Err(Error::scene(
            file,
            format!("{path}.type"),
            format!(
                "expected one of \"envmap\", \"constant\", \"point\", \"directional\" (area lights are an \"emitter\" of a shape), found {}",
                v.get("type")
                    .map(describe)
                    .unwrap_or_else(|| "nothing".into())
            ),
        )),
    }
}
