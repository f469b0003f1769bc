//! Stanford PLY reading (the format of scanned meshes: the Stanford and Georgia Tech
//! scans; Mitsuba 3's and pbrt-v4's `ply` shapes), ASCII and binary of either byte order,
//! through the `ply-rs-bw` crate: the `vertex` element's `x`, `y`, `z` (and `nx`, `ny`, `nz`,
//! and `u`, `v` or `s`, `t` when every vertex has them) and the `face` element's
//! `vertex_indices` (or `vertex_index`) lists, polygons split into fans. Other elements
//! (edges, materials, ...) and properties (colours, confidence) are read past and ignored.
//!
//! Element counts are checked against [`MAX_TRIANGLES`] and against the file's size before
//! anything is read, so a header that announces more than the file holds is an error, not
//! an allocation.

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::limits::MAX_TRIANGLES;
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{ElementDef, Property, PropertyAccess};
use smallvec::SmallVec;

/// One vertex as read: position, normal, texture coordinates, and which were given
/// (bits 1: position x, 2: y, 4: z, 8..32: normal x, y, z, 64, 128: u, v).
#[derive(Default, Clone, Copy)]
struct Vertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    given: u8,
    /// A value that is not a finite number.
    bad: bool,
}

/// A scalar property as f32 (lists are not vertex data).
fn scalar(p: &Property) -> Option<f32> {
    Some(match *p {
        Property::Char(v) => v as f32,
        Property::UChar(v) => v as f32,
        Property::Short(v) => v as f32,
        Property::UShort(v) => v as f32,
        Property::Int(v) => v as f32,
        Property::UInt(v) => v as f32,
        Property::Float(v) => v,
        Property::Double(v) => v as f32,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) {
        let slot = match name {
            "x" => (0, 0),
            "y" => (0, 1),
            "z" => (0, 2),
            "nx" => (1, 0),
            "ny" => (1, 1),
            "nz" => (1, 2),
            "u" | "s" | "texture_u" | "texture_s" => (2, 0),
            "v" | "t" | "texture_v" | "texture_t" => (2, 1),
            _ => return,
        };
        let Some(v) = scalar(&property) else { return };
        self.bad |= !v.is_finite();
        match slot.0 {
            0 => self.p[slot.1] = v,
            1 => self.n[slot.1] = v,
            _ => self.uv[slot.1] = v,
        }
        self.given |= 1 << (3 * slot.0 + slot.1);
    }
}

/// One face as read: its corners' vertex indices (at most [`MAX_CORNERS`]; a triangle's
/// held in place, 32 bytes a face rather than a vector and its allocation), or why not.
#[derive(Default)]
struct Face {
    corners: SmallVec<[u32; 3]>,
    error: Option<FaceError>,
}

/// What is wrong with a face's vertex indices.
#[derive(Clone, Copy)]
enum FaceError {
    NotIntegers,
    TooManyCorners,
    /// A negative index (only signed lists, whose values fit in 32 bits, hold them).
    Negative(i32),
}

/// Corners of one polygon.
const MAX_CORNERS: usize = 1 << 16;

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) {
        if name != "vertex_indices" && name != "vertex_index" {
            return;
        }
        let signed = |v: Vec<i32>| -> std::result::Result<SmallVec<[u32; 3]>, FaceError> {
            v.into_iter()
                .map(|i| u32::try_from(i).map_err(|_| FaceError::Negative(i)))
                .collect()
        };
        let corners: std::result::Result<SmallVec<[u32; 3]>, FaceError> = match property {
            Property::ListChar(v) => signed(v.into_iter().map(i32::from).collect()),
            Property::ListUChar(v) => Ok(v.into_iter().map(u32::from).collect()),
            Property::ListShort(v) => signed(v.into_iter().map(i32::from).collect()),
            Property::ListUShort(v) => Ok(v.into_iter().map(u32::from).collect()),
            Property::ListInt(v) => signed(v),
            Property::ListUInt(v) => Ok(v.into_iter().collect()),
            _ => Err(FaceError::NotIntegers),
        };
        match corners {
            Ok(c) if c.len() > MAX_CORNERS => self.error = Some(FaceError::TooManyCorners),
            Ok(c) => self.corners = c,
            Err(e) => self.error = Some(e),
        }
    }
}

/// Properties of other elements: read past.
struct Ignored;

impl PropertyAccess for Ignored {
    fn new() -> Self {
        Ignored
    }
}

/// The fewest bytes one element of `def` takes (lists: their count; ASCII: a digit and a
/// separator per value).
fn min_bytes(def: &ElementDef, ascii: bool) -> u64 {
    use ply_rs_bw::ply::{PropertyType, ScalarType};
    let size = |t: &ScalarType| match t {
        _ if ascii => 2,
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    def.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) => size(t),
            PropertyType::List(count, _) => size(count),
        })
        .sum::<u64>()
        .max(1)
}

/// Reads a PLY file's bytes as one mesh; `shown` names the file in errors.
pub fn parse(bytes: &[u8], shown: &str) -> Result<Mesh> {
    // The crate's messages span lines; an error is one line.
    let fail = |m: String| Error::file(shown, m.split_whitespace().collect::<Vec<_>>().join(" "));
    let mut reader = std::io::Cursor::new(bytes);
    let header = lobe_materials::guard::third_party("PLY", || {
        Parser::<Ignored>::new().read_header(&mut reader)
    })
    .map_err(fail)?
    .map_err(|e| fail(format!("cannot read the PLY header: {e}")))?;
    let body = bytes.len() as u64 - reader.position();
    let ascii = header.encoding == ply_rs_bw::ply::Encoding::Ascii;
    let (mut vertices, mut faces) = (Vec::new(), Vec::new());
    for (name, def) in &header.elements {
        let limit = match name.as_str() {
            "vertex" => 3 * MAX_TRIANGLES as u64,
            "face" => MAX_TRIANGLES as u64,
            _ => u64::MAX,
        };
        let count = def.count as u64;
        let least = min_bytes(def, ascii);
        if count > limit || count.saturating_mul(least) > body {
            return Err(fail(format!(
                "element \"{name}\": {count} announced, more than {} holds; expected at most {}",
                if count > limit {
                    "lobe reads"
                } else {
                    "the file"
                },
                limit.min(body / least)
            )));
        }
        let read = |what: &str| format!("cannot read element \"{name}\" ({what})");
        match name.as_str() {
            "vertex" => {
                vertices = lobe_materials::guard::third_party("PLY", || {
                    Parser::<Vertex>::new().read_payload_for_element(&mut reader, def, &header)
                })
                .map_err(fail)?
                .map_err(|e| fail(format!("{}: {e}", read("vertices"))))?;
            }
            "face" => {
                faces = lobe_materials::guard::third_party("PLY", || {
                    Parser::<Face>::new().read_payload_for_element(&mut reader, def, &header)
                })
                .map_err(fail)?
                .map_err(|e| fail(format!("{}: {e}", read("faces"))))?;
            }
            _ => {
                lobe_materials::guard::third_party("PLY", || {
                    Parser::<Ignored>::new().read_payload_for_element(&mut reader, def, &header)
                })
                .map_err(fail)?
                .map_err(|e| fail(format!("{}: {e}", read("skipped"))))?;
            }
        }
    }
    mesh(&vertices, &faces).map_err(fail)
}

/// The mesh of the vertices and faces read.
fn mesh(vertices: &[Vertex], faces: &[Face]) -> std::result::Result<Mesh, String> {
    if let Some(k) = vertices.iter().position(|v| v.given & 7 != 7 || v.bad) {
        return Err(format!(
            "vertex {k}: expected finite x, y and z properties{}",
            if vertices[k].bad {
                " (found a value that is not)"
            } else {
                ""
            }
        ));
    }
    let n = vertices.len();
    let mut indices = Vec::with_capacity(faces.len());
    for (k, f) in faces.iter().enumerate() {
        let bad_vertex =
            |v: i64| format!("face {k} refers to vertex {v}, but the file has {n} vertices");
        match f.error {
            Some(FaceError::NotIntegers) => {
                return Err(format!(
                    "face {k}: expected a list of integer vertex indices"
                ));
            }
            Some(FaceError::TooManyCorners) => {
                return Err(format!("face {k}: has more than {MAX_CORNERS} corners"));
            }
            Some(FaceError::Negative(v)) => return Err(bad_vertex(v as i64)),
            None => {}
        }
        if f.corners.len() < 3 {
            return Err(format!(
                "face {k}: expected at least three vertex indices, found {}",
                f.corners.len()
            ));
        }
        if let Some(&bad) = f.corners.iter().find(|&&i| i as usize >= n) {
            return Err(bad_vertex(bad as i64));
        }
        for j in 1..f.corners.len() - 1 {
            indices.push([f.corners[0], f.corners[j], f.corners[j + 1]]);
        }
        if indices.len() > MAX_TRIANGLES {
            return Err(format!(
                "has more than {MAX_TRIANGLES} triangles (after splitting polygons)"
            ));
        }
    }
    let all = |bits: u8| vertices.iter().all(|v| v.given & bits == bits);
    Ok(Mesh {
        positions: vertices.iter().map(|v| Vec3::from(v.p)).collect(),
        normals: if all(0o70) {
            vertices
                .iter()
                .map(|v| Vec3::from(v.n).normalize_or_zero())
                .collect()
        } else {
            Vec::new()
        },
        texcoords: if all(0o300) {
            vertices.iter().map(|v| Vec2::from(v.uv)).collect()
        } else {
            Vec::new()
        },
        indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PLY file of a unit quad (two triangles as one polygon), in `format`.
    pub(crate) fn quad(format: &str) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {format} 1.0\ncomment a quad\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n\
             element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let v = [
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        match format {
            "ascii" => {
                for p in v {
                    out.extend(format!("{} {} {} 0 0 1 255\n", p[0], p[1], p[2]).bytes());
                }
                out.extend(b"4 0 1 2 3\n");
            }
            _ => {
                let big = format == "binary_big_endian";
                let f = |x: f32| {
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                };
                let i = |x: i32| {
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                };
                for p in v {
                    for c in [p[0], p[1], p[2], 0.0, 0.0, 1.0] {
                        out.extend(f(c));
                    }
                    out.push(255);
                }
                out.push(4);
                for k in 0..4 {
                    out.extend(i(k));
                }
            }
        }
        out
    }

    #[test]
    fn ascii_and_binary_files_read_the_same_mesh() {
        for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let m = parse(&quad(format), "q.ply").unwrap_or_else(|e| panic!("{format}: {e}"));
            assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]], "{format}");
            assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0), "{format}");
            assert_eq!(m.normals, vec![Vec3::Z; 4], "{format}");
            assert!(m.texcoords.is_empty());
        }
    }

    /// `binary` (the little-endian quad) with vertex `k`'s y a NaN.
    fn nan_y(binary: &[u8], k: usize) -> Vec<u8> {
        let header = binary.len() - (4 * 25 + 1 + 16);
        let mut out = binary.to_vec();
        let at = header + 25 * k + 4;
        out[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        out
    }

    #[test]
    fn a_face_as_read_takes_32_bytes() {
        // 4M faces of a scan held at once while the file is read.
        assert!(
            std::mem::size_of::<Face>() <= 32,
            "{}",
            std::mem::size_of::<Face>()
        );
    }

    #[test]
    fn broken_files_are_errors_naming_what_is_wrong() {
        let ascii = String::from_utf8(quad("ascii")).unwrap();
        let binary = quad("binary_little_endian");
        for (bytes, needle) in [
            (b"not a ply file".to_vec(), "cannot read the PLY header"),
            (
                ascii.replace("4 0 1 2 3", "4 0 1 2 9").into_bytes(),
                "face 0 refers to vertex 9",
            ),
            (
                ascii.replace("4 0 1 2 3", "4 0 1 -2 3").into_bytes(),
                "face 0 refers to vertex -2",
            ),
            (
                ascii.replace("4 0 1 2 3", "2 0 1").into_bytes(),
                "face 0: expected at least three",
            ),
            (
                ascii
                    .replace("element vertex 4", "element vertex 4000000000")
                    .into_bytes(),
                "element \"vertex\"",
            ),
            (
                ascii
                    .replace("property float z\n", "")
                    .replace(" 0 0 1 255", " 0 1 255")
                    .into_bytes(),
                "expected finite x, y and z",
            ),
            (
                ascii.replace("1 1 0 0 0 1", "1 x 0 0 0 1").into_bytes(),
                "cannot read element \"vertex\"",
            ),
            (nan_y(&binary, 2), "vertex 2: expected finite x, y and z"),
            (
                binary[..binary.len() - 3].to_vec(),
                "cannot read element \"face\"",
            ),
        ] {
            let e = parse(&bytes, "q.ply").unwrap_err().to_string();
            assert!(
                e.starts_with("q.ply") && e.contains(needle),
                "{needle}: {e}"
            );
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }
}
