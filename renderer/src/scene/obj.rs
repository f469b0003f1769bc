//! Wavefront OBJ reading (the `v`, `vt`, `vn` and `f` statements of the format's polygon
//! subset, as Mitsuba 3 and pbrt-v4 read it): all objects and groups of a file as one
//! triangle mesh, polygons split into fans, 1-based and negative (relative) indices, and
//! per-corner position/texture/normal triplets turned into shared vertices. Everything
//! else (`o`, `g`, `s`, `usemtl`, `mtllib`, points, lines, free-form geometry) is ignored:
//! lobe's materials come from the scene file.
//!
//! The file is parsed in parallel: it is cut at line ends into chunks that are parsed
//! independently (each records its own counts of `v`, `vt` and `vn`, so that relative
//! indices are resolved once the counts before it are known), then joined in file order.
//! A mesh whose faces name positions only (the common form of scanned meshes) keeps its
//! positions as its vertices and its face indices as they are, with no per-corner table.

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::limits::MAX_TRIANGLES;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A corner's index that the file did not give (`v` or `v//vn` has no texture index).
const ABSENT: u32 = u32::MAX;

/// What one chunk of the file holds.
#[derive(Default)]
struct Chunk {
    positions: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// Triangle corners (three per triangle): position, texture and normal indices,
    /// 0-based in the whole file, or [`ABSENT`]; `tex` and `nrm` stay empty while no face
    /// of the chunk has them.
    pos: Vec<u32>,
    tex: Vec<u32>,
    nrm: Vec<u32>,
    /// Relative (negative) indices: (attribute, corner, index relative to the chunk's
    /// first element of that attribute), resolved once the counts before the chunk are
    /// known.
    relative: Vec<(u8, u32, i64)>,
    /// Lines in the chunk.
    lines: usize,
    /// The first error: (line within the chunk, 0-based; message).
    error: Option<(usize, String)>,
    /// The corners of the face being read.
    scratch: Vec<[Index; 3]>,
    /// The file's triangles passed [`MAX_TRIANGLES`] while this chunk was read.
    too_many: bool,
}

/// Reads an OBJ file's bytes as one mesh; `shown` names the file in errors.
pub fn parse(bytes: &[u8], shown: &str) -> Result<Mesh> {
    let triangles = AtomicUsize::new(0);
    let chunks: Vec<Chunk> = split(bytes, rayon::current_num_threads() * 4)
        .into_par_iter()
        .map(|text| parse_chunk(text, &triangles))
        .collect();
    if chunks.iter().any(|c| c.too_many) {
        return Err(Error::file(shown, too_many_triangles()));
    }
    let mut lines_before = 0;
    for c in &chunks {
        if let Some((line, message)) = &c.error {
            return Err(Error::file(
                shown,
                format!("line {}: {message}", lines_before + line + 1),
            ));
        }
        lines_before += c.lines;
    }
    join(chunks).map_err(|m| Error::file(shown, m))
}

/// `bytes` cut at line ends into about `n` pieces.
fn split(bytes: &[u8], n: usize) -> Vec<&[u8]> {
    let target = (bytes.len() / n.max(1)).max(1 << 16);
    let mut out = Vec::new();
    let mut rest = bytes;
    while rest.len() > target {
        match memchr::memchr(b'\n', &rest[target..]) {
            Some(k) => {
                let (a, b) = rest.split_at(target + k + 1);
                out.push(a);
                rest = b;
            }
            None => break,
        }
    }
    out.push(rest);
    out
}

/// The error of a file beyond [`MAX_TRIANGLES`].
fn too_many_triangles() -> String {
    format!(
        "has more than {MAX_TRIANGLES} triangles (after splitting polygons); expected at most that"
    )
}

/// Parses one chunk, adding its triangles to the file's count `triangles` as it goes, so
/// that every chunk stops once the file is past [`MAX_TRIANGLES`] (a polygon's fan makes
/// six times as many bytes of corners as the file spends on it).
fn parse_chunk(text: &[u8], triangles: &AtomicUsize) -> Chunk {
    let mut c = Chunk::default();
    let mut counted = 0;
    for (k, line) in text.split(|&b| b == b'\n').enumerate() {
        c.lines = k + 1;
        if let Err(m) = c.statement(line) {
            c.error = Some((k, m));
            return c;
        }
        let added = c.pos.len() / 3 - counted;
        if added >= 1 << 12 {
            counted += added;
            if triangles.fetch_add(added, Ordering::Relaxed) + added > MAX_TRIANGLES {
                c.too_many = true;
                return c;
            }
        }
    }
    // A final line end makes an empty last piece, which is not a line of its own.
    if text.last() == Some(&b'\n') {
        c.lines -= 1;
    }
    c
}

/// The whitespace-separated words of a line.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
}

fn number(word: Option<&[u8]>, what: &str) -> std::result::Result<f32, String> {
    let w = word.ok_or_else(|| format!("expected {what}, found the end of the line"))?;
    let v: f32 = std::str::from_utf8(w)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("expected {what}, found \"{}\"", String::from_utf8_lossy(w)))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("expected {what}, found {v}"))
    }
}

/// Three numbers of a line.
fn vec3<'a>(
    words: &mut impl Iterator<Item = &'a [u8]>,
    what: &str,
) -> std::result::Result<Vec3, String> {
    Ok(Vec3::new(
        number(words.next(), what)?,
        number(words.next(), what)?,
        number(words.next(), what)?,
    ))
}

/// A face index: a non-zero integer (1-based, or negative: counted back from the last
/// element read so far).
fn index(w: &[u8]) -> std::result::Result<i64, String> {
    let bad = || {
        format!(
            "expected a face index (a non-zero integer), found \"{}\"",
            String::from_utf8_lossy(w)
        )
    };
    let (neg, digits) = match w.first() {
        Some(b'-') => (true, &w[1..]),
        Some(b'+') => (false, &w[1..]),
        _ => (false, w),
    };
    if digits.is_empty() || digits.len() > 12 || !digits.iter().all(u8::is_ascii_digit) {
        return Err(bad());
    }
    let v = digits
        .iter()
        .fold(0i64, |v, &d| v * 10 + i64::from(d - b'0'));
    match (v, neg) {
        (0, _) => Err(bad()),
        (v, true) => Ok(-v),
        (v, false) => Ok(v),
    }
}

/// A corner's index as read: 0-based in the file, or relative to the chunk's first
/// element of its attribute (from a negative index), or not given.
#[derive(Clone, Copy)]
enum Index {
    File(u32),
    Chunk(i64),
    Absent,
}

impl Chunk {
    fn statement(&mut self, line: &[u8]) -> std::result::Result<(), String> {
        let mut w = words(line);
        let head = w.next();
        if head.is_some_and(|h| h[0] != b'#') && line.trim_ascii_end().ends_with(b"\\") {
            return Err("line continuations (a final \\) are not supported".into());
        }
        match head {
            Some(b"v") => self
                .positions
                .push(vec3(&mut w, "three coordinates after v")?),
            Some(b"vn") => self
                .normals
                .push(vec3(&mut w, "three components after vn")?),
            Some(b"vt") => {
                let u = number(w.next(), "a texture coordinate after vt")?;
                let v = match w.next() {
                    Some(v) => number(Some(v), "a second texture coordinate")?,
                    None => 0.0,
                };
                self.texcoords.push(Vec2::new(u, v));
            }
            Some(b"f") => self.face(w)?,
            _ => {}
        }
        Ok(())
    }

    /// One corner `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn corner(&self, word: &[u8]) -> std::result::Result<[Index; 3], String> {
        let mut parts = word.split(|&b| b == b'/');
        let counts = [
            self.positions.len(),
            self.texcoords.len(),
            self.normals.len(),
        ];
        let mut corner = [Index::Absent; 3];
        for (attr, slot) in corner.iter_mut().enumerate() {
            match parts.next() {
                Some(p) if !p.is_empty() => {
                    let i = index(p)?;
                    *slot = if i > 0 {
                        Index::File(
                            u32::try_from(i - 1)
                                .map_err(|_| format!("face index {i} is too large"))?,
                        )
                    } else {
                        Index::Chunk(counts[attr] as i64 + i)
                    };
                }
                Some(_) if attr == 0 => return Err("a face corner without a vertex index".into()),
                _ => {}
            }
        }
        if parts.next().is_some() {
            return Err(format!(
                "expected a face corner v, v/vt, v//vn or v/vt/vn, found \"{}\"",
                String::from_utf8_lossy(word)
            ));
        }
        Ok(corner)
    }

    /// One polygon, split into a fan of triangles about its first corner.
    fn face<'a>(
        &mut self,
        words: impl Iterator<Item = &'a [u8]>,
    ) -> std::result::Result<(), String> {
        let mut corners = std::mem::take(&mut self.scratch);
        corners.clear();
        for word in words {
            corners.push(self.corner(word)?);
        }
        if corners.len() < 3 {
            return Err(format!(
                "expected a face of at least three corners, found {}",
                corners.len()
            ));
        }
        for k in 1..corners.len() - 1 {
            for c in [corners[0], corners[k], corners[k + 1]] {
                self.push_corner(c);
            }
        }
        self.scratch = corners;
        Ok(())
    }

    fn push_corner(&mut self, c: [Index; 3]) {
        let n = self.pos.len();
        for (attr, index) in c.into_iter().enumerate() {
            let v = match index {
                Index::File(v) => v,
                Index::Chunk(rel) => {
                    self.relative.push((attr as u8, n as u32, rel));
                    ABSENT
                }
                Index::Absent => ABSENT,
            };
            let list = match attr {
                0 => &mut self.pos,
                1 => &mut self.tex,
                _ => &mut self.nrm,
            };
            if attr > 0 && list.is_empty() {
                if matches!(index, Index::Absent) {
                    continue;
                }
                list.resize(n, ABSENT);
            }
            list.push(v);
        }
    }
}

/// The chunks' data in file order as one mesh, every index resolved and checked.
fn join(chunks: Vec<Chunk>) -> std::result::Result<Mesh, String> {
    let tris: usize = chunks.iter().map(|c| c.pos.len() / 3).sum();
    if tris > MAX_TRIANGLES {
        return Err(too_many_triangles());
    }
    let with_attributes = chunks
        .iter()
        .any(|c| !c.tex.is_empty() || !c.nrm.is_empty());
    let mut positions = Vec::with_capacity(chunks.iter().map(|c| c.positions.len()).sum());
    let mut texcoords = Vec::new();
    let mut normals = Vec::new();
    let mut corners: [Vec<u32>; 3] = [Vec::with_capacity(3 * tris), Vec::new(), Vec::new()];
    for c in chunks {
        let before = [positions.len(), texcoords.len(), normals.len()];
        let first = corners[0].len();
        corners[0].extend_from_slice(&c.pos);
        if with_attributes {
            for (a, list) in [(1, &c.tex), (2, &c.nrm)] {
                if list.is_empty() {
                    corners[a].resize(first + c.pos.len(), ABSENT);
                } else {
                    corners[a].extend_from_slice(list);
                }
            }
        }
        for &(attr, corner, rel) in &c.relative {
            let v = before[attr as usize] as i64 + rel;
            let slot = &mut corners[attr as usize][first + corner as usize];
            *slot = u32::try_from(v).map_err(|_| {
                format!(
                    "a relative face index points before the first {} of the file",
                    ["vertex", "texture coordinate", "normal"][attr as usize]
                )
            })?;
        }
        positions.extend_from_slice(&c.positions);
        texcoords.extend_from_slice(&c.texcoords);
        normals.extend_from_slice(&c.normals);
    }
    let counts = [positions.len(), texcoords.len(), normals.len()];
    for (attr, list) in corners.iter().enumerate() {
        if let Some(k) = list
            .par_iter()
            .position_first(|&v| v != ABSENT && v as usize >= counts[attr])
        {
            let what = ["vertex", "texture coordinate", "normal"][attr];
            return Err(format!(
                "triangle {} refers to {what} {}, but the file has {} (indices start at 1)",
                k / 3,
                list[k] as u64 + 1,
                counts[attr]
            ));
        }
    }
    if !with_attributes {
        return Ok(Mesh {
            positions,
            normals: Vec::new(),
            texcoords: Vec::new(),
            indices: corners[0]
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
        });
    }
    Ok(shared_vertices(
        &corners,
        (&positions, &texcoords, &normals),
    ))
}

/// A mesh of one vertex per distinct (position, texture, normal) triplet of the corners,
/// in order of first use. Normals and texture coordinates are kept only when every vertex
/// has one.
fn shared_vertices(corners: &[Vec<u32>; 3], (pos, tex, nrm): (&[Vec3], &[Vec2], &[Vec3])) -> Mesh {
    let mut ids: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut mesh = Mesh::default();
    let (mut all_tex, mut all_nrm) = (true, true);
    let mut flat = Vec::with_capacity(corners[0].len());
    let keys = corners[0]
        .iter()
        .zip(&corners[1])
        .zip(&corners[2])
        .map(|((&p, &t), &n)| [p, t, n]);
    for key in keys {
        let id = *ids.entry(key).or_insert_with(|| {
            mesh.positions.push(pos[key[0] as usize]);
            all_tex &= key[1] != ABSENT;
            all_nrm &= key[2] != ABSENT;
            mesh.texcoords
                .push(tex.get(key[1] as usize).copied().unwrap_or(Vec2::ZERO));
            mesh.normals.push(
                nrm.get(key[2] as usize)
                    .map_or(Vec3::ZERO, |n| n.normalize_or_zero()),
            );
            (mesh.positions.len() - 1) as u32
        });
        flat.push(id);
    }
    if !all_tex {
        mesh.texcoords.clear();
    }
    if !all_nrm {
        mesh.normals.clear();
    }
    mesh.indices = flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(text: &str) -> Mesh {
        parse(text.as_bytes(), "t.obj").unwrap_or_else(|e| panic!("{e}"))
    }

    fn error(text: &str) -> String {
        parse(text.as_bytes(), "t.obj").unwrap_err().to_string()
    }

    #[test]
    fn positions_only_faces_keep_the_file_s_vertices() {
        let m = mesh("# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.normals.is_empty() && m.texcoords.is_empty());
    }

    #[test]
    fn relative_indices_count_back_from_the_last_vertex_read() {
        let m = mesh("v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\nv 0 1 0\nf 1 -2 -1\n");
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn corner_triplets_become_shared_vertices() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 2\n\
                    f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 2/2/-1\n";
        let m = mesh(text);
        assert_eq!(m.positions.len(), 3);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 1]]);
        assert_eq!(m.normals, vec![Vec3::Z; 3]);
        assert_eq!(m.texcoords[2], Vec2::new(1.0, 1.0));
        // The same position with two normals is two vertices; a corner without a normal
        // drops the normals of the mesh.
        let m = mesh(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nvn 0 1 0\nf 1//1 2//1 3//1\nf 1//2 3//2 2\n",
        );
        assert_eq!(m.positions.len(), 6);
        assert!(m.normals.is_empty());
    }

    #[test]
    fn chunks_join_in_file_order_with_relative_indices_across_them() {
        // Enough lines for several chunks; every face refers back across chunk ends.
        let mut text = String::from("v 0 0 0\nv 1 0 0\n");
        for k in 0..60_000 {
            text += &format!("v {k} 1 0\nf -3 -2 -1\nf 1 2 {}\n", k + 3);
        }
        let m = mesh(&text);
        assert_eq!(m.positions.len(), 60_002);
        assert_eq!(m.indices.len(), 120_000);
        for k in 0..60_000u32 {
            assert_eq!(m.indices[2 * k as usize], [k, k + 1, k + 2]);
            assert_eq!(m.indices[2 * k as usize + 1], [0, 1, k + 2]);
        }
        assert!(split(text.as_bytes(), 8).len() > 1);
    }

    #[test]
    fn mistakes_name_the_line() {
        for (text, needle) in [
            (
                "v 0 0\n",
                "line 1: expected three coordinates after v, found the end",
            ),
            (
                "v 0 0 0\nv 0 x 0\n",
                "line 2: expected three coordinates after v, found \"x\"",
            ),
            (
                "v 0 0 0\nv 1e39 0 0\n",
                "line 2: expected three coordinates after v, found inf",
            ),
            (
                "v 0 0 0\nf 1 1\n",
                "line 2: expected a face of at least three corners, found 2",
            ),
            (
                "v 0 0 0\nf 1 0 1\n",
                "line 2: expected a face index (a non-zero integer), found \"0\"",
            ),
            (
                "v 0 0 0\nf 1/2/3/4 1 1\n",
                "expected a face corner v, v/vt, v//vn or v/vt/vn",
            ),
            (
                "v 0 0 0\nf 1 1 2\n",
                "triangle 0 refers to vertex 2, but the file has 1",
            ),
            ("v 0 0 0\nf -2 1 1\n", "points before the first vertex"),
            ("v 0 0 0\nf 1/5 1 1\n", "refers to texture coordinate 5"),
            ("v 0 0 \\\n 0\n", "line 1: line continuations"),
        ] {
            let e = error(text);
            assert!(
                e.contains(needle) && e.starts_with("t.obj"),
                "{text:?}: {e}"
            );
        }
    }
}
