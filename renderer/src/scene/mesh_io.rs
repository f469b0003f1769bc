//! Triangle-mesh loading: Wavefront OBJ (tobj) and glTF 2.0 (gltf: meshes of the default
//! scene with their node transforms, and the first camera found in depth-first order).
//! Every index and position is validated, so a broken file gives an error, never a panic.

use crate::camera::{Camera, look_at};
use crate::error::{Error, Result};
use crate::geometry::Mesh;
use glam::{Mat4, Vec2, Vec3};
use std::path::Path;

fn check_mesh(mesh: &Mesh, shown: &str) -> Result<()> {
    let n = mesh.positions.len() as u32;
    if mesh.indices.is_empty() {
        return Err(Error::file(
            shown,
            "contains no triangles; expected a triangle mesh",
        ));
    }
    if let Some((i, _)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.is_finite())
    {
        return Err(Error::file(
            shown,
            format!("vertex {i} has a non-finite position; expected finite coordinates"),
        ));
    }
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

/// Loads an OBJ file as one mesh (all its objects and groups).
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let shown = path.display().to_string();
    if path.is_dir() {
        return Err(Error::file(&shown, "is a directory; expected an OBJ file"));
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj(path, &opts)
        .map_err(|e| Error::file(&shown, format!("cannot read OBJ: {e}")))?;
    let mut mesh = Mesh::default();
    let mut all_have_normals = true;
    for m in &models {
        let mm = &m.mesh;
        let base = mesh.positions.len() as u32;
        if mm.positions.len() % 3 != 0 || mm.indices.len() % 3 != 0 {
            return Err(Error::file(
                &shown,
                format!("object \"{}\" has malformed vertex or face data", m.name),
            ));
        }
        let nv = mm.positions.len() / 3;
        mesh.positions
            .extend(mm.positions.chunks(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        if mm.normals.len() == mm.positions.len() {
            mesh.normals.extend(
                mm.normals
                    .chunks(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero()),
            );
        } else {
            all_have_normals = false;
        }
        if mm.texcoords.len() == 2 * nv {
            mesh.texcoords
                .extend(mm.texcoords.chunks(2).map(|c| Vec2::new(c[0], c[1])));
        }
        mesh.indices.extend(
            mm.indices
                .chunks(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
    }
    if mesh.texcoords.len() != mesh.positions.len() {
        mesh.texcoords.clear();
    }
    check_mesh(&mesh, &shown)?;
    if !all_have_normals || mesh.normals.contains(&Vec3::ZERO) {
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
/// every mesh node, transformed by its node's world transform, as one mesh.
/// Checks every index between glTF objects before the `gltf` crate validates the document:
/// its validation indexes some arrays unchecked (found by fuzzing: a primitive's `indices`
/// naming a missing accessor panics inside gltf-json 1.4), so a malformed file must be
/// refused first. Binary .glb files are checked through their JSON chunk.
fn check_gltf_indices(bytes: &[u8]) -> std::result::Result<(), String> {
    let json: &[u8] = if bytes.starts_with(b"glTF") {
        // The GLB container (its header arithmetic is unchecked in gltf 1.4 too).
        let u32_at = |o: usize| -> Option<usize> {
            bytes
                .get(o..o + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
        };
        let (Some(version), Some(length), Some(json_len)) = (u32_at(4), u32_at(8), u32_at(12))
        else {
            return Err("truncated GLB header; expected a 12-byte header and a JSON chunk".into());
        };
        if version != 2 {
            return Err(format!("GLB version {version}; expected 2"));
        }
        if length < 20 || length > bytes.len() {
            return Err(format!(
                "GLB header declares {length} bytes, the file has {}; expected 20 to {}",
                bytes.len(),
                bytes.len()
            ));
        }
        if bytes.get(16..20) != Some(b"JSON".as_slice()) {
            return Err("the first GLB chunk is not JSON; expected a JSON chunk".into());
        }
        let json_end = 20usize.saturating_add(json_len);
        if json_end > length {
            return Err(format!(
                "GLB JSON chunk of {json_len} bytes runs past the declared length {length}"
            ));
        }
        // An optional BIN chunk must fit as well.
        let bin_at = json_end.next_multiple_of(4);
        if bin_at + 8 <= length
            && let Some(bin_len) = u32_at(bin_at)
            && bin_at + 8 + bin_len > length
        {
            return Err(format!(
                "GLB BIN chunk of {bin_len} bytes runs past the declared length {length}"
            ));
        }
        &bytes[20..json_end]
    } else {
        bytes
    };
    // Not JSON: leave the error message to the gltf crate.
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(json) else {
        return Ok(());
    };
    let count = |k: &str| v.get(k).and_then(|a| a.as_array()).map_or(0, |a| a.len());
    let check =
        |what: String, idx: &serde_json::Value, target: &str| -> std::result::Result<(), String> {
            match idx.as_u64() {
                Some(i) if (i as usize) < count(target) => Ok(()),
                _ => Err(format!(
                    "{what}: {idx} is not an index into \"{target}\" (which has {} entries)",
                    count(target)
                )),
            }
        };
    let arr = |o: &serde_json::Value, k: &str| -> Vec<serde_json::Value> {
        o.get(k)
            .and_then(|a| a.as_array())
            .cloned()
            .unwrap_or_default()
    };
    for (m, mesh) in arr(&v, "meshes").iter().enumerate() {
        for (p, prim) in arr(mesh, "primitives").iter().enumerate() {
            let at = format!("meshes[{m}].primitives[{p}]");
            if let Some(a) = prim.get("attributes").and_then(|a| a.as_object()) {
                for (name, idx) in a {
                    check(format!("{at}.attributes.{name}"), idx, "accessors")?;
                }
            }
            if let Some(i) = prim.get("indices") {
                check(format!("{at}.indices"), i, "accessors")?;
            }
            for (t, target) in arr(prim, "targets").iter().enumerate() {
                if let Some(a) = target.as_object() {
                    for (name, idx) in a {
                        check(format!("{at}.targets[{t}].{name}"), idx, "accessors")?;
                    }
                }
            }
            if let Some(i) = prim.get("material") {
                check(format!("{at}.material"), i, "materials")?;
            }
        }
    }
    for (a, acc) in arr(&v, "accessors").iter().enumerate() {
        if let Some(i) = acc.get("bufferView") {
            check(format!("accessors[{a}].bufferView"), i, "bufferViews")?;
        }
    }
    for (b, view) in arr(&v, "bufferViews").iter().enumerate() {
        if let Some(i) = view.get("buffer") {
            check(format!("bufferViews[{b}].buffer"), i, "buffers")?;
        }
    }
    for (n, node) in arr(&v, "nodes").iter().enumerate() {
        if let Some(i) = node.get("mesh") {
            check(format!("nodes[{n}].mesh"), i, "meshes")?;
        }
        if let Some(i) = node.get("camera") {
            check(format!("nodes[{n}].camera"), i, "cameras")?;
        }
        for (c, child) in arr(node, "children").iter().enumerate() {
            check(format!("nodes[{n}].children[{c}]"), child, "nodes")?;
        }
    }
    for (sc, scene) in arr(&v, "scenes").iter().enumerate() {
        for (k, node) in arr(scene, "nodes").iter().enumerate() {
            check(format!("scenes[{sc}].nodes[{k}]"), node, "nodes")?;
        }
    }
    if let Some(i) = v.get("scene") {
        check("scene".into(), i, "scenes")?;
    }
    Ok(())
}

pub fn load_gltf(path: &Path) -> Result<GltfScene> {
    let shown = path.display().to_string();
    if path.is_dir() {
        return Err(Error::file(&shown, "is a directory; expected a glTF file"));
    }
    let bytes =
        std::fs::read(path).map_err(|e| Error::file(&shown, format!("cannot read: {e}")))?;
    check_gltf_indices(&bytes).map_err(|m| Error::file(&shown, m))?;
    let gltf = gltf::Gltf::from_slice(&bytes)
        .map_err(|e| Error::file(&shown, format!("cannot read glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = gltf::import_buffers(&gltf.document, Some(base), gltf.blob.clone())
        .map_err(|e| Error::file(&shown, format!("cannot load glTF buffers: {e}")))?;
    let doc = &gltf.document;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::file(&shown, "has no scene; expected at least one glTF scene"))?;
    let mut out = GltfScene {
        mesh: Mesh::default(),
        camera: None,
    };
    let mut any_missing_normals = false;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(cam) = node.camera()
            && out.camera.is_none()
        {
            let origin = world.transform_point3(Vec3::ZERO);
            let fwd = world.transform_vector3(Vec3::NEG_Z);
            let up = world.transform_vector3(Vec3::Y);
            let to_world = look_at(origin, origin + fwd, up).ok_or_else(|| {
                Error::file(
                    &shown,
                    format!("camera node {} has a degenerate transform", node.index()),
                )
            })?;
            out.camera = Some(match cam.projection() {
                gltf::camera::Projection::Perspective(p) => GltfCamera::Perspective {
                    to_world,
                    yfov_deg: p.yfov().to_degrees(),
                },
                gltf::camera::Projection::Orthographic(o) => GltfCamera::Orthographic {
                    to_world,
                    xmag: o.xmag(),
                },
            });
        }
        if let Some(mesh) = node.mesh() {
            let normal_m = world.inverse().transpose();
            let mirror = world.determinant() < 0.0;
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let Some(positions) = reader.read_positions() else {
                    continue;
                };
                let base = out.mesh.positions.len() as u32;
                let pos: Vec<Vec3> = positions
                    .map(|p| world.transform_point3(Vec3::from_array(p)))
                    .collect();
                let n = pos.len() as u32;
                match reader.read_normals() {
                    Some(ns) => {
                        let ns: Vec<Vec3> = ns
                            .map(|v| {
                                normal_m
                                    .transform_vector3(Vec3::from_array(v))
                                    .normalize_or_zero()
                            })
                            .collect();
                        if ns.len() == pos.len() {
                            out.mesh.normals.extend(ns);
                        } else {
                            any_missing_normals = true;
                        }
                    }
                    None => any_missing_normals = true,
                }
                let idx: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..n).collect(),
                };
                if !idx.len().is_multiple_of(3) {
                    return Err(Error::file(
                        &shown,
                        format!(
                            "mesh {} has an index count that is not a multiple of 3",
                            mesh.index()
                        ),
                    ));
                }
                if let Some(bad) = idx.iter().find(|&&k| k >= n) {
                    return Err(Error::file(
                        &shown,
                        format!(
                            "mesh {} refers to vertex {bad}, but has {n} vertices",
                            mesh.index()
                        ),
                    ));
                }
                out.mesh.positions.extend(pos);
                out.mesh.indices.extend(idx.chunks(3).map(|c| {
                    if mirror {
                        [c[0] + base, c[2] + base, c[1] + base]
                    } else {
                        [c[0] + base, c[1] + base, c[2] + base]
                    }
                }));
            }
        }
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world));
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
