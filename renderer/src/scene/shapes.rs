//! The `shapes` of a scene file (docs/scene-format.md, "Shapes"; Mitsuba 3's `sphere`,
//! `rectangle`, `obj`, `ply` and `gltf` shapes, same parameters and meanings): each becomes
//! primitives for the BVH, its material (from the registry, see [`super::Loader`]) and, when
//! it has an `emitter`, a one-sided diffuse area light on its surface.

use super::json::{Obj, describe};
use super::mesh_io::{self, GltfCamera};
use super::{Loader, ShapeInfo, positive, transform};
use crate::error::{Error, Result};
use crate::geometry::bvh::{Prims, ShapeGeom};
use crate::geometry::primitive::{PrimKind, Primitive};
use crate::geometry::{Mesh, Rectangle, Sphere, Triangle};
use crate::lights::{AreaShape, Light};
use crate::limits::MAX_COORDINATE;
use glam::{Mat4, Vec3};
use serde_json::Value;

/// What the shapes of a scene contribute to it: primitives, meshes, per-shape geometry
/// flags, materials and lights (area lights, in shape order), and the first glTF camera.
#[derive(Default)]
pub(super) struct Shapes {
    pub prims: Prims,
    pub meshes: Vec<Mesh>,
    /// The rectangles [`PrimKind::Rectangle`] points into.
    pub rects: Vec<Rectangle>,
    pub shape_geom: Vec<ShapeGeom>,
    pub shapes: Vec<ShapeInfo>,
    pub lights: Vec<Light>,
    pub gltf_camera: Option<GltfCamera>,
    /// Seconds spent reading mesh files.
    pub mesh_read_seconds: f64,
    /// Each distinct material's number ([`ShapeInfo::material_group`]), by its address.
    material_groups: std::collections::HashMap<*const (), u32>,
}

/// The keys every shape has beside those of its kind.
struct Common {
    id: u32,
    flip: bool,
    face_normals: bool,
    to_world: Mat4,
}

/// Reads the `shapes` array of a scene (absent: none).
pub(super) fn parse_shapes<'a>(ld: &mut Loader<'a>, top: &Obj<'a>) -> Result<Shapes> {
    let shape_list = match top.get("shapes") {
        None => &[][..],
        Some(Value::Array(a)) => &a[..],
        Some(other) => {
            return Err(Error::scene(
                ld.file,
                "shapes",
                format!("expected an array of shapes, found {}", describe(other)),
            ));
        }
    };
    let mut out = Shapes::default();
    for (i, sv) in shape_list.iter().enumerate() {
        out.parse_shape(ld, &format!("shapes[{i}]"), sv)?;
    }
    Ok(out)
}

/// The keys a shape of type `kind` may have, or the error naming the known types.
fn allowed_keys(file: &str, path: &str, sv: &Value, kind: &str) -> Result<&'static [&'static str]> {
    Ok(match kind {
        "sphere" => &[
            "type",
            "center",
            "radius",
            "material",
            "emitter",
            "flip_normals",
        ],
        "rectangle" => &["type", "to_world", "material", "emitter", "flip_normals"],
        "obj" | "ply" | "gltf" => &[
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
                    "expected one of \"sphere\", \"rectangle\", \"obj\", \"ply\", \"gltf\", found {found}"
                ),
            ));
        }
    })
}

impl Shapes {
    /// One shape: its geometry, then its material, then its emitter.
    fn parse_shape<'a>(&mut self, ld: &mut Loader<'a>, path: &str, sv: &'a Value) -> Result<()> {
        let file = ld.file;
        let kind = sv.get("type").and_then(Value::as_str).unwrap_or("");
        let o = Obj::new(file, path, sv, allowed_keys(file, path, sv, kind)?)?;
        let c = Common {
            id: self.shapes.len() as u32,
            flip: o.bool_or("flip_normals", false)?,
            face_normals: o.bool_or("face_normals", false)?,
            to_world: match o.get("to_world") {
                Some(t) => transform::parse(file, &o.key_path("to_world"), t)?,
                None => Mat4::IDENTITY,
            },
        };
        let area = match kind {
            "sphere" => self.sphere(&o, &c)?,
            "rectangle" => self.rectangle(&o, &c)?,
            _ => self.mesh(ld, &o, kind, &c)?,
        };
        let material = ld.material(o.get("material"), &o.key_path("material"))?;
        let light = self.emitter(&o, area)?;
        self.shape_geom.push(ShapeGeom {
            flip_normals: c.flip,
            face_normals: c.face_normals,
        });
        let next = self.material_groups.len() as u32;
        let material_group = *self
            .material_groups
            .entry(std::sync::Arc::as_ptr(&material) as *const ())
            .or_insert(next);
        self.shapes.push(ShapeInfo {
            material,
            light,
            material_group,
        });
        Ok(())
    }

    fn sphere(&mut self, o: &Obj, c: &Common) -> Result<Option<AreaShape>> {
        let center = o.vec3_opt("center")?.unwrap_or(Vec3::ZERO);
        let radius = o.f32_or("radius", 1.0, "a positive radius", positive)?;
        // The limit of mesh vertices: beyond it f32 holds positions to 64 units or worse.
        let reach = center.abs().max_element() + radius;
        if !(reach <= MAX_COORDINATE) {
            return Err(o.err(
                "radius",
                format!(
                    "the sphere at {center} of radius {radius} reaches {reach:e} from the origin; expected within {MAX_COORDINATE:e} per axis (as mesh vertices)"
                ),
            ));
        }
        let s = Sphere { center, radius };
        self.prims.push(Primitive {
            kind: PrimKind::Sphere(s),
            shape: c.id,
        });
        Ok(Some(AreaShape::Sphere {
            sphere: s,
            flip: c.flip,
        }))
    }

    fn rectangle(&mut self, o: &Obj, c: &Common) -> Result<Option<AreaShape>> {
        let r = Rectangle::from_transform(&c.to_world).ok_or_else(|| {
            o.err(
                "to_world",
                "maps the rectangle to a degenerate (zero-area) shape",
            )
        })?;
        self.rects.push(r);
        self.prims.push(Primitive {
            kind: PrimKind::Rectangle(self.rects.len() as u32 - 1),
            shape: c.id,
        });
        Ok(Some(AreaShape::Rectangle {
            rect: r,
            flip: c.flip,
        }))
    }

    /// An OBJ, PLY or glTF mesh: its non-degenerate triangles, and their outward normals when
    /// the shape emits.
    fn mesh(&mut self, ld: &Loader, o: &Obj, kind: &str, c: &Common) -> Result<Option<AreaShape>> {
        let fname = o.str_req("file", "a mesh file path")?;
        let fpath = ld.resolve(fname);
        if !fpath.exists() {
            return Err(o.err("file", format!("file {} does not exist", fpath.display())));
        }
        let start = std::time::Instant::now();
        let mut mesh = if kind == "obj" {
            mesh_io::load_obj(&fpath)?
        } else if kind == "ply" {
            mesh_io::load_ply(&fpath)?
        } else {
            let g = mesh_io::load_gltf(&fpath)?;
            if self.gltf_camera.is_none() {
                self.gltf_camera = g.camera;
            }
            g.mesh
        };
        self.mesh_read_seconds += start.elapsed().as_secs_f64();
        if self.prims.len() + mesh.indices.len() > crate::limits::MAX_TRIANGLES {
            return Err(o.err(
                "file",
                format!(
                    "brings the scene to {} primitives; expected at most {} triangles in all",
                    self.prims.len() + mesh.indices.len(),
                    crate::limits::MAX_TRIANGLES
                ),
            ));
        }
        mesh.transform(&c.to_world);
        mesh_io::check_positions(&mesh, &fpath.display().to_string())?;
        let mesh_id = self.meshes.len() as u32;
        let mut emit_tris = Vec::new();
        for t in 0..mesh.indices.len() as u32 {
            let tri = Triangle::new(mesh_id, &mesh, t);
            if !(tri.area() > 0.0) {
                continue; // degenerate triangles can never be hit
            }
            self.prims.push(Primitive {
                kind: PrimKind::Triangle {
                    mesh: mesh_id,
                    index: t,
                },
                shape: c.id,
            });
            if o.has("emitter") {
                let mut n = tri.normal();
                if !c.face_normals && !mesh.normals.is_empty() {
                    let avg: Vec3 = mesh.indices[t as usize]
                        .iter()
                        .map(|&k| mesh.normals[k as usize])
                        .sum();
                    if avg.dot(n) < 0.0 {
                        n = -n;
                    }
                }
                emit_tris.push((tri, if c.flip { -n } else { n }));
            }
        }
        self.meshes.push(mesh);
        Ok(if o.has("emitter") {
            AreaShape::mesh(emit_tris)
        } else {
            None
        })
    }

    /// The shape's `emitter` (an area light on `area`), if it has one: the index of its
    /// light.
    fn emitter(&mut self, o: &Obj, area: Option<AreaShape>) -> Result<Option<u32>> {
        let Some(ev) = o.get("emitter") else {
            return Ok(None);
        };
        let e = Obj::new(o.file, o.key_path("emitter"), ev, &["type", "radiance"])?;
        match e.str_opt("type")? {
            Some("area") | None => {}
            Some(other) => {
                return Err(e.err("type", format!("expected \"area\", found \"{other}\"")));
            }
        }
        let radiance = e.rgb_req("radiance")?;
        let shape = area.ok_or_else(|| o.err("emitter", "the shape has no area to emit from"))?;
        self.lights.push(Light::Area { shape, radiance });
        Ok(Some(self.lights.len() as u32 - 1))
    }
}

/// Refuses spheres that f32 cannot resolve as the camera sees them, with the scale of
/// their coordinates and the camera's: the radius and the camera's distance to the
/// surface must each span at least 64 f32 steps (ulps) at that scale. Below, a camera
/// ray's closest approach to the centre is off by a good part of the radius (a camera
/// 1e7 from a unit sphere) or the surface lies between representable points (a camera
/// 4.5 from a sphere of radius 1e8), and the sphere renders black or in pieces.
pub(super) fn check_sphere_precision(file: &str, eye: Vec3, prims: &Prims) -> Result<()> {
    for p in prims.iter() {
        let PrimKind::Sphere(s) = &p.kind else {
            continue;
        };
        let scale = (s.center.abs().max_element() + s.radius).max(eye.abs().max_element());
        let step = 64.0 * scale * f32::EPSILON;
        let clearance = ((eye - s.center).length() - s.radius).abs();
        let (what, value) = if s.radius < step {
            ("radius", s.radius)
        } else if clearance < step {
            ("distance from the camera to the surface", clearance)
        } else {
            continue;
        };
        return Err(Error::scene(
            file,
            format!("shapes[{}]", p.shape),
            format!(
                "the sphere's {what} is {value:e}, below 64 single-precision steps ({step:e}) at the scene's scale {scale:e} (the camera at {eye}, the sphere at {}): expected the scene moved or scaled so that f32 resolves it",
                s.center
            ),
        ));
    }
    Ok(())
}
