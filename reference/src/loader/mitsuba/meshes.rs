//! Mitsuba 3's mesh files: what the `obj`, `ply` and `serialized` shape
//! plugins read, with Mitsuba's meaning.
//!
//! Provenance: every rule below was read from Mitsuba 3.9.1 (tag `v3.9.1`
//! of mitsuba-renderer/mitsuba3): `src/shapes/obj.cpp`, `src/shapes/ply.cpp`,
//! `src/shapes/ply.h`, `src/shapes/serialized.cpp` and
//! `Mesh::recompute_vertex_normals` in `src/render/mesh.cpp`, and checked
//! against the `mitsuba==3.9.1` Python package (variant `scalar_rgb`). The
//! file formats are parsed by the field's crates: OBJ by `tobj`, PLY by
//! `ply-rs-bw`, the zlib stream of `.serialized` files by `flate2`.
//!
//! What Mitsuba does and these readers do too:
//! - Positions, normals and texture coordinates are `f32` (Mitsuba's
//!   `InputFloat`); double-precision data is rounded to `f32`.
//! - Normals read from a file are normalized (`dr::normalize` in each
//!   plugin).
//! - Without normals in the file and without `face_normals`, vertex normals
//!   are computed as [`vertex_normals`] does (Mitsuba's
//!   `recompute_vertex_normals`). With `face_normals`, a mesh has no vertex
//!   normals at all, whatever the file holds.
//! - Degenerate triangles are kept.
//!
//! Where these readers knowingly differ from Mitsuba 3.9.1, it is to refuse
//! what Mitsuba would read as garbage or to accept more:
//! - A face index out of range is an error (Mitsuba's PLY and serialized
//!   readers keep it, and render from out-of-bounds memory).
//! - OBJ: relative (negative) indices are resolved as the OBJ format says
//!   (Mitsuba 3.9.1 rejects them). Texture coordinates or normals that a
//!   face corner lacks while others have them are (0, 0) and the computed
//!   normal (Mitsuba leaves them uninitialized); `vt`/`vn` lines that no
//!   face uses give no texture coordinates and computed normals (the same).
//! - PLY: faces with more than 3 vertices are fanned (Mitsuba 3.9.1 reads
//!   only triangles); faces with fewer than 3 are skipped.
//! - PLY and serialized: a file normal of zero length is replaced by the
//!   computed normal (Mitsuba stores NaN); a non-finite position is an error
//!   in all three formats (Mitsuba checks only OBJ and PLY).
//! - PLY through ply-rs-bw: an ASCII record must sit on one line (Mitsuba
//!   reads a stream of words); Mitsuba's extra types `long`, `ulong`, `half`
//!   and `float16` are not read; the format version is not checked.
//!
//! PLY vertex and face properties beyond those are grouped into attributes
//! as Mitsuba groups them ([`ply_attributes`]), for `mesh_attribute`.
//!
//! Not read at all: the serialized shape name and vertex colors
//! (skipped), and the plugins' `to_world` and `flip_normals` (the
//! caller's business).

use glam::{Vec2, Vec3};
use std::fmt::Display;
use std::io::Read;
use std::path::Path;

/// An indexed triangle mesh as a file holds it, in the file's coordinates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<glam::Vec3>,
    /// Per-vertex normals (from the file, or computed: see [`vertex_normals`]);
    /// None when face normals are asked for.
    pub normals: Option<Vec<glam::Vec3>>,
    /// Per-vertex texture coordinates, v as Mitsuba's shape would report it
    /// after its flip_tex_coords handling.
    pub uvs: Option<Vec<glam::Vec2>>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// The PLY file's other vertex and face properties, grouped into
    /// attributes as Mitsuba's `ply` groups them ([`ply_attributes`]);
    /// none for the other formats.
    pub attributes: Vec<Attribute>,
}

/// A mesh attribute (what Mitsuba's `mesh_attribute` texture reads): its
/// name (`vertex_…` or `face_…`), its channels (1, 3 or, for a colour
/// with alpha, 4) and its values, `channels` a vertex, or a triangle for
/// a face attribute (a polygon's value repeated on each triangle of its
/// fan).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attribute {
    pub name: String,
    pub channels: usize,
    pub values: Vec<f32>,
}

impl Attribute {
    /// Whether it is a face attribute (one value a triangle).
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }
}

/// How Mitsuba's `ply` groups the properties of an element (`kind`
/// "vertex_" or "face_") that it reads otherwise into attributes (its
/// ply.h `find_other_fields`): `r`, `g`, `b` (and `a`), or `red`,
/// `green`, `blue` (and `alpha`), are `{kind}color`; then consecutive
/// properties `{prefix}_{c}` whose one-letter postfixes run through one of
/// the series x y z w, r g b a, 0 1 2 3, 1 2 3 4 are `{kind}{prefix}`
/// (`{kind}{prefix}_color` for r g b), kept where they have 1 or 3
/// channels. Properties without such a postfix, a prefix met a second
/// time, and a broken series are left out, as Mitsuba leaves them (with a
/// warning); after a broken series Mitsuba's loop also drops the next
/// property and may keep a one-field remnant, which this does not copy.
/// Returns each attribute's name and its properties' names.
pub fn ply_attributes(
    kind: &str,
    properties: &[&str],
    reserved: &[&str],
) -> Vec<(String, Vec<String>)> {
    let has = |n: &str| properties.contains(&n);
    let mut out = Vec::new();
    let mut colour_names: &[&str] = &[];
    if has("r") && has("g") && has("b") {
        colour_names = &["r", "g", "b", "a"];
    } else if has("red") && has("green") && has("blue") {
        colour_names = &["red", "green", "blue", "alpha"];
    }
    if !colour_names.is_empty() {
        let fields: Vec<String> = colour_names
            .iter()
            .filter(|n| has(n))
            .map(|n| n.to_string())
            .collect();
        out.push((format!("{kind}color"), fields));
    }
    const SERIES: [&str; 4] = ["xyzw", "rgba", "0123", "1234"];
    let mut seen: Vec<&str> = Vec::new();
    // The attribute being read: its prefix, its series, its fields.
    let mut current: Option<(&str, usize, Vec<String>)> = None;
    #[allow(clippy::type_complexity)]
    fn flush<'a>(
        kind: &str,
        current: &mut Option<(&'a str, usize, Vec<String>)>,
        seen: &mut Vec<&'a str>,
        out: &mut Vec<(String, Vec<String>)>,
    ) {
        if let Some((prefix, series, fields)) = current.take() {
            if fields.len() == 1 || fields.len() == 3 {
                let colour = if series == 1 { "_color" } else { "" };
                out.push((format!("{kind}{prefix}{colour}"), fields));
            }
            seen.push(prefix);
        }
    }
    let mut skip_prefix: Option<&str> = None;
    for &name in properties {
        if reserved.contains(&name)
            || ["r", "g", "b", "a"].contains(&name)
            || colour_names.contains(&name)
        {
            continue;
        }
        let Some((prefix, postfix)) = name.rsplit_once('_') else {
            flush(kind, &mut current, &mut seen, &mut out);
            continue;
        };
        if skip_prefix == Some(prefix) {
            continue;
        }
        skip_prefix = None;
        let mut chars = postfix.chars();
        let (Some(c), None) = (chars.next(), chars.next()) else {
            flush(kind, &mut current, &mut seen, &mut out);
            continue;
        };
        if current.as_ref().is_some_and(|(p, _, _)| *p != prefix) {
            flush(kind, &mut current, &mut seen, &mut out);
        }
        match &mut current {
            None => {
                if seen.contains(&prefix) {
                    skip_prefix = Some(prefix);
                    continue;
                }
                if let Some(series) = SERIES.iter().position(|s| s.starts_with(c)) {
                    current = Some((prefix, series, vec![name.to_string()]));
                }
            }
            Some((_, series, fields)) => {
                if SERIES[*series].chars().nth(fields.len()) == Some(c) {
                    fields.push(name.to_string());
                } else {
                    // A broken series: the attribute is left out.
                    current = None;
                    seen.push(prefix);
                    skip_prefix = Some(prefix);
                }
            }
        }
    }
    flush(kind, &mut current, &mut seen, &mut out);
    out
}

/// The shape plugin parameters that change what a mesh file means.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshOptions {
    /// Mitsuba's `face_normals` (all three plugins; default false): no vertex
    /// normals, neither the file's nor computed ones.
    pub face_normals: bool,
    /// Mitsuba's `flip_tex_coords` (v becomes 1 - v). None: the plugin's
    /// default, true for `obj` and false for `ply`. The `serialized` plugin
    /// has no such parameter (Mitsuba rejects it as unreferenced), so
    /// [`read_serialized`] refuses Some.
    pub flip_tex_coords: Option<bool>,
    /// Mitsuba's `shape_index` (`serialized` only; default 0): which of the
    /// file's meshes to read.
    pub shape_index: u32,
}

/// Reads a Wavefront OBJ file as Mitsuba's `obj` shape does.
///
/// Only `v`, `vt`, `vn` and `f` lines matter; objects, groups, materials,
/// smoothing groups, lines and points are ignored, so the whole file is one
/// mesh. A vertex is a distinct (position, texture coordinate, normal) index
/// triple, numbered in the order faces first use it; polygons are fanned
/// around their first vertex. `flip_tex_coords` defaults to true.
pub fn read_obj(path: &Path, opts: &MeshOptions) -> Result<Mesh, String> {
    parse_obj(&read_file(path)?, opts)
}

/// Reads a Stanford PLY file (ASCII, binary little or big endian) as
/// Mitsuba's `ply` shape does. `flip_tex_coords` defaults to false.
///
/// The `vertex` element's `x`, `y`, `z` are required; `nx`, `ny`, `nz` are
/// used when all three are present; texture coordinates are `u`, `v`, else
/// `texture_u`, `texture_v`, else `s`, `t` (Mitsuba's order; it does not read
/// `texture_s`/`texture_t`). The `face` element's `vertex_index`, else
/// `vertex_indices`, list gives the faces. Other properties and elements
/// (colors, attributes) are ignored.
pub fn read_ply(path: &Path, opts: &MeshOptions) -> Result<Mesh, String> {
    parse_ply(&read_file(path)?, opts)
}

/// Reads one mesh of a Mitsuba `.serialized` file (format versions 3 and 4)
/// as Mitsuba's `serialized` shape does: the one `opts.shape_index` selects.
/// Texture coordinates are never flipped.
pub fn read_serialized(path: &Path, opts: &MeshOptions) -> Result<Mesh, String> {
    parse_serialized(&read_file(path)?, opts)
}

/// A grid of one channel of f32 samples read from a Mitsuba `.vol` file
/// (as its `sdfgrid` reads it): samples per axis and the values, x
/// fastest, then y, then z. The header's bounding box is ignored, as
/// Mitsuba's `sdfgrid` ignores it.
#[derive(Clone, Debug, PartialEq)]
pub struct VolGrid {
    pub dims: [u32; 3],
    pub values: Vec<f32>,
}

/// Reads a `.vol` grid file: `VOL`, version 3, encoding 1 (f32), the
/// three sizes and the channel count (i32, little endian), six f32 of
/// bounding box, then the samples.
pub fn read_vol(path: &Path) -> Result<VolGrid, String> {
    parse_vol(&read_file(path)?)
}

/// [`read_vol`] of a file's bytes.
pub fn parse_vol(b: &[u8]) -> Result<VolGrid, String> {
    if b.len() < 48 || &b[..3] != b"VOL" {
        return Err("not a .vol grid (no \"VOL\" header)".into());
    }
    if b[3] != 3 {
        return Err(format!("a .vol of version {}, not 3", b[3]));
    }
    let int = |at: usize| i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
    if int(4) != 1 {
        return Err(format!("a .vol of encoding {}, not 1 (float32)", int(4)));
    }
    let (nx, ny, nz, channels) = (int(8), int(12), int(16), int(20));
    if channels != 1 {
        return Err(format!("{channels} channels; an sdfgrid takes 1"));
    }
    let dims = [nx, ny, nz].map(|n| u32::try_from(n).unwrap_or(0));
    if dims.contains(&0) {
        return Err(format!("sizes {nx} x {ny} x {nz}"));
    }
    let count = dims
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n as usize));
    let need = count
        .and_then(|c| c.checked_mul(4))
        .and_then(|n| n.checked_add(48));
    match need {
        Some(n) if n <= b.len() => {}
        _ => {
            return Err(format!(
                "{nx} x {ny} x {nz} samples, more than the file holds"
            ))
        }
    }
    let values = b[48..need.unwrap_or(48)]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok(VolGrid { dims, values })
}

fn read_file(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))
}

/// One line, at most this many characters, for messages that quote a
/// library's error (ply-rs-bw's quote the offending line). Our own choice.
const MAX_QUOTED_ERROR: usize = 200;

fn one_line(msg: impl Display) -> String {
    let text = msg.to_string();
    let mut out = String::new();
    for word in text.split_whitespace() {
        if !out.is_empty() {
            out.push(' ');
        }
        out.push_str(word);
    }
    if out.chars().count() > MAX_QUOTED_ERROR {
        out = out.chars().take(MAX_QUOTED_ERROR).collect::<String>() + "...";
    }
    out
}

// ---------------------------------------------------------------------------
// Vertex normals and the common last step
// ---------------------------------------------------------------------------

/// Vertex normals as Mitsuba's `Mesh::recompute_vertex_normals` computes
/// them (scalar variants, `src/render/mesh.cpp`): the weighting of Thürmer
/// and Wüthrich, "Computing Vertex Normals from Polygonal Facets" (JGT
/// 1998). Each triangle adds its unit normal, oriented by the right-hand
/// rule on its index order, times its angle at the vertex; degenerate
/// triangles (zero cross product) add nothing. The sums are normalized; a
/// vertex that gets nothing has the normal (1, 0, 0), Mitsuba's "bogus
/// value". Computed in `f32` in triangle order, as Mitsuba does. Triangles
/// with an index out of range are skipped.
pub fn vertex_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let corner = |k: usize| positions.get(tri[k] as usize).copied();
        let (Some(v0), Some(v1), Some(v2)) = (corner(0), corner(1), corner(2)) else {
            continue;
        };
        let side_0 = v1 - v0;
        let side_1 = v2 - v0;
        let n = side_0.cross(side_1);
        let length_sqr = n.length_squared();
        // `likely(length_sqr > 0)`: false for degenerate triangles (and NaN).
        if length_sqr > 0.0 {
            let n = n * (1.0 / length_sqr.sqrt());
            // The angle at each corner between its two outgoing edges, in
            // Mitsuba's operand order.
            let angles = [
                unit_angle(normalize(side_0), normalize(side_1)),
                unit_angle(normalize(v2 - v1), normalize(v0 - v1)),
                unit_angle(normalize(v0 - v2), normalize(v1 - v2)),
            ];
            for (k, angle) in angles.into_iter().enumerate() {
                // Finite unless an edge underflows to zero length while the
                // cross product does not; Mitsuba would spread a NaN.
                if angle.is_finite() {
                    sums[tri[k] as usize] += n * angle;
                }
            }
        }
    }
    sums.into_iter()
        .map(|n| {
            let length = n.length();
            if length != 0.0 {
                n / length
            } else {
                // mesh.cpp: "Choose some bogus value".
                Vec3::X
            }
        })
        .collect()
}

/// `dr::normalize`: the vector times the reciprocal of its length.
fn normalize(v: Vec3) -> Vec3 {
    v * (1.0 / v.length_squared().sqrt())
}

/// Dr.Jit's `unit_angle` (`drjit/sphere.h`): the angle between two unit
/// vectors, by the numerically robust half-chord formula.
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    let dot = a.dot(b);
    if dot >= 0.0 {
        2.0 * (0.5 * (b - a).length()).min(1.0).asin()
    } else {
        std::f32::consts::PI - 2.0 * (0.5 * (b + a).length()).min(1.0).asin()
    }
}

/// The step all three readers end with: checks positions and indices,
/// normalizes the file's normals (a NaN normal marks one to compute), or
/// computes them, or drops them for face normals.
fn finish(
    positions: Vec<Vec3>,
    file_normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<u32>,
    face_normals: bool,
) -> Result<Mesh, String> {
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("vertex {i} has a non-finite position"));
    }
    let count = positions.len();
    if let Some((k, &i)) = indices
        .iter()
        .enumerate()
        .find(|(_, &i)| i as usize >= count)
    {
        return Err(format!(
            "triangle {}: vertex index {i} out of range ({count} vertices)",
            k / 3
        ));
    }
    let normals = if face_normals {
        None
    } else {
        match file_normals {
            Some(mut normals) => {
                for n in &mut normals {
                    *n = normalize(*n);
                }
                if normals.iter().any(|n| !n.is_finite()) {
                    let computed = vertex_normals(&positions, &indices);
                    for (n, c) in normals.iter_mut().zip(computed) {
                        if !n.is_finite() {
                            *n = c;
                        }
                    }
                }
                Some(normals)
            }
            None => Some(vertex_normals(&positions, &indices)),
        }
    };
    Ok(Mesh {
        positions,
        normals,
        uvs,
        indices,
        attributes: Vec::new(),
    })
}

fn flip_v(uvs: &mut [Vec2], flip: bool) {
    if flip {
        for uv in uvs {
            uv.y = 1.0 - uv.y;
        }
    }
}

// ---------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------

/// obj.cpp: `props.get<bool>("flip_tex_coords", true)`.
const OBJ_FLIP_DEFAULT: bool = true;

/// The lines of an OBJ file that Mitsuba reads: after leading blanks
/// (" \t\r"), the keyword followed by a space or a tab (obj.cpp).
enum ObjLine<'a> {
    V(&'a str),
    Vt(&'a str),
    Vn(&'a str),
    F(&'a str),
    Other,
}

fn classify(line: &str) -> ObjLine<'_> {
    let s = line.trim_start_matches([' ', '\t', '\r']);
    let after = |keyword: &str| {
        s.strip_prefix(keyword)
            .filter(|rest| rest.starts_with([' ', '\t']))
    };
    if let Some(rest) = after("v") {
        ObjLine::V(rest)
    } else if let Some(rest) = after("vt") {
        ObjLine::Vt(rest)
    } else if let Some(rest) = after("vn") {
        ObjLine::Vn(rest)
    } else if let Some(rest) = after("f") {
        ObjLine::F(rest)
    } else {
        ObjLine::Other
    }
}

/// The first `N` numbers of a `v`, `vt` or `vn` line (Mitsuba reads 3, 2
/// and 3 and ignores the rest, such as a `w` or colors).
fn obj_floats<'a, const N: usize>(
    rest: &'a str,
    line: usize,
    what: &str,
) -> Result<([f32; N], [&'a str; N]), String> {
    let mut values = [0.0; N];
    let mut tokens = [""; N];
    let mut words = rest.split_ascii_whitespace();
    for (value, token) in values.iter_mut().zip(&mut tokens) {
        let word = words.next().unwrap_or("");
        *value = word.parse::<f32>().map_err(|_| {
            format!(
                "line {line}: could not parse the {what} \"{}\"",
                one_line(rest)
            )
        })?;
        *token = word;
    }
    Ok((values, tokens))
}

/// The corners of an `f` line: its words up to a comment.
fn face_words(rest: &str) -> impl Iterator<Item = &str> {
    rest.split_ascii_whitespace()
        .take_while(|w| !w.starts_with('#'))
}

/// One face corner `v`, `v/t`, `v//n` or `v/t/n` as written; an empty or
/// zero `t` or `n` means none (Mitsuba keys a missing index as 0).
struct Corner<'a> {
    v: i64,
    t: Option<i64>,
    n: Option<i64>,
    v_text: &'a str,
    t_text: &'a str,
    n_text: &'a str,
}

fn parse_corner(word: &str) -> Option<Corner<'_>> {
    let mut parts = word.split('/');
    let v_text = parts.next()?;
    let t_text = parts.next().unwrap_or("");
    let n_text = parts.next().unwrap_or("");
    if parts.next().is_some() {
        return None;
    }
    let optional = |text: &str| -> Option<Option<i64>> {
        if text.is_empty() {
            return Some(None);
        }
        let value = text.parse::<i64>().ok()?;
        Some((value != 0).then_some(value))
    };
    Some(Corner {
        v: v_text.parse().ok()?,
        t: optional(t_text)?,
        n: optional(n_text)?,
        v_text,
        t_text,
        n_text,
    })
}

/// What the first pass over an OBJ file learns.
#[derive(Default)]
struct ObjScan {
    positions: usize,
    texcoords: usize,
    normals: usize,
    /// Some corner has a texture coordinate / lacks one.
    with_t: bool,
    without_t: bool,
    with_n: bool,
    without_n: bool,
    /// The largest positive texture coordinate and normal index, and its
    /// line: Mitsuba checks these against the file's totals at the end.
    max_t: (i64, usize),
    max_n: (i64, usize),
}

/// Resolves a face index as the OBJ format does: k > 0 is the k-th entry so
/// far, k < 0 counts back from the last one.
fn resolve(k: i64, count: usize, line: usize, what: &str) -> Result<(), String> {
    if k != 0 && k.unsigned_abs() <= count as u64 {
        Ok(())
    } else {
        Err(format!(
            "line {line}: face index {k} out of range ({count} {what})"
        ))
    }
}

fn obj_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, std::borrow::Cow<'_, str>)> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(k, line)| (k + 1, String::from_utf8_lossy(line)))
}

/// Pass one: checks every line Mitsuba reads, with its line number.
fn scan_obj(bytes: &[u8], face_normals: bool) -> Result<ObjScan, String> {
    let mut scan = ObjScan::default();
    for (line, text) in obj_lines(bytes) {
        match classify(&text) {
            ObjLine::V(rest) => {
                let (p, _) = obj_floats::<3>(rest, line, "vertex position")?;
                if !p.iter().all(|c| c.is_finite()) {
                    // obj.cpp: "mesh contains invalid vertex position data".
                    return Err(format!("line {line}: the vertex position is not finite"));
                }
                scan.positions += 1;
            }
            ObjLine::Vt(rest) => {
                obj_floats::<2>(rest, line, "texture coordinate")?;
                scan.texcoords += 1;
            }
            ObjLine::Vn(rest) => {
                // With face normals Mitsuba does not even parse `vn` lines.
                if !face_normals {
                    let (n, _) = obj_floats::<3>(rest, line, "vertex normal")?;
                    if !normalize(Vec3::from(n)).is_finite() {
                        // obj.cpp: "mesh contains invalid vertex normal data".
                        return Err(format!(
                            "line {line}: the vertex normal is zero or not finite"
                        ));
                    }
                    scan.normals += 1;
                }
            }
            ObjLine::F(rest) => {
                for word in face_words(rest) {
                    let c = parse_corner(word).ok_or_else(|| {
                        format!(
                            "line {line}: could not parse the face corner \"{}\"",
                            one_line(word)
                        )
                    })?;
                    resolve(c.v, scan.positions, line, "vertices")?;
                    match c.t {
                        Some(t) if t > 0 => scan.max_t = scan.max_t.max((t, line)),
                        Some(t) => resolve(t, scan.texcoords, line, "texture coordinates")?,
                        None => {}
                    }
                    scan.with_t |= c.t.is_some();
                    scan.without_t |= c.t.is_none();
                    if !face_normals {
                        match c.n {
                            Some(n) if n > 0 => scan.max_n = scan.max_n.max((n, line)),
                            Some(n) => resolve(n, scan.normals, line, "normals")?,
                            None => {}
                        }
                    }
                    scan.with_n |= c.n.is_some();
                    scan.without_n |= c.n.is_none();
                }
            }
            ObjLine::Other => {}
        }
    }
    let (t, line) = scan.max_t;
    if t > 0 {
        resolve(t, scan.texcoords, line, "texture coordinates")?;
    }
    let (n, line) = scan.max_n;
    if n > 0 {
        resolve(n, scan.normals, line, "normals")?;
    }
    Ok(scan)
}

/// Reads OBJ text from memory: [`read_obj`] without the file.
///
/// The text is checked line by line first (errors name the line), then
/// handed to `tobj` as only the lines Mitsuba reads, with each `v` line cut
/// to its three coordinates, so that tobj's one model is the whole file and
/// its `single_index` de-duplication of (position, texture coordinate,
/// normal) index triples numbers the vertices as Mitsuba does. Where some
/// face corners lack a texture coordinate (or normal) that others have, those
/// corners are given the index of one extra entry appended after the file's
/// own, (0, 0) (or a NaN normal, which is then replaced by the computed
/// one): Mitsuba leaves such data uninitialized.
pub fn parse_obj(bytes: &[u8], opts: &MeshOptions) -> Result<Mesh, String> {
    let scan = scan_obj(bytes, opts.face_normals)?;
    let flip = opts.flip_tex_coords.unwrap_or(OBJ_FLIP_DEFAULT);
    let pad_t = scan.with_t && scan.without_t;
    let pad_n = !opts.face_normals && scan.with_n && scan.without_n;
    let extra_t = (scan.texcoords + 1).to_string();
    let extra_n = (scan.normals + 1).to_string();

    // Pass two: the text tobj reads.
    let mut text = String::with_capacity(bytes.len() + 64);
    for (_, line_text) in obj_lines(bytes) {
        match classify(&line_text) {
            ObjLine::V(rest) => {
                if let Ok((_, words)) = obj_floats::<3>(rest, 0, "") {
                    push_line(&mut text, "v", &words);
                }
            }
            ObjLine::Vt(rest) => {
                if let Ok((_, words)) = obj_floats::<2>(rest, 0, "") {
                    push_line(&mut text, "vt", &words);
                }
            }
            ObjLine::Vn(rest) => {
                if let (false, Ok((_, words))) = (opts.face_normals, obj_floats::<3>(rest, 0, "")) {
                    push_line(&mut text, "vn", &words);
                }
            }
            ObjLine::F(rest) => {
                text.push('f');
                for word in face_words(rest) {
                    let Some(c) = parse_corner(word) else {
                        continue;
                    };
                    text.push(' ');
                    let t_missing = pad_t && c.t.is_none();
                    let n_missing = pad_n && c.n.is_none();
                    if !t_missing && !n_missing {
                        text.push_str(word);
                        continue;
                    }
                    let t = if t_missing {
                        extra_t.as_str()
                    } else {
                        c.t_text
                    };
                    let n = if n_missing {
                        extra_n.as_str()
                    } else {
                        c.n_text
                    };
                    text.push_str(c.v_text);
                    if !t.is_empty() || !n.is_empty() {
                        text.push('/');
                        text.push_str(t);
                    }
                    if !n.is_empty() {
                        text.push('/');
                        text.push_str(n);
                    }
                }
                text.push('\n');
            }
            ObjLine::Other => {}
        }
    }
    if pad_t {
        // Flipped below like the file's own: (0, 0) in the end.
        text.push_str(if flip { "vt 0 1\n" } else { "vt 0 0\n" });
    }
    if pad_n {
        text.push_str("vn NaN NaN NaN\n");
    }

    // The update fills the fields tobj's `merging` and `reordering` features
    // add, should another crate of the build switch them on.
    #[allow(clippy::needless_update)]
    let load = tobj::LoadOptions {
        single_index: true,
        // Fanned below from `face_arities`, so that faces of one or two
        // corners still number their vertices, as in Mitsuba.
        triangulate: false,
        ignore_points: false,
        ignore_lines: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &load, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| format!("tobj: {e}"))?;
    let Some(model) = models.into_iter().next() else {
        return finish(Vec::new(), None, None, Vec::new(), opts.face_normals);
    };
    let m = model.mesh;
    let count = m.positions.len() / 3;
    let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(Vec3::from_slice).collect();
    let uvs = if scan.with_t {
        if m.texcoords.len() != 2 * count {
            return Err("tobj returned texture coordinates that do not match its vertices".into());
        }
        let mut uvs: Vec<Vec2> = m.texcoords.chunks_exact(2).map(Vec2::from_slice).collect();
        flip_v(&mut uvs, flip);
        Some(uvs)
    } else {
        None
    };
    let normals = if !opts.face_normals && scan.with_n {
        if m.normals.len() != 3 * count {
            return Err("tobj returned normals that do not match its vertices".into());
        }
        Some(m.normals.chunks_exact(3).map(Vec3::from_slice).collect())
    } else {
        None
    };
    let indices = fan(&m.indices, &m.face_arities)?;
    finish(positions, normals, uvs, indices, opts.face_normals)
}

fn push_line(text: &mut String, keyword: &str, words: &[&str]) {
    text.push_str(keyword);
    for w in words {
        text.push(' ');
        text.push_str(w);
    }
    text.push('\n');
}

/// Triangulates polygons given as corner lists (`arities` empty: all
/// triangles) by fanning around each one's first corner: obj.cpp keeps
/// `tri[0]` and shifts `tri[1] = tri[2]; tri[2] = id` per further corner.
/// Polygons of fewer than 3 corners give no triangle.
fn fan(corners: &[u32], arities: &[u32]) -> Result<Vec<u32>, String> {
    if arities.is_empty() {
        if corners.len() % 3 != 0 {
            return Err("tobj returned a partial triangle".into());
        }
        return Ok(corners.to_vec());
    }
    let mut out = Vec::with_capacity(corners.len() * 2);
    let mut rest = corners;
    for &arity in arities {
        let arity = arity as usize;
        let Some((face, tail)) = rest.split_at_checked(arity) else {
            return Err("tobj returned fewer face corners than its face sizes".into());
        };
        for k in 1..arity.saturating_sub(1) {
            out.extend_from_slice(&[face[0], face[k], face[k + 1]]);
        }
        rest = tail;
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, KeyMap, PropertyAccess, PropertyAccessResult, PropertyDef,
    PropertyType, ScalarType,
};

/// ply.cpp: `props.get<bool>("flip_tex_coords", false)`.
const PLY_FLIP_DEFAULT: bool = false;

/// The texture coordinate pairs ply.cpp accepts, in its order of preference.
const PLY_UV_NAMES: [(&str, &str); 3] = [("u", "v"), ("texture_u", "texture_v"), ("s", "t")];

/// The face lists ply.cpp accepts, in its order of preference.
const PLY_FACE_LISTS: [&str; 2] = ["vertex_index", "vertex_indices"];

/// The vertex properties this reader keeps, by the canonical names its
/// renamed element definition gives them; all others are renamed apart.
const VERTEX_SLOTS: [&str; 8] = ["x", "y", "z", "nx", "ny", "nz", "u", "v"];

/// One `vertex` record: the eight slots, converted to `f32` by a plain
/// cast whatever their type (Mitsuba converts integer properties to float
/// without normalizing them: checked with a `uchar x` file).
/// The attribute properties' values follow, by the slot numbers
/// [`attribute_slot`] gives them.
struct PlyVertex([f32; VERTEX_SLOTS.len()], Vec<f32>);

/// The name the renamed element definitions give attribute property `k`.
fn attribute_slot(k: usize) -> String {
    format!("@{k}")
}

/// Stores `value` in `extra` at the attribute slot `name` names, if it
/// names one.
fn set_attribute(extra: &mut Vec<f32>, name: &str, value: f32) -> PropertyAccessResult {
    match name.strip_prefix('@').and_then(|k| k.parse::<usize>().ok()) {
        Some(k) => {
            if extra.len() <= k {
                extra.resize(k + 1, 0.0);
            }
            extra[k] = value;
            PropertyAccessResult::Set
        }
        None => PropertyAccessResult::Ignored,
    }
}

impl PlyVertex {
    fn set(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        match VERTEX_SLOTS.iter().position(|&s| s == name) {
            Some(k) => {
                self.0[k] = value;
                PropertyAccessResult::Set
            }
            None => set_attribute(&mut self.1, name, value),
        }
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex([0.0; VERTEX_SLOTS.len()], Vec::new())
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
}

/// The name the renamed `face` definition gives the index list.
const FACE_LIST: &str = "i";

/// One `face` record: its index list, or the negative index it held, and
/// its attribute properties' values (by [`attribute_slot`]).
struct PlyFace {
    indices: Vec<u32>,
    negative: Option<i64>,
    extra: Vec<f32>,
}

impl PlyFace {
    fn take<T: Copy + TryInto<u32> + Into<i64>>(
        &mut self,
        name: &str,
        values: Vec<T>,
    ) -> PropertyAccessResult {
        if name != FACE_LIST {
            return PropertyAccessResult::Ignored;
        }
        self.indices.clear();
        for v in values {
            match v.try_into() {
                Ok(i) => self.indices.push(i),
                Err(_) => self.negative = Some(v.into()),
            }
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace {
            indices: Vec::new(),
            negative: None,
            extra: Vec::new(),
        }
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, f32::from(value))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, f32::from(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, f32::from(value))
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, f32::from(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, value as f32)
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, value as f32)
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, value)
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        set_attribute(&mut self.extra, name, value as f32)
    }
    fn set_list_char(&mut self, name: &str, value: Vec<i8>) -> PropertyAccessResult {
        self.take(name, value)
    }
    fn set_list_uchar(&mut self, name: &str, value: Vec<u8>) -> PropertyAccessResult {
        self.take(name, value)
    }
    fn set_list_short(&mut self, name: &str, value: Vec<i16>) -> PropertyAccessResult {
        self.take(name, value)
    }
    fn set_list_ushort(&mut self, name: &str, value: Vec<u16>) -> PropertyAccessResult {
        self.take(name, value)
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        self.take(name, value)
    }
    fn set_list_uint(&mut self, name: &str, value: Vec<u32>) -> PropertyAccessResult {
        if name != FACE_LIST {
            return PropertyAccessResult::Ignored;
        }
        self.indices = value;
        PropertyAccessResult::Set
    }
}

/// A record of an element this reader ignores: read and dropped.
struct PlySkip;

impl PropertyAccess for PlySkip {
    fn new() -> Self {
        PlySkip
    }
}

/// Bytes of one scalar in a binary PLY file (the PLY format's type sizes).
fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The fewest bytes one record of `def` can take: every scalar, and every
/// list's count with no entries. ASCII: every property at least one
/// character and one separator (the last record may lack its newline).
fn min_record_bytes(def: &ElementDef, encoding: Encoding) -> usize {
    match encoding {
        Encoding::Ascii => 2 * def.properties.len(),
        Encoding::BinaryBigEndian | Encoding::BinaryLittleEndian => def
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_size(t),
            })
            .sum(),
    }
}

/// A copy of `def` with the properties in `keep` renamed to their slot
/// names and every other one to a name no slot has.
fn renamed(def: &ElementDef, keep: &[(&str, &str)]) -> ElementDef {
    let mut out = ElementDef::new(def.name.clone());
    out.count = def.count;
    out.properties = KeyMap::new();
    for (k, (name, prop)) in def.properties.iter().enumerate() {
        let new_name = match keep.iter().find(|(file, _)| file == name) {
            Some((_, slot)) => (*slot).to_string(),
            None => format!("-{k}"),
        };
        out.properties
            .add(PropertyDef::new(new_name, prop.data_type.clone()));
    }
    out
}

/// The payload after the header, read record by record.
struct PlyBody<'a> {
    rest: &'a [u8],
    encoding: Encoding,
    /// ASCII: the number of the last line read.
    line: usize,
}

impl<'a> PlyBody<'a> {
    /// Reads one record of `def` into an `E`, or says where it failed.
    fn record<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        index: usize,
    ) -> Result<E, String> {
        let here = |body: &Self, msg: String| match body.encoding {
            Encoding::Ascii => format!("line {}: {} {index}: {msg}", body.line, def.name),
            _ => format!("{} {index}: {msg}", def.name),
        };
        let result = match self.encoding {
            Encoding::Ascii => {
                let text = loop {
                    let all: &'a [u8] = self.rest;
                    if all.is_empty() {
                        self.line += 1;
                        return Err(here(self, "unexpected end of file".into()));
                    }
                    let end = all.iter().position(|&b| b == b'\n').unwrap_or(all.len());
                    let line = &all[..end];
                    self.rest = all.get(end + 1..).unwrap_or(&[]);
                    self.line += 1;
                    // Mitsuba reads ASCII PLY as a stream of words: blank
                    // lines hold no record.
                    if !line.iter().all(u8::is_ascii_whitespace) {
                        break line;
                    }
                };
                let text = std::str::from_utf8(text)
                    .map_err(|_| here(self, "the line is not valid UTF-8".into()))?;
                parser.read_ascii_element(text.trim_end_matches('\r'), def)
            }
            Encoding::BinaryLittleEndian => parser.read_little_endian_element(&mut self.rest, def),
            Encoding::BinaryBigEndian => parser.read_big_endian_element(&mut self.rest, def),
        };
        result.map_err(|e| {
            let msg = if e.kind() == std::io::ErrorKind::UnexpectedEof {
                "unexpected end of file".to_string()
            } else {
                one_line(&e)
            };
            here(self, msg)
        })
    }
}

/// Reads PLY data from memory: [`read_ply`] without the file.
pub fn parse_ply(bytes: &[u8], opts: &MeshOptions) -> Result<Mesh, String> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<PlySkip>::new()
        .read_header(&mut reader)
        .map_err(|e| format!("invalid PLY header: {}", one_line(&e)))?;
    let rest = reader.into_inner();
    let header_len = bytes.len() - rest.len();
    let encoding = header.encoding;

    // Refuse counts the file cannot hold before reading anything, so that
    // no allocation or loop is sized by a count alone.
    let mut needed = 0usize;
    for def in header.elements.values() {
        let need = def
            .count
            .checked_mul(min_record_bytes(def, encoding))
            .and_then(|n| n.checked_add(needed));
        match need {
            // ASCII: the last record needs no newline.
            Some(n) if n <= rest.len() + usize::from(encoding == Encoding::Ascii) => needed = n,
            _ => {
                return Err(format!(
                    "the header declares {} {} records, more than the {} bytes after it can hold",
                    def.count,
                    def.name,
                    rest.len()
                ))
            }
        }
    }

    let mut body = PlyBody {
        rest,
        encoding,
        line: bytes[..header_len].iter().filter(|&&b| b == b'\n').count(),
    };
    let mut positions = Vec::new();
    let mut normals: Option<Vec<Vec3>> = None;
    let mut uvs: Option<Vec<Vec2>> = None;
    let mut indices = Vec::new();
    let mut attributes = Vec::new();
    for (name, def) in &header.elements {
        // Room for what the file can hold, not for what the header claims.
        let capacity = def
            .count
            .min(rest.len() / min_record_bytes(def, encoding).max(1));
        if def.properties.is_empty() {
            // Records without properties take no bytes (nor words).
            continue;
        }
        match name.as_str() {
            "vertex" => {
                let mut keep = Vec::new();
                for (file, slot) in [("x", "x"), ("y", "y"), ("z", "z")] {
                    scalar_property(def, file)?;
                    keep.push((file, slot));
                }
                let has_normals = !opts.face_normals
                    && ["nx", "ny", "nz"]
                        .iter()
                        .all(|n| def.properties.contains_key(*n));
                if has_normals {
                    for n in ["nx", "ny", "nz"] {
                        scalar_property(def, n)?;
                        keep.push((n, n));
                    }
                }
                let uv_names = PLY_UV_NAMES.iter().find(|(u, v)| {
                    def.properties.contains_key(*u) && def.properties.contains_key(*v)
                });
                if let Some(&(u, v)) = uv_names {
                    scalar_property(def, u)?;
                    scalar_property(def, v)?;
                    keep.extend([(u, "u"), (v, "v")]);
                }
                let mut reserved = vec!["x", "y", "z", "nx", "ny", "nz", "u", "v"];
                reserved.extend(uv_names.iter().flat_map(|&(u, v)| [u, v]));
                let (groups, slots) = attribute_slots(def, "vertex_", &reserved);
                let slot_keep: Vec<(&str, &str)> = slots
                    .iter()
                    .map(|(file, slot)| (file.as_str(), slot.as_str()))
                    .collect();
                keep.extend(slot_keep);
                let def = renamed(def, &keep);
                let parser = Parser::<PlyVertex>::new();
                positions = Vec::with_capacity(capacity);
                let mut ns = Vec::with_capacity(if has_normals { capacity } else { 0 });
                let mut ts = Vec::with_capacity(if uv_names.is_some() { capacity } else { 0 });
                let mut values: Vec<Vec<f32>> = vec![Vec::new(); groups.len()];
                for i in 0..def.count {
                    let PlyVertex(s, extra) = body.record(&parser, &def, i)?;
                    positions.push(Vec3::new(s[0], s[1], s[2]));
                    if has_normals {
                        ns.push(Vec3::new(s[3], s[4], s[5]));
                    }
                    if uv_names.is_some() {
                        ts.push(Vec2::new(s[6], s[7]));
                    }
                    gather(&groups, &extra, &mut values, 1);
                }
                normals = has_normals.then_some(ns);
                uvs = uv_names.is_some().then_some(ts);
                attributes.extend(attributes_of(&groups, values));
            }
            "face" => {
                let list = PLY_FACE_LISTS
                    .iter()
                    .find(|n| def.properties.contains_key(**n))
                    .ok_or("face element has no vertex_index or vertex_indices property")?;
                match &def.properties[*list].data_type {
                    PropertyType::List(_, ScalarType::Float | ScalarType::Double)
                    | PropertyType::Scalar(_) => {
                        return Err(format!("face property {list} is not a list of integers"));
                    }
                    PropertyType::List(..) => {}
                }
                let (groups, slots) = attribute_slots(def, "face_", &[list]);
                let mut keep = vec![(*list, FACE_LIST)];
                keep.extend(slots.iter().map(|(f, s)| (f.as_str(), s.as_str())));
                let def = renamed(def, &keep);
                let parser = Parser::<PlyFace>::new();
                indices = Vec::with_capacity(capacity.saturating_mul(3));
                let mut values: Vec<Vec<f32>> = vec![Vec::new(); groups.len()];
                for i in 0..def.count {
                    let face = body.record(&parser, &def, i)?;
                    if let Some(v) = face.negative {
                        return Err(format!("face {i}: negative vertex index {v}"));
                    }
                    let c = &face.indices;
                    let triangles = c.len().saturating_sub(2);
                    for k in 1..c.len().saturating_sub(1) {
                        indices.extend_from_slice(&[c[0], c[k], c[k + 1]]);
                    }
                    gather(&groups, &face.extra, &mut values, triangles);
                }
                attributes.extend(attributes_of(&groups, values));
            }
            _ => {
                let all_scalar = def
                    .properties
                    .values()
                    .all(|p| matches!(p.data_type, PropertyType::Scalar(_)));
                if all_scalar && encoding != Encoding::Ascii {
                    // Checked above: the records fit in what is left.
                    let skip = def.count * min_record_bytes(def, encoding);
                    body.rest = body.rest.get(skip..).unwrap_or(&[]);
                } else {
                    let parser = Parser::<PlySkip>::new();
                    for i in 0..def.count {
                        body.record(&parser, def, i)?;
                    }
                }
            }
        }
    }
    // ply.cpp: "invalid file -- trailing content" (binary); ply.h: "trailing
    // tokens after end of PLY file" (ASCII).
    let trailing = match encoding {
        Encoding::Ascii => body.rest.iter().any(|b| !b.is_ascii_whitespace()),
        _ => !body.rest.is_empty(),
    };
    if trailing {
        return Err(format!(
            "{} bytes of trailing content after the last element",
            body.rest.len()
        ));
    }
    if let Some(uvs) = &mut uvs {
        flip_v(uvs, opts.flip_tex_coords.unwrap_or(PLY_FLIP_DEFAULT));
    }
    let mut mesh = finish(positions, normals, uvs, indices, opts.face_normals)?;
    mesh.attributes = attributes;
    Ok(mesh)
}

/// An element's attributes ([`ply_attributes`] over its scalar properties
/// but `reserved`), each with its properties' slot numbers, and the
/// (file name, slot name) pairs that rename them for the parser.
#[allow(clippy::type_complexity)]
fn attribute_slots(
    def: &ElementDef,
    kind: &str,
    reserved: &[&str],
) -> (Vec<(String, Vec<usize>)>, Vec<(String, String)>) {
    let scalars: Vec<&str> = def
        .properties
        .iter()
        .filter(|(_, p)| matches!(p.data_type, PropertyType::Scalar(_)))
        .map(|(n, _)| n.as_str())
        .collect();
    let mut slots = Vec::new();
    let groups = ply_attributes(kind, &scalars, reserved)
        .into_iter()
        .map(|(name, fields)| {
            let ks = fields
                .into_iter()
                .map(|f| {
                    slots.push((f, attribute_slot(slots.len())));
                    slots.len() - 1
                })
                .collect();
            (name, ks)
        })
        .collect();
    (groups, slots)
}

/// Appends one record's attribute values (`extra`, by slot), `repeat`
/// times, to each attribute's values.
fn gather(groups: &[(String, Vec<usize>)], extra: &[f32], values: &mut [Vec<f32>], repeat: usize) {
    for ((_, ks), out) in groups.iter().zip(values) {
        for _ in 0..repeat {
            out.extend(ks.iter().map(|&k| extra.get(k).copied().unwrap_or(0.0)));
        }
    }
}

fn attributes_of(groups: &[(String, Vec<usize>)], values: Vec<Vec<f32>>) -> Vec<Attribute> {
    groups
        .iter()
        .zip(values)
        .map(|((name, ks), values)| Attribute {
            name: name.clone(),
            channels: ks.len(),
            values,
        })
        .collect()
}

/// Checks that `def` has the scalar property `name`.
fn scalar_property(def: &ElementDef, name: &str) -> Result<(), String> {
    match def.properties.get(name).map(|p| &p.data_type) {
        Some(PropertyType::Scalar(_)) => Ok(()),
        Some(PropertyType::List(..)) => Err(format!("{} property {name} is a list", def.name)),
        None => Err(format!("{} element has no property {name}", def.name)),
    }
}

// ---------------------------------------------------------------------------
// Mitsuba's serialized format
// ---------------------------------------------------------------------------

/// serialized.cpp: `MI_FILEFORMAT_HEADER`, the first little-endian `u16`.
const SERIALIZED_MAGIC: u16 = 0x041C;
/// serialized.cpp: `MI_FILEFORMAT_VERSION_V3` and `_V4`, the second `u16`.
/// Version 4 adds the shape name and has 64-bit offsets in the end table.
const SERIALIZED_V3: u16 = 0x0003;
const SERIALIZED_V4: u16 = 0x0004;
/// serialized.cpp `TriMeshFlags`: `HasNormals`, `HasTexcoords`, `HasColors`
/// and `DoublePrecision`. `HasTangents` (0x0004) is "unused" and adds no
/// data; `FaceNormals` (0x0010) is not read by Mitsuba 3 (its
/// `face_normals` comes from the plugin parameter only: checked with a file
/// that sets it); `SinglePrecision` (0x1000) is what any file without
/// `DoublePrecision` is.
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE_PRECISION: u32 = 0x2000;
/// The longest shape name (version 4) this reader skips before calling the
/// stream corrupt: our own bound, so that a stream of non-zero bytes cannot
/// keep it reading (Mitsuba has none).
const MAX_SHAPE_NAME: u64 = 1 << 16;

/// Reads a `.serialized` file from memory: [`read_serialized`] without the
/// file.
///
/// Layout (serialized.cpp): `u16` 0x041C, `u16` version (3 or 4), then a
/// zlib stream of `u32` flags, (version 4) a NUL-terminated name, `u64`
/// vertex count, `u64` triangle count, positions (xyz), normals (xyz, if
/// flagged), texture coordinates (uv, if flagged), colors (rgb, if flagged;
/// skipped), all `f32` or (flagged) `f64`, then `u32` indices, three per
/// triangle. Little endian throughout. Several meshes follow one another,
/// each with its own two-`u16` header; the file ends with the offsets of
/// all of them (`u64` in version 4, `u32` in version 3) and their count
/// (`u32`). Shape 0 is read from offset 4 without the table, as Mitsuba
/// does.
pub fn parse_serialized(bytes: &[u8], opts: &MeshOptions) -> Result<Mesh, String> {
    if opts.flip_tex_coords.is_some() {
        return Err("the serialized shape has no flip_tex_coords parameter".into());
    }
    let u16_at = |at: usize| -> Option<u16> {
        Some(u16::from_le_bytes(
            bytes.get(at..at.checked_add(2)?)?.try_into().ok()?,
        ))
    };
    let u32_at = |at: usize| -> Option<u32> {
        Some(u32::from_le_bytes(
            bytes.get(at..at.checked_add(4)?)?.try_into().ok()?,
        ))
    };
    let u64_at = |at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(
            bytes.get(at..at.checked_add(8)?)?.try_into().ok()?,
        ))
    };
    let (Some(format), Some(version)) = (u16_at(0), u16_at(2)) else {
        return Err("the file is too short for a serialized header".into());
    };
    if format != SERIALIZED_MAGIC {
        return Err(format!(
            "not a Mitsuba serialized file (format 0x{format:04X}, expected 0x{SERIALIZED_MAGIC:04X})"
        ));
    }
    if version != SERIALIZED_V3 && version != SERIALIZED_V4 {
        return Err(format!(
            "serialized format version {version} is not supported (Mitsuba reads 3 and 4)"
        ));
    }
    let start = if opts.shape_index == 0 {
        4
    } else {
        let size = bytes.len();
        let count = size
            .checked_sub(4)
            .and_then(u32_at)
            .ok_or("the file is too short for the shape table")?;
        let index = opts.shape_index;
        if index >= count {
            return Err(format!(
                "shape index {index} out of range ({count} shapes in the file)"
            ));
        }
        let back = u64::from(count - index);
        let offset = if version == SERIALIZED_V4 {
            back.checked_mul(8)
                .and_then(|b| usize::try_from(b).ok())
                .and_then(|b| size.checked_sub(b + 4))
                .and_then(u64_at)
        } else {
            (back + 1)
                .checked_mul(4)
                .and_then(|b| usize::try_from(b).ok())
                .and_then(|b| size.checked_sub(b))
                .and_then(u32_at)
                .map(u64::from)
        }
        .ok_or("the shape table does not fit in the file")?;
        // Each mesh starts with its own two-u16 header, which Mitsuba skips.
        usize::try_from(offset)
            .ok()
            .and_then(|o| o.checked_add(4))
            .filter(|&s| s <= size)
            .ok_or_else(|| {
                format!("shape {index} starts at offset {offset}, past the end of the file")
            })?
    };

    let mut z = flate2::read::ZlibDecoder::new(&bytes[start..]);
    let flags = u32::from_le_bytes(read_exact::<4>(&mut z, "the flags")?);
    if version == SERIALIZED_V4 {
        let mut name = Vec::new();
        (&mut z)
            .take(MAX_SHAPE_NAME)
            .read_until_nul(&mut name)
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::UnexpectedEof => "the stream ends in the shape name".into(),
                _ => format!("corrupt zlib stream in the shape name: {e}"),
            })?;
        if name.last() != Some(&0) {
            return Err(if (name.len() as u64) < MAX_SHAPE_NAME {
                "the stream ends in the shape name".to_string()
            } else {
                format!("the shape name has no end within {MAX_SHAPE_NAME} bytes")
            });
        }
    }
    let vertex_count = u64::from_le_bytes(read_exact::<8>(&mut z, "the vertex count")?);
    let triangle_count = u64::from_le_bytes(read_exact::<8>(&mut z, "the triangle count")?);
    // Mitsuba stores both counts as u32 (`ScalarSize`), and its indices are
    // u32.
    let too_many = |n: u64| n > u64::from(u32::MAX);
    if too_many(vertex_count) || too_many(triangle_count) {
        return Err(format!(
            "{vertex_count} vertices and {triangle_count} triangles: more than Mitsuba's 32-bit counts"
        ));
    }
    let (vertices, triangles) = (vertex_count as usize, triangle_count as usize);
    let double = flags & DOUBLE_PRECISION != 0;
    let positions = read_floats::<3>(&mut z, vertices, double, "positions")?;
    let mut normals = None;
    if flags & HAS_NORMALS != 0 {
        let n = read_floats::<3>(&mut z, vertices, double, "normals")?;
        normals = (!opts.face_normals).then_some(n);
    }
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        Some(read_floats::<2>(
            &mut z,
            vertices,
            double,
            "texture coordinates",
        )?)
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        read_floats::<3>(&mut z, vertices, double, "colors")?;
    }
    // Three u32 (4 bytes) per triangle.
    let indices = read_bytes(&mut z, triangles * 3 * 4, "indices")?
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let positions = positions.into_iter().map(Vec3::from).collect();
    let normals = normals.map(|n| n.into_iter().map(Vec3::from).collect());
    let uvs = uvs.map(|t| t.into_iter().map(Vec2::from).collect());
    finish(positions, normals, uvs, indices, opts.face_normals)
}

/// `BufRead::read_until` for a reader without a buffer: byte by byte.
trait ReadUntilNul {
    fn read_until_nul(&mut self, out: &mut Vec<u8>) -> std::io::Result<()>;
}

impl<R: Read> ReadUntilNul for R {
    fn read_until_nul(&mut self, out: &mut Vec<u8>) -> std::io::Result<()> {
        let mut byte = [0u8];
        loop {
            match self.read(&mut byte) {
                Ok(0) => return Ok(()),
                Ok(_) => {
                    out.push(byte[0]);
                    if byte[0] == 0 {
                        return Ok(());
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

fn read_exact<const N: usize>(z: &mut impl Read, what: &str) -> Result<[u8; N], String> {
    let bytes = read_bytes(z, N, what)?;
    bytes
        .try_into()
        .map_err(|_| format!("could not read {what}"))
}

/// Reads `len` bytes of the stream. The buffer grows with the data that
/// actually arrives, so a count in the file cannot size it alone.
fn read_bytes(z: &mut impl Read, len: usize, what: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    match z.take(len as u64).read_to_end(&mut out) {
        Ok(_) => {}
        // flate2 says so when its input ends inside the stream.
        Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            return Err(format!("the stream ends in {what}"));
        }
        Err(e) => return Err(format!("corrupt zlib stream in {what}: {e}")),
    }
    if out.len() < len {
        return Err(format!(
            "the stream ends in {what} ({} of {len} bytes)",
            out.len()
        ));
    }
    Ok(out)
}

/// Reads `count` vectors of `N` floats, `f64` rounded to `f32` when
/// `double` (serialized.cpp's `read_helper` casts with `(float)`).
fn read_floats<const N: usize>(
    z: &mut impl Read,
    count: usize,
    double: bool,
    what: &str,
) -> Result<Vec<[f32; N]>, String> {
    let size = if double { 8 } else { 4 };
    let len = count
        .checked_mul(N * size)
        .ok_or_else(|| format!("{count} vertices of {what} overflow"))?;
    let bytes = read_bytes(z, len, what)?;
    let value = |b: &[u8]| -> f32 {
        if double {
            f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]) as f32
        } else {
            f32::from_le_bytes([b[0], b[1], b[2], b[3]])
        }
    };
    Ok(bytes
        .chunks_exact(N * size)
        .map(|v| std::array::from_fn(|k| value(&v[k * size..])))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.vol` file of `dims` and `values` (the header's box zero).
    fn vol(version: u8, encoding: i32, dims: [i32; 3], channels: i32, values: &[f32]) -> Vec<u8> {
        let mut b = b"VOL".to_vec();
        b.push(version);
        for v in [encoding, dims[0], dims[1], dims[2], channels] {
            b.extend(v.to_le_bytes());
        }
        b.extend([0u8; 24]);
        for v in values {
            b.extend(v.to_le_bytes());
        }
        b
    }

    #[test]
    fn a_vol_grid_reads_its_samples_x_fastest() {
        let values: Vec<f32> = (0..12).map(|i| i as f32 - 5.5).collect();
        let g = parse_vol(&vol(3, 1, [3, 2, 2], 1, &values)).unwrap();
        assert_eq!(g.dims, [3, 2, 2]);
        assert_eq!(g.values, values);
    }

    #[test]
    fn malformed_vol_grids_are_refused_in_one_line() {
        let ok = vec![0.5f32; 8];
        for (bytes, says) in [
            (b"VOX".to_vec(), "not a .vol grid"),
            (vol(2, 1, [2, 2, 2], 1, &ok), "version 2"),
            (vol(3, 2, [2, 2, 2], 1, &ok), "encoding 2"),
            (vol(3, 1, [2, 2, 2], 3, &ok), "3 channels"),
            (vol(3, 1, [2, 0, 2], 1, &ok), "sizes 2 x 0 x 2"),
            (vol(3, 1, [2, -1, 2], 1, &ok), "sizes 2 x -1 x 2"),
            (vol(3, 1, [2, 2, 3], 1, &ok), "more than the file holds"),
            (
                vol(3, 1, [i32::MAX, i32::MAX, 2], 1, &ok),
                "more than the file holds",
            ),
        ] {
            let err = parse_vol(&bytes).unwrap_err();
            assert!(err.contains(says), "{says}: {err}");
            assert!(!err.contains('\n'), "{err}");
        }
    }
    use std::io::Write;
    use std::path::PathBuf;

    fn opts() -> MeshOptions {
        MeshOptions::default()
    }

    fn face_normals() -> MeshOptions {
        MeshOptions {
            face_normals: true,
            ..MeshOptions::default()
        }
    }

    fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn close3(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    fn err(result: Result<Mesh, String>) -> String {
        match result {
            Ok(m) => panic!("expected an error, got {m:?}"),
            Err(e) => {
                assert!(!e.contains('\n'), "error is not one line: {e:?}");
                e
            }
        }
    }

    const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    // ---- vertex normals -------------------------------------------------

    #[test]
    fn ply_properties_group_into_attributes_as_mitsubas() {
        let names = |v: Vec<(String, Vec<String>)>| {
            v.into_iter()
                .map(|(n, f)| format!("{n}:{}", f.join(",")))
                .collect::<Vec<_>>()
        };
        let vertex = ["x", "y", "z", "nx", "ny", "nz", "u", "v"];
        assert_eq!(
            names(ply_attributes(
                "vertex_",
                &["x", "y", "z", "color_0", "color_1", "color_2", "weight_0"],
                &vertex
            )),
            [
                "vertex_color:color_0,color_1,color_2",
                "vertex_weight:weight_0"
            ]
        );
        // Plain r g b (and red green blue) are the colour; an r g b series
        // is `_color`; x y z and 1 2 3 series; two fields are dropped, as
        // are names without a one-letter postfix.
        assert_eq!(
            names(ply_attributes(
                "face_",
                &[
                    "vertex_indices",
                    "red",
                    "green",
                    "blue",
                    "n_x",
                    "n_y",
                    "p_r",
                    "p_g",
                    "p_b",
                    "q_1",
                    "q_2",
                    "q_3",
                    "plain",
                    "s_ab"
                ],
                &["vertex_indices"]
            )),
            [
                "face_color:red,green,blue",
                "face_p_color:p_r,p_g,p_b",
                "face_q:q_1,q_2,q_3"
            ]
        );
        // A broken series and a prefix met again are left out (Mitsuba
        // 3.9.1 also drops b_0 here, the field after the break: not
        // copied, see ply_attributes).
        assert_eq!(
            names(ply_attributes(
                "vertex_",
                &["a_x", "a_z", "b_0", "c_0", "b_0"],
                &vertex
            )),
            ["vertex_b:b_0", "vertex_c:c_0"]
        );
    }

    #[test]
    fn computed_normals_are_angle_weighted() {
        // At the origin: a right angle of a triangle facing +z and a 45
        // degree angle of one facing +x, both of area 1/2. Angle weighting
        // gives (pi/4, 0, pi/2) normalized = (1, 0, 2)/sqrt 5; area weighting
        // would give (1, 0, 1)/sqrt 2.
        let p = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Y,
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let n = vertex_normals(&p, &[0, 1, 2, 0, 3, 4]);
        assert!(
            close3(n[0], Vec3::new(1.0, 0.0, 2.0) / 5f32.sqrt()),
            "{:?}",
            n[0]
        );
        assert!(close3(n[1], Vec3::Z));
        assert!(close3(n[4], Vec3::X));
    }

    #[test]
    fn degenerate_triangles_are_kept_and_add_nothing() {
        let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.indices, [0, 1, 2, 0, 1, 3]);
        let n = m.normals.unwrap();
        assert!(close3(n[0], Vec3::Z) && close3(n[1], Vec3::Z) && close3(n[3], Vec3::Z));
        // Only on the degenerate triangle: Mitsuba's bogus (1, 0, 0).
        assert_eq!(n[2], Vec3::X);
    }

    #[test]
    fn vertex_normals_skip_indices_out_of_range() {
        let n = vertex_normals(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[0, 1, 7, 0, 1, 2, 5]);
        assert_eq!(n.len(), 3);
        assert!(close3(n[0], Vec3::Z));
    }

    // ---- OBJ ------------------------------------------------------------

    #[test]
    fn obj_triangle_from_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(&dir, "t.obj", TRIANGLE_OBJ.as_bytes());
        let m = read_obj(&path, &opts()).unwrap();
        assert_eq!(m.positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(m.indices, [0, 1, 2]);
        assert_eq!(m.uvs, None);
        assert_eq!(m.normals, Some(vec![Vec3::Z; 3]));
        assert!(read_obj(&dir.path().join("missing.obj"), &opts()).is_err());
    }

    #[test]
    fn obj_quads_and_polygons_are_fanned() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n\
                    f 1 2 3 4\nf 1 2 3 4 5\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.indices, [0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3, 0, 3, 4]);
    }

    #[test]
    fn obj_negative_indices_count_back() {
        let positive = "v 0 0 0\nvt 0 0\nv 1 0 0\nvt 1 0\nv 0 1 0\nvt 0 1\nvn 0 0 1\n\
                        f 1/1/1 2/2/1 3/3/1\n";
        let negative = "v 0 0 0\nvt 0 0\nv 1 0 0\nvt 1 0\nv 0 1 0\nvt 0 1\nvn 0 0 1\n\
                        f -3/-3/-1 -2/-2/-1 -1/-1/-1\n";
        let a = parse_obj(positive.as_bytes(), &opts()).unwrap();
        let b = parse_obj(negative.as_bytes(), &opts()).unwrap();
        assert_eq!(a, b);
        // Relative to the line: -1 is the last vertex so far.
        let later = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf 1 -1 2\n";
        let m = parse_obj(later.as_bytes(), &opts()).unwrap();
        assert_eq!(m.positions[3], Vec3::splat(5.0));
        assert_eq!(m.indices, [0, 1, 2, 0, 3, 1]);
    }

    #[test]
    fn obj_flip_tex_coords_defaults_to_true() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.25\nf 1/1 2/1 3/1\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.uvs, Some(vec![Vec2::new(0.5, 0.75); 3]));
        let no_flip = MeshOptions {
            flip_tex_coords: Some(false),
            ..opts()
        };
        let m = parse_obj(text.as_bytes(), &no_flip).unwrap();
        assert_eq!(m.uvs, Some(vec![Vec2::new(0.5, 0.25); 3]));
    }

    #[test]
    fn obj_vertices_are_index_triples_in_first_use_order() {
        // Groups, objects and materials do not split the mesh: vertex 1/1
        // is shared across them, 1/2 is another vertex.
        let text = "mtllib a.mtl\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 1\n\
                    g one\nusemtl red\ns 1\nf 2/1 1/1 3/1\ng two\nusemtl blue\n\
                    f 1/1 4/1 3/1\nf 1/2 2/1 4/1\nl 1 2 3\np 1\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(
            m.positions,
            [
                Vec3::X,
                Vec3::ZERO,
                Vec3::Y,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::ZERO
            ]
        );
        assert_eq!(m.indices, [0, 1, 2, 1, 3, 2, 4, 0, 3]);
        let uvs = m.uvs.unwrap();
        assert_eq!(uvs[4], Vec2::new(1.0, 0.0)); // (1, 1) flipped
    }

    #[test]
    fn obj_file_normals_are_normalized_and_face_normals_drop_them() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nvn 0 3 0\n\
                    f 1//1 2//1 3//1\nf 1//2 2//2 3//2\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        let n = m.normals.unwrap();
        assert_eq!(n, [Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Y, Vec3::Y, Vec3::Y]);
        // With face normals the normal index still tells vertices apart,
        // as in Mitsuba, but no normals are kept (nor `vn` lines parsed).
        let text = text.replace("vn 0 3 0", "vn not a normal");
        let m = parse_obj(text.as_bytes(), &face_normals()).unwrap();
        assert_eq!(m.positions.len(), 6);
        assert_eq!(m.normals, None);
        // Nor are normal indices checked then (Mitsuba does not), safely.
        let huge = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//9223372036854775807 2//-9 3//1\n";
        let m = parse_obj(huge.as_bytes(), &face_normals()).unwrap();
        assert_eq!(m.indices, [0, 1, 2]);
    }

    #[test]
    fn obj_ignores_w_comments_and_unknown_lines() {
        let text = "# a comment\nv 0 0 0 2\n  v 1 0 0 1\n\tv 0 1 0 0.5\nvp 1 2\n\
                    f 1 2 3 # trailing comment 4\r\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(m.indices, [0, 1, 2]);
    }

    #[test]
    fn obj_short_faces_number_vertices_without_triangles() {
        // Mitsuba gives "f 4 1" vertex ids but no triangle.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 4 1\nf 1 2 3\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.positions[0], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.indices, [1, 2, 3]);
        assert_eq!(m.normals.unwrap()[0], Vec3::X);
    }

    #[test]
    fn obj_corners_without_texcoords_or_normals_are_padded() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.25\nvn 0 0 3\n\
                    f 1/1/1 2 3//1\nf 1/0/0 2/1 3\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.positions.len(), 6);
        assert_eq!(m.indices, [0, 1, 2, 3, 4, 5]);
        let uvs = m.uvs.unwrap();
        assert_eq!(uvs[0], Vec2::new(0.5, 0.75));
        assert_eq!(uvs[1], Vec2::ZERO);
        assert_eq!(uvs[2], Vec2::ZERO);
        let n = m.normals.unwrap();
        assert!(n.iter().all(|n| close3(*n, Vec3::Z)), "{n:?}");
    }

    #[test]
    fn obj_errors_name_the_line() {
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
                "line 4: face index 9 out of range (3 vertices)",
            ),
            (
                "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
                "line 3: face index 3 out of range (2 vertices)",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
                "line 4: face index 0 out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n",
                "line 4: face index -4 out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n",
                "line 4: could not parse the face corner",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
                "line 4: could not parse the face corner",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 99999999999999999999 1 2\n",
                "line 4: could not parse",
            ),
            (
                "v 0 0 0\nv 1 zero 0\n",
                "line 2: could not parse the vertex position",
            ),
            ("v 0 0\n", "line 1: could not parse the vertex position"),
            ("v 0 0 inf\n", "line 1: the vertex position is not finite"),
            ("vt 0\n", "line 1: could not parse the texture coordinate"),
            (
                "vn 0 0 0\n",
                "line 1: the vertex normal is zero or not finite",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n",
                "line 5: face index 2 out of range (1 texture coordinates)",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",
                "line 4: face index 1 out of range (0 normals)",
            ),
        ];
        for (text, expected) in cases {
            let e = err(parse_obj(text.as_bytes(), &opts()));
            assert!(e.starts_with(expected), "{text:?}: {e}");
        }
    }

    #[test]
    fn obj_forward_texture_coordinates_are_allowed_as_in_mitsuba() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\nvt 0.5 0.25\n";
        let m = parse_obj(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.uvs, Some(vec![Vec2::new(0.5, 0.75); 3]));
    }

    // ---- PLY ------------------------------------------------------------

    /// A unit square in z = 0 as two triangles (or one quad), with normals
    /// (0, 0, 2) and texture coordinates, plus a color and an extra element.
    const SQUARE: [[f32; 8]; 4] = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 2.0, 1.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 2.0, 1.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.25],
    ];

    fn ply_header(format: &str, faces: usize, list: &str) -> String {
        format!(
            "ply\nformat {format} 1.0\ncomment test\nelement vertex 4\n\
             property float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\n\
             property float u\nproperty float v\nproperty uchar red\n\
             element face {faces}\nproperty list {list} vertex_indices\nproperty int flags\n\
             element edge 1\nproperty int a\nproperty list uchar int b\nend_header\n"
        )
    }

    fn ply_ascii(faces: &[&[u32]]) -> Vec<u8> {
        let mut s = ply_header("ascii", faces.len(), "uchar int");
        for v in SQUARE {
            let words: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            s += &format!("{} 255\n", words.join(" "));
        }
        s += "\n"; // a blank line holds no record
        for f in faces {
            let words: Vec<String> = f.iter().map(|x| x.to_string()).collect();
            s += &format!("{} {} 7\n", f.len(), words.join(" "));
        }
        s += "3 2 0 1 2\n";
        s.into_bytes()
    }

    /// Binary PLY with the face list as `list COUNT INDEX`.
    fn ply_binary(big: bool, faces: &[&[u32]], count: &str, index: &str) -> Vec<u8> {
        let format = if big {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut out = ply_header(format, faces.len(), &format!("{count} {index}")).into_bytes();
        let int = |out: &mut Vec<u8>, ty: &str, v: u32| {
            let b: Vec<u8> = match (ty, big) {
                ("uchar" | "char", _) => vec![v as u8],
                ("ushort" | "short", false) => (v as u16).to_le_bytes().to_vec(),
                ("ushort" | "short", true) => (v as u16).to_be_bytes().to_vec(),
                (_, false) => v.to_le_bytes().to_vec(),
                (_, true) => v.to_be_bytes().to_vec(),
            };
            out.extend(b);
        };
        for v in SQUARE {
            for x in v {
                out.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            out.push(255);
        }
        for f in faces {
            int(&mut out, count, f.len() as u32);
            for &i in *f {
                int(&mut out, index, i);
            }
            int(&mut out, "int", 7);
        }
        int(&mut out, "int", 2);
        out.push(1);
        int(&mut out, "int", 3);
        out
    }

    const TWO_TRIANGLES: [&[u32]; 2] = [&[0, 1, 2], &[0, 2, 3]];

    #[test]
    fn ply_ascii_reads_normals_and_uvs_from_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(&dir, "s.ply", &ply_ascii(&TWO_TRIANGLES));
        let m = read_ply(&path, &opts()).unwrap();
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.normals, Some(vec![Vec3::Z; 4]));
        // flip_tex_coords defaults to false for PLY.
        assert_eq!(m.uvs.as_ref().unwrap()[3], Vec2::new(0.0, 0.25));
        assert_eq!(m.indices, [0, 1, 2, 0, 2, 3]);
        let flip = MeshOptions {
            flip_tex_coords: Some(true),
            ..opts()
        };
        let m = read_ply(&path, &flip).unwrap();
        assert_eq!(m.uvs.unwrap()[3], Vec2::new(0.0, 0.75));
        let m = read_ply(&path, &face_normals()).unwrap();
        assert_eq!(m.normals, None);
    }

    #[test]
    fn ply_binary_both_endians_and_all_index_types_agree_with_ascii() {
        let ascii = parse_ply(&ply_ascii(&TWO_TRIANGLES), &opts()).unwrap();
        for big in [false, true] {
            for (count, index) in [
                ("uchar", "int"),
                ("uchar", "uint"),
                ("ushort", "ushort"),
                ("int", "uchar"),
                ("uint", "char"),
                ("uchar", "short"),
            ] {
                let bytes = ply_binary(big, &TWO_TRIANGLES, count, index);
                let m = parse_ply(&bytes, &opts()).unwrap();
                assert_eq!(m, ascii, "big endian {big}, list {count} {index}");
            }
        }
    }

    #[test]
    fn ply_polygons_are_fanned_and_short_faces_skipped() {
        let faces: [&[u32]; 3] = [&[0, 1, 2, 3], &[3, 2], &[1, 2, 3]];
        let m = parse_ply(&ply_ascii(&faces), &opts()).unwrap();
        assert_eq!(m.indices, [0, 1, 2, 0, 2, 3, 1, 2, 3]);
        let m = parse_ply(&ply_binary(true, &faces, "uchar", "uint"), &opts()).unwrap();
        assert_eq!(m.indices, [0, 1, 2, 0, 2, 3, 1, 2, 3]);
    }

    fn ply_texcoords(names: &[&str]) -> Option<Vec<Vec2>> {
        let mut s = "ply\nformat ascii 1.0\nelement vertex 3\n".to_string();
        for n in ["x", "y", "z"].iter().chain(names) {
            s += &format!("property float {n}\n");
        }
        s += "element face 1\nproperty list uchar uint vertex_index\nend_header\n";
        for k in 0..3 {
            let extra: Vec<String> = (0..names.len()).map(|j| format!("{}", j + 1)).collect();
            s += &format!("{k} {} 0 {}\n", k % 2, extra.join(" "));
        }
        s += "3 0 1 2\n";
        parse_ply(s.as_bytes(), &opts()).unwrap().uvs
    }

    #[test]
    fn ply_texture_coordinate_names_in_mitsubas_order() {
        let uv = |u: f32, v: f32| Some(vec![Vec2::new(u, v); 3]);
        assert_eq!(ply_texcoords(&["u", "v"]), uv(1.0, 2.0));
        assert_eq!(ply_texcoords(&["texture_u", "texture_v"]), uv(1.0, 2.0));
        assert_eq!(ply_texcoords(&["s", "t"]), uv(1.0, 2.0));
        assert_eq!(ply_texcoords(&["s", "t", "u", "v"]), uv(3.0, 4.0));
        assert_eq!(
            ply_texcoords(&["s", "t", "texture_u", "texture_v"]),
            uv(3.0, 4.0)
        );
        assert_eq!(ply_texcoords(&["texture_s", "texture_t"]), None);
        assert_eq!(ply_texcoords(&["u"]), None);
    }

    #[test]
    fn ply_zero_normals_are_computed_instead() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nproperty float nx\nproperty float ny\n\
                    property float nz\nelement face 1\nproperty list uchar int vertex_indices\n\
                    end_header\n0 0 0 0 0 0\n1 0 0 0 0 2\n0 1 0 0 1 0\n3 0 1 2\n";
        let m = parse_ply(text.as_bytes(), &opts()).unwrap();
        assert_eq!(m.normals, Some(vec![Vec3::Z, Vec3::Z, Vec3::Y]));
    }

    #[test]
    fn ply_without_faces_or_with_integer_positions() {
        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty uchar x\n\
                    property short y\nproperty double z\nend_header\n128 -3 0.5\n255 1 1\n";
        let m = parse_ply(text.as_bytes(), &opts()).unwrap();
        // A plain cast, as Mitsuba does.
        assert_eq!(
            m.positions,
            [Vec3::new(128.0, -3.0, 0.5), Vec3::new(255.0, 1.0, 1.0)]
        );
        assert!(m.indices.is_empty());
        assert_eq!(m.normals, Some(vec![Vec3::X; 2]));
    }

    #[test]
    fn ply_errors() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                    end_header\n";
        let verts = "0 0 0\n1 0 0\n0 1 0\n";
        let ascii = |s: String| parse_ply(s.as_bytes(), &opts());
        let cases = [
            (
                ascii(format!("{head}{verts}3 0 1 3\n")),
                "triangle 0: vertex index 3 out of range (3 vertices)",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 -1\n")),
                "face 0: negative vertex index -1",
            ),
            (ascii(format!("{head}{verts}3 0 1\n")), "line 13: face 0:"),
            (
                ascii(format!("{head}{verts}")),
                "the header declares 1 face records, more than the 18 bytes after it can hold",
            ),
            (
                ascii(format!("{head}0 0 0.000000000000000\n1 0 0\n")),
                "line 12: vertex 2: unexpected end of file",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n4\n")),
                "2 bytes of trailing content",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n").replace("float x", "float w")),
                "vertex element has no property x",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n").replace("vertex_indices", "corners")),
                "face element has no vertex_index or vertex_indices property",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n").replace("uchar int", "uchar float")),
                "face property vertex_indices is not a list of integers",
            ),
            (
                ascii(
                    format!("{head}{verts}3 0 1 2\n")
                        .replace("vertex 3", "vertex 18446744073709551615"),
                ),
                "the header declares 18446744073709551615 vertex records",
            ),
            (
                ascii(
                    format!("{head}{verts}3 0 1 2\n")
                        .replace("face 1", "face 99999999999999999999999"),
                ),
                "invalid PLY header",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n").replace("ply\n", "plx\n")),
                "invalid PLY header",
            ),
            (
                ascii(format!("{head}{verts}3 0 1 2\n").replace("end_header\n", "")),
                "invalid PLY header",
            ),
            (
                ascii(format!("{head}0 0 nan\n1 0 0\n0 1 0\n3 0 1 2\n")),
                "line 10: vertex 0:",
            ),
            (
                ascii(format!("{head}0 0 1e39\n1 0 0\n0 1 0\n3 0 1 2\n")),
                "vertex 0 has a non-finite position",
            ),
        ];
        for (result, expected) in cases {
            let e = err(result);
            assert!(e.starts_with(expected), "expected {expected:?}, got {e:?}");
        }
        // Binary: trailing bytes, a truncated list, a huge list count.
        let mut bytes = ply_binary(false, &TWO_TRIANGLES, "uchar", "int");
        bytes.push(0);
        assert!(err(parse_ply(&bytes, &opts())).contains("trailing content"));
        let bytes = ply_binary(false, &TWO_TRIANGLES, "uint", "int");
        let header_len = ply_header("binary_little_endian", 2, "uint int").len();
        let mut huge = bytes.clone();
        let first_face = header_len + 4 * 33;
        huge[first_face..first_face + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(
            err(parse_ply(&huge, &opts())),
            "face 0: unexpected end of file"
        );
    }

    // ---- serialized -----------------------------------------------------

    struct Shape<'a> {
        flags: u32,
        positions: &'a [[f64; 3]],
        normals: Option<&'a [[f64; 3]]>,
        uvs: Option<&'a [[f64; 2]]>,
        colors: Option<&'a [[f64; 3]]>,
        triangles: &'a [[u32; 3]],
    }

    const SQ_POSITIONS: [[f64; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.1],
    ];
    const SQ_NORMALS: [[f64; 3]; 4] = [[0.0, 0.0, 3.0]; 4];
    const SQ_UVS: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.25]];
    const SQ_TRIANGLES: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    fn square(flags: u32) -> Shape<'static> {
        Shape {
            flags,
            positions: &SQ_POSITIONS,
            normals: (flags & HAS_NORMALS != 0).then_some(&SQ_NORMALS[..]),
            uvs: (flags & HAS_TEXCOORDS != 0).then_some(&SQ_UVS[..]),
            colors: (flags & HAS_COLORS != 0).then_some(&SQ_NORMALS[..]),
            triangles: &SQ_TRIANGLES,
        }
    }

    /// One mesh: its two-u16 header and its zlib stream.
    fn serialized_mesh(version: u16, s: &Shape) -> Vec<u8> {
        let double = s.flags & DOUBLE_PRECISION != 0;
        let mut body = s.flags.to_le_bytes().to_vec();
        if version == 4 {
            body.extend(b"a shape\0");
        }
        body.extend((s.positions.len() as u64).to_le_bytes());
        body.extend((s.triangles.len() as u64).to_le_bytes());
        let mut floats = |values: &mut dyn Iterator<Item = f64>| {
            for v in values {
                if double {
                    body.extend(v.to_le_bytes());
                } else {
                    body.extend((v as f32).to_le_bytes());
                }
            }
        };
        floats(&mut s.positions.iter().flatten().copied());
        floats(&mut s.normals.unwrap_or_default().iter().flatten().copied());
        floats(&mut s.uvs.unwrap_or_default().iter().flatten().copied());
        floats(&mut s.colors.unwrap_or_default().iter().flatten().copied());
        for i in s.triangles.iter().flatten() {
            body.extend(i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&body).unwrap();
        let mut out = SERIALIZED_MAGIC.to_le_bytes().to_vec();
        out.extend(version.to_le_bytes());
        out.extend(z.finish().unwrap());
        out
    }

    /// A file of several meshes and the offset table.
    fn serialized_file(version: u16, shapes: &[Shape]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for s in shapes {
            offsets.push(out.len() as u64);
            out.extend(serialized_mesh(version, s));
        }
        for o in &offsets {
            if version == 4 {
                out.extend(o.to_le_bytes());
            } else {
                out.extend((*o as u32).to_le_bytes());
            }
        }
        out.extend((offsets.len() as u32).to_le_bytes());
        out
    }

    fn shape(index: u32) -> MeshOptions {
        MeshOptions {
            shape_index: index,
            ..opts()
        }
    }

    #[test]
    fn serialized_reads_normals_and_uvs_from_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let bytes = serialized_file(4, &[square(HAS_NORMALS | HAS_TEXCOORDS)]);
        let path = write(&dir, "s.serialized", &bytes);
        let m = read_serialized(&path, &opts()).unwrap();
        assert_eq!(m.positions[3], Vec3::new(0.0, 1.0, 0.1));
        assert_eq!(m.normals, Some(vec![Vec3::Z; 4]));
        // No flip: the serialized plugin has no flip_tex_coords.
        assert_eq!(m.uvs.unwrap()[3], Vec2::new(0.0, 0.25));
        assert_eq!(m.indices, [0, 1, 2, 0, 2, 3]);
        let flip = MeshOptions {
            flip_tex_coords: Some(false),
            ..opts()
        };
        assert!(err(read_serialized(&path, &flip)).contains("flip_tex_coords"));
    }

    #[test]
    fn serialized_several_shapes_v3_and_v4() {
        let mut moved = SQ_POSITIONS;
        moved[0] = [5.0, 5.0, 5.0];
        let shapes = [
            square(HAS_NORMALS),
            Shape {
                positions: &moved,
                ..square(DOUBLE_PRECISION | HAS_TEXCOORDS)
            },
            square(HAS_COLORS | HAS_TEXCOORDS),
        ];
        for version in [3, 4] {
            let bytes = serialized_file(version, &shapes);
            let a = parse_serialized(&bytes, &shape(0)).unwrap();
            let b = parse_serialized(&bytes, &shape(1)).unwrap();
            let c = parse_serialized(&bytes, &shape(2)).unwrap();
            assert_eq!(a.normals, Some(vec![Vec3::Z; 4]));
            assert_eq!(a.uvs, None);
            assert_eq!(b.positions[0], Vec3::splat(5.0));
            assert_eq!(b.uvs.as_ref().unwrap()[1], Vec2::X);
            assert_eq!(c.uvs, b.uvs);
            assert_eq!(c.positions, a.positions);
            assert_eq!(
                err(parse_serialized(&bytes, &shape(3))),
                "shape index 3 out of range (3 shapes in the file)"
            );
        }
    }

    #[test]
    fn serialized_double_precision_rounds_to_f32() {
        let third = [[1.0 / 3.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let s = Shape {
            positions: &third,
            triangles: &[[0, 1, 2]],
            ..square(DOUBLE_PRECISION)
        };
        let m = parse_serialized(&serialized_file(4, &[s]), &opts()).unwrap();
        assert_eq!(m.positions[0].x, (1.0f64 / 3.0) as f32);
    }

    #[test]
    fn serialized_face_normals_drop_normals_and_the_file_flag_is_ignored() {
        // 0x0010 in the file does not set face normals (Mitsuba 3).
        let bytes = serialized_file(4, &[square(HAS_NORMALS | 0x0010)]);
        let m = parse_serialized(&bytes, &opts()).unwrap();
        assert_eq!(m.normals, Some(vec![Vec3::Z; 4]));
        let m = parse_serialized(&bytes, &face_normals()).unwrap();
        assert_eq!(m.normals, None);
        // Without normals in the file they are computed.
        let bytes = serialized_file(3, &[square(0)]);
        let n = parse_serialized(&bytes, &opts()).unwrap().normals.unwrap();
        assert!(close3(n[1], Vec3::Z));
    }

    #[test]
    fn serialized_errors() {
        let good = serialized_file(4, &[square(HAS_NORMALS)]);
        let mut magic = good.clone();
        magic[0] = 0x1D;
        assert_eq!(
            err(parse_serialized(&magic, &opts())),
            "not a Mitsuba serialized file (format 0x041D, expected 0x041C)"
        );
        let mut version = good.clone();
        version[2] = 5;
        assert!(err(parse_serialized(&version, &opts())).contains("version 5"));
        assert!(err(parse_serialized(&good[..3], &opts())).contains("too short"));
        let cut = &good[..good.len() - 20];
        let e = err(parse_serialized(cut, &opts()));
        assert!(e.starts_with("the stream ends in"), "{e}");
        let mut corrupt = good.clone();
        corrupt[10] ^= 0xFF;
        err(parse_serialized(&corrupt, &opts()));
        // Counts past Mitsuba's 32 bits; counts the stream does not hold.
        let many = [[0.0; 3]; 1];
        let s = Shape {
            positions: &many,
            triangles: &[],
            ..square(0)
        };
        let mut body = serialized_mesh(3, &s);
        let mut raw = Vec::new();
        flate2::read::ZlibDecoder::new(&body[4..])
            .read_to_end(&mut raw)
            .unwrap();
        for (vertices, expected) in [
            (1u64 << 40, "more than Mitsuba's"),
            (u32::MAX as u64, "the stream ends in positions"),
        ] {
            raw[4..12].copy_from_slice(&vertices.to_le_bytes());
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            z.write_all(&raw).unwrap();
            body.truncate(4);
            body.extend(z.finish().unwrap());
            assert!(err(parse_serialized(&body, &opts())).contains(expected));
        }
        // A broken table: an offset past the end, and a count past it.
        let mut table = serialized_file(4, &[square(0), square(0)]);
        let n = table.len();
        table[n - 12..n - 4].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(err(parse_serialized(&table, &shape(1))).contains("past the end"));
        table[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(err(parse_serialized(&table, &shape(7))).contains("does not fit"));
        // An index out of range.
        let s = Shape {
            triangles: &[[0, 1, 4]],
            ..square(0)
        };
        let e = err(parse_serialized(&serialized_file(4, &[s]), &opts()));
        assert_eq!(e, "triangle 0: vertex index 4 out of range (4 vertices)");
    }

    // ---- no panics on damaged files ---------------------------------------

    /// Every prefix of a valid file, and every byte of it changed, reads as
    /// a mesh or an error, never a panic or a hang.
    fn damage(bytes: &[u8], parse: fn(&[u8], &MeshOptions) -> Result<Mesh, String>) {
        for options in [opts(), face_normals(), shape(1)] {
            for len in 0..bytes.len() {
                let _ = parse(&bytes[..len], &options);
            }
        }
        let mut copy = bytes.to_vec();
        for i in 0..copy.len() {
            for x in [0x01, 0x80, 0xFF] {
                copy[i] ^= x;
                let _ = parse(&copy, &opts());
                copy[i] ^= x;
            }
        }
    }

    #[test]
    fn damaged_files_do_not_panic() {
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 1\nvn 0 0 1\n\
                   f 1/1/1 2/2/1 3/1/1 4/2/1\nf -1//1 -2//1 -3//1\nf 1/2 2 3//1\n";
        damage(obj.as_bytes(), parse_obj);
        damage(&ply_ascii(&TWO_TRIANGLES), parse_ply);
        damage(
            &ply_binary(false, &TWO_TRIANGLES, "uchar", "int"),
            parse_ply,
        );
        damage(
            &ply_binary(true, &TWO_TRIANGLES, "ushort", "uint"),
            parse_ply,
        );
        let shapes = [
            square(HAS_NORMALS | HAS_TEXCOORDS),
            square(DOUBLE_PRECISION | HAS_COLORS),
        ];
        damage(&serialized_file(3, &shapes), parse_serialized);
        damage(&serialized_file(4, &shapes), parse_serialized);
    }
}
