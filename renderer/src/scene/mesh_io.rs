//! Triangle-mesh loading: Wavefront OBJ ([`super::obj`]), Stanford PLY ([`super::ply`])
//! and glTF 2.0 (gltf: meshes of the default
//! scene with their node transforms, and the first camera found in depth-first order).
//! Every index and position is validated, so a broken file gives an error, never a panic.

use crate::camera::{Camera, look_at};
use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::limits::{MAX_COORDINATE, MAX_TRIANGLES};
use glam::{Mat4, Vec3};
use std::path::Path;

fn check_mesh(mesh: &Mesh, shown: &str) -> Result<()> {
    let n = mesh.positions.len() as u32;
    if mesh.indices.is_empty() {
        return Err(Error::file(
            shown,
            "contains no triangles; expected a triangle mesh",
        ));
    }
    check_positions(mesh, shown)?;
    if let Some((i, t)) = mesh
        .indices
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&k| k >= n))
    {
        return Err(Error::file(
            shown,
            format!(
                "triangle {i} refers to vertex {:?}, but the mesh has {n} vertices",
                t
            ),
        ));
    }
    Ok(())
}

/// Every vertex finite and within [`MAX_COORDINATE`] (of the origin, per axis).
pub fn check_positions(mesh: &Mesh, shown: &str) -> Result<()> {
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !(p.abs().max_element() <= MAX_COORDINATE))
    {
        return Err(Error::file(
            shown,
            format!(
                "vertex {i} is at {p}; expected finite coordinates within {MAX_COORDINATE:e} (after the shape's transform)"
            ),
        ));
    }
    Ok(())
}

/// Loads an OBJ file as one mesh (all its objects and groups; [`super::obj`]), with
/// angle-weighted vertex normals where the file gives none for some vertex.
pub fn load_obj(path: &Path) -> Result<Mesh> {
    load_mesh_file(path, "an OBJ file", super::obj::parse)
}

/// Loads a PLY file as one mesh ([`super::ply`]), with angle-weighted vertex normals where
/// the file gives none.
pub fn load_ply(path: &Path) -> Result<Mesh> {
    load_mesh_file(path, "a PLY file", super::ply::parse)
}

/// Reads `path` (`what` it should be) whole, parses it with `parse`, checks the mesh and
/// computes vertex normals where some are missing.
fn load_mesh_file(path: &Path, what: &str, parse: fn(&[u8], &str) -> Result<Mesh>) -> Result<Mesh> {
    let shown = path.display().to_string();
    let bytes = lobe_materials::io::read_regular(path, lobe_materials::io::MAX_DATA_BYTES, what)?;
    let mut mesh = parse(&bytes, &shown)?;
    drop(bytes);
    check_mesh(&mesh, &shown)?;
    if mesh.normals.len() != mesh.positions.len() || mesh.normals.contains(&Vec3::ZERO) {
        mesh.compute_vertex_normals();
    }
    Ok(mesh)
}

/// Meshes and the first camera of a glTF file.
pub struct GltfScene {
    pub mesh: Mesh,
    /// Camera-to-world frame (Mitsuba convention) and the glTF camera.
    pub camera: Option<GltfCamera>,
}

#[derive(Clone, Copy, Debug)]
pub enum GltfCamera {
    /// Vertical field of view in degrees.
    Perspective { to_world: Mat4, yfov_deg: f32 },
    /// Half-width of the view (`xmag`).
    Orthographic { to_world: Mat4, xmag: f32 },
}

impl GltfCamera {
    pub fn build(&self, width: u32, height: u32) -> Camera {
        match *self {
            GltfCamera::Perspective { to_world, yfov_deg } => {
                let fx = crate::camera::fov_x_degrees(
                    yfov_deg,
                    crate::camera::FovAxis::Y,
                    width,
                    height,
                );
                Camera::perspective(to_world, fx, width, height, 0.01)
            }
            GltfCamera::Orthographic { to_world, xmag } => Camera::Orthographic {
                to_world,
                scale: xmag,
                aspect: width as f32 / height as f32,
                near_clip: 0.0,
            },
        }
    }
}

/// Loads the default scene of a glTF 2.0 file (.gltf or .glb): every triangle primitive of
/// every mesh node, transformed by its node's world transform, as one mesh, and the first
/// camera in depth-first order. The file is checked first ([`super::gltf_check`]: container,
/// cross-references, buffers, accessors, node graph), then the `gltf` crate parses it and
/// reads the accessors, each call under [`lobe_materials::guard::third_party`].
pub fn load_gltf(path: &Path) -> Result<GltfScene> {
    use super::gltf_check as check;
    let shown = path.display().to_string();
    let bytes =
        lobe_materials::io::read_regular(path, lobe_materials::io::MAX_DATA_BYTES, "a glTF file")?;
    let fail = |m: String| Error::file(&shown, m);
    let parts = check::container(&bytes).map_err(fail)?;
    // Everything the gltf crate reads must pass the checks, so a document they cannot
    // parse is refused here (serde_json skips unknown keys without validating their UTF-8
    // when deserializing the crate's types, so the crate would accept more).
    let (buffers, visits) = match serde_json::from_slice::<serde_json::Value>(parts.json) {
        Err(e) => return Err(fail(format!("cannot read glTF: invalid JSON ({e})"))),
        Ok(v) => {
            check::check_indices(&v).map_err(fail)?;
            let base = path.parent().unwrap_or(Path::new("."));
            let buffers = check::load_buffers(&v, base, parts.bin).map_err(fail)?;
            check::check_accessors(&v, &buffers).map_err(fail)?;
            let scene = v
                .get("scene")
                .and_then(serde_json::Value::as_u64)
                .unwrap_or(0) as usize;
            let visits = if v.get("scenes").and_then(|s| s.get(scene)).is_some() {
                check::walk(&v, scene).map_err(fail)?
            } else {
                Vec::new()
            };
            let tris = check::triangle_count(&v, &visits);
            if tris > MAX_TRIANGLES as u64 {
                return Err(fail(format!(
                    "its meshes and node instances expand to {tris} triangles; expected at most {MAX_TRIANGLES}"
                )));
            }
            (buffers, visits)
        }
    };
    let gltf = lobe_materials::guard::third_party("glTF", || gltf::Gltf::from_slice(&bytes))
        .map_err(fail)?
        .map_err(|e| Error::file(&shown, format!("cannot read glTF: {e}")))?;
    let doc = &gltf.document;
    if doc.scenes().next().is_none() {
        return Err(Error::file(
            &shown,
            "has no scene; expected at least one glTF scene",
        ));
    }
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut out = GltfScene {
        mesh: Mesh::default(),
        camera: None,
    };
    let mut any_missing_normals = false;
    let mut worlds: Vec<Mat4> = Vec::with_capacity(visits.len());
    for visit in &visits {
        let node = &nodes[visit.node];
        let parent = visit.parent.map_or(Mat4::IDENTITY, |k| worlds[k]);
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        worlds.push(world);
        if out.camera.is_none()
            && let Some(cam) = node.camera()
        {
            out.camera = Some(gltf_camera(&cam, world, node.index(), &shown)?);
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let missing = add_primitive(&mut out.mesh, (mesh.index(), &prim), &buffers, world)
                    .map_err(fail)?;
                any_missing_normals |= missing;
            }
        }
    }
    if out.mesh.indices.is_empty() {
        if out.camera.is_some() {
            return Ok(out);
        }
        return Err(Error::file(
            &shown,
            "contains no triangle meshes and no camera",
        ));
    }
    check_mesh(&out.mesh, &shown)?;
    if any_missing_normals || out.mesh.normals.len() != out.mesh.positions.len() {
        out.mesh.compute_vertex_normals();
    }
    Ok(out)
}

/// The camera of a glTF node with world transform `world`.
fn gltf_camera(cam: &gltf::Camera, world: Mat4, node: usize, shown: &str) -> Result<GltfCamera> {
    let origin = world.transform_point3(Vec3::ZERO);
    let fwd = world.transform_vector3(Vec3::NEG_Z);
    let up = world.transform_vector3(Vec3::Y);
    let to_world = look_at(origin, origin + fwd, up).ok_or_else(|| {
        Error::file(
            shown,
            format!("camera node {node} has a degenerate transform"),
        )
    })?;
    Ok(match cam.projection() {
        gltf::camera::Projection::Perspective(p) => GltfCamera::Perspective {
            to_world,
            yfov_deg: p.yfov().to_degrees(),
        },
        gltf::camera::Projection::Orthographic(o) => GltfCamera::Orthographic {
            to_world,
            xmag: o.xmag(),
        },
    })
}

/// Appends one triangle primitive (its accessors already checked), transformed by
/// `world`, within [`MAX_TRIANGLES`]; returns true when it has no usable normals.
fn add_primitive(
    mesh: &mut Mesh,
    (mesh_index, prim): (usize, &gltf::Primitive),
    buffers: &[Vec<u8>],
    world: Mat4,
) -> std::result::Result<bool, String> {
    let at = format!("meshes[{mesh_index}].primitives[{}]", prim.index());
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
    let guarded =
        |f: &dyn Fn() -> Option<Vec<Vec3>>| lobe_materials::guard::third_party("glTF accessor", f);
    let Some(pos) = guarded(&|| {
        reader
            .read_positions()
            .map(|ps| ps.map(Vec3::from_array).collect())
    })?
    else {
        return Ok(false);
    };
    let idx: Vec<u32> = match lobe_materials::guard::third_party("glTF accessor", || {
        reader.read_indices().map(|i| i.into_u32().collect())
    })? {
        Some(i) => i,
        None => (0..pos.len() as u32).collect(),
    };
    let n = pos.len() as u32;
    let (tris, verts) = (
        mesh.indices.len() + idx.len() / 3,
        mesh.positions.len() + pos.len(),
    );
    if tris > MAX_TRIANGLES || verts > 3 * MAX_TRIANGLES {
        return Err(format!(
            "{at}: the scene's meshes and their instances reach {tris} triangles and {verts} vertices; expected at most {MAX_TRIANGLES} triangles (and three times as many vertices)"
        ));
    }
    if let Some(bad) = idx.iter().find(|&&k| k >= n) {
        return Err(format!(
            "{at}: refers to vertex {bad}, but has {n} vertices"
        ));
    }
    let normals = guarded(&|| {
        reader
            .read_normals()
            .map(|ns| ns.map(Vec3::from_array).collect())
    })?;
    let normal_m = world.inverse().transpose();
    let mut missing = true;
    if let Some(ns) = normals
        && ns.len() == pos.len()
    {
        mesh.normals.extend(
            ns.iter()
                .map(|&v| normal_m.transform_vector3(v).normalize_or_zero()),
        );
        missing = false;
    }
    let base = mesh.positions.len() as u32;
    mesh.positions
        .extend(pos.iter().map(|&p| world.transform_point3(p)));
    let mirror = world.determinant() < 0.0;
    mesh.indices.extend(idx.chunks(3).map(|c| {
        if mirror {
            [c[0] + base, c[2] + base, c[1] + base]
        } else {
            [c[0] + base, c[1] + base, c[2] + base]
        }
    }));
    Ok(missing)
}
