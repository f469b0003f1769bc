//! Scene files: JSON descriptions (docs/scene-format.md) loaded into a [`Scene`].
//!
//! Loading validates every value (unknown keys, wrong types and out-of-range values are
//! errors naming the file, the JSON path and what was expected), resolves relative paths
//! against the scene file's folder, asks the materials registry for each material (named
//! materials are built once, only if a shape uses them, and shared), reads meshes and
//! environment maps, and builds one BVH over all primitives. [`from_value`] reads the
//! film, sampler, integrator and materials here, the shapes, lights and camera each in
//! their own module (`shapes`, `lights`, `camera`).

pub mod builtin_images;
mod camera;
pub mod gltf_check;
pub mod inputs;
pub mod json;
mod lights;
pub mod mesh_io;
pub mod obj;
pub mod ply;
mod shapes;
pub mod transform;
mod world;

pub use world::{ShapeInfo, World};

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::image_io::RgbImage;
use crate::lights::Light;
use crate::lights::envmap::load_rgb_image;
use crate::sampler::Scramble;
use crate::settings::{Integrator, RenderSettings};
use json::{Obj, describe};
use lobe_materials::Bsdf;
use lobe_materials::registry::{BuildContext, Registry};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A loaded scene, ready to render.
pub struct Scene {
    /// The scene file (for messages and the statistics sidecar).
    pub file: String,
    pub camera: Camera,
    /// The film, sampler and integrator the file asks for.
    pub settings: RenderSettings,
    /// The geometry and BVH, shapes and lights (what the integrators read).
    pub world: World,
    /// The digest of the scene description and the folder its paths resolve against
    /// ([`lobe_materials::key`]; the files it names are not read into it).
    pub description_digest: String,
    /// Where the time of loading went.
    pub load_times: LoadTimes,
}

/// Seconds spent loading a scene: reading its mesh files (parsing, checking, vertex
/// normals) and building its BVH are parts of the whole (which also counts materials,
/// images and environment maps).
#[derive(Clone, Copy, Debug, Default)]
pub struct LoadTimes {
    pub total_seconds: f64,
    pub mesh_read_seconds: f64,
    pub bvh_build_seconds: f64,
}

impl Scene {
    /// The key of this scene's render as now set up: its description with the samples per
    /// pixel, seed, scrambling and film size (which callers may override after loading).
    /// Parts of one render share it ([`crate::partial`]).
    pub fn render_key(&self) -> String {
        lobe_materials::key::KeyBuilder::new("render")
            .text("scene", &self.description_digest)
            .number("spp", self.settings.spp as f64)
            .text("seed", &self.settings.seed.to_string())
            .text("scramble", self.settings.scramble.name())
            .number("width", self.settings.width as f64)
            .number("height", self.settings.height as f64)
            .finish()
    }
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
    /// The built-in images (`builtin:studio`, `builtin:sunset`).
    pub fn with_builtins() -> Self {
        let mut b: BTreeMap<String, ImageMaker> = BTreeMap::new();
        b.insert("studio".to_string(), || {
            builtin_images::studio_environment(512, 256)
        });
        b.insert("sunset".to_string(), builtin_images::sunset_environment);
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

    /// The named `materials`: validated now, built when a shape uses them.
    fn declare_materials(&mut self, v: Option<&'a Value>) -> Result<()> {
        let file = self.file;
        if let Some(mv) = v {
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
                self.registry
                    .check(desc, &format!("materials.{name}"))
                    .map_err(|e| Error::scene(file, e.path, e.message))?;
                self.named.insert(name.clone(), desc);
            }
        }
        Ok(())
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
    let start = std::time::Instant::now();
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
    let (width, height, exposure) = parse_film(file, top.get("film"))?;
    let (spp, seed, scramble) = parse_sampler(file, top.get("sampler"))?;
    let integrator = parse_integrator(file, top.get("integrator"))?;
    ld.declare_materials(top.get("materials"))?;
    let shapes = shapes::parse_shapes(&mut ld, &top)?;
    // Area lights first (shapes refer to them by index), then the `lights`.
    let mut lights = shapes.lights;
    lights::parse_lights(&ld, top.get("lights"), &integrator, &mut lights)?;
    let infinite_lights = lights
        .iter()
        .enumerate()
        .filter(|(_, l)| matches!(l, Light::Env(_) | Light::Constant { .. }))
        .map(|(i, _)| i as u32)
        .collect();
    let camera = camera::scene_camera(file, top.get("camera"), shapes.gltf_camera, width, height)?;
    let eye = camera.ray(glam::Vec2::splat(0.5)).o;
    shapes::check_sphere_precision(file, eye, &shapes.prims)?;
    let mesh_read_seconds = shapes.mesh_read_seconds;
    let geometry = Geometry::build(shapes.prims, shapes.meshes, shapes.rects, shapes.shape_geom)
        .map_err(|e| Error::scene(file, "shapes", e))?;
    let load_times = LoadTimes {
        total_seconds: start.elapsed().as_secs_f64(),
        mesh_read_seconds,
        bvh_build_seconds: geometry.build_seconds,
    };
    Ok(Scene {
        file: file.to_string(),
        camera,
        settings: RenderSettings {
            width,
            height,
            spp,
            seed,
            scramble,
            exposure,
            integrator,
        },
        world: World {
            geometry,
            shapes: shapes.shapes,
            lights,
            infinite_lights,
        },
        description_digest: lobe_materials::key::KeyBuilder::new("scene")
            .json("scene", v)
            .text("base", &base.display().to_string())
            .finish(),
        load_times,
    })
}

/// The `film`: (width, height, exposure).
fn parse_film(file: &str, v: Option<&Value>) -> Result<(u32, u32, f32)> {
    Ok(match v {
        None => (256, 256, 0.0),
        Some(fv) => {
            let f = Obj::new(file, "film", fv, &["width", "height", "exposure"])?;
            (
                f.int_opt("width", 1, 16384)?.unwrap_or(256) as u32,
                f.int_opt("height", 1, 16384)?.unwrap_or(256) as u32,
                f.f32_or("exposure", 0.0, "a number of stops", |x| x.abs() <= 64.0)?,
            )
        }
    })
}

/// The `sampler`: (samples per pixel, seed, scrambling).
fn parse_sampler(file: &str, v: Option<&Value>) -> Result<(u32, u64, Scramble)> {
    Ok(match v {
        None => (16, 0, Scramble::default()),
        Some(sv) => {
            let s = Obj::new(file, "sampler", sv, &["spp", "seed", "scramble"])?;
            let scramble = s
                .name_opt("scramble", &Scramble::NAMES, Scramble::parse)?
                .unwrap_or_default();
            (
                s.int_opt("spp", 1, crate::limits::MAX_SPP as i64)?
                    .unwrap_or(16) as u32,
                s.int_opt("seed", 0, i64::MAX)?.unwrap_or(0) as u64,
                scramble,
            )
        }
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
