//! Stanford PLY (ascii, binary little and big endian) through `ply-rs`.
//!
//! Reads the `vertex` element's `x`, `y`, `z` (any numeric type) and, when all three are present,
//! `nx`, `ny`, `nz`; and the `face` element's `vertex_indices` (or `vertex_index`) integer list,
//! fan-triangulating polygons. Other elements and properties are skipped. Vertex colors
//! (`red`, `green`, `blue`: 8-bit, 16-bit or float in [0, 1], taken as sRGB) are averaged (in
//! linear RGB) into the part's material color, since strata colors whole objects; without them
//! the part has no material of its own. The whole file is one part named after the file stem.

use std::io::BufRead;

use ply_rs::parser::Parser;
use ply_rs::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType,
};

use super::{finish_mesh, Part};
use crate::error::{Error, Result};
use crate::scene::{srgb_to_linear, Material, Mesh};

#[derive(Default)]
struct Vertex {
    position: [f64; 3],
    normal: [f64; 3],
    color: [f64; 3],
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_property(&mut self, name: String, p: Property) {
        let Some(v) = scalar(&p) else { return };
        // Colors to [0, 1] by their type's range.
        let unit = match p {
            Property::UChar(_) | Property::Char(_) => v / 255.0,
            Property::UShort(_) | Property::Short(_) => v / 65535.0,
            _ => v,
        };
        match name.as_str() {
            "x" => self.position[0] = v,
            "y" => self.position[1] = v,
            "z" => self.position[2] = v,
            "nx" => self.normal[0] = v,
            "ny" => self.normal[1] = v,
            "nz" => self.normal[2] = v,
            "red" => self.color[0] = unit,
            "green" => self.color[1] = unit,
            "blue" => self.color[2] = unit,
            _ => {}
        }
    }
}

#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }
    fn set_property(&mut self, name: String, p: Property) {
        if name != "vertex_indices" && name != "vertex_index" {
            return;
        }
        self.indices = match p {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return,
        };
    }
}

/// Elements we do not use.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// ply-rs errors span several lines (`Line 3: ...\n\tString: ...`): one line for ours.
fn one_line(e: impl std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// A binary read's error in one line: ply-rs wraps the end of the file inside a list in an
/// error of another kind whose message is the inner error's debug form.
fn binary_error(e: &std::io::Error) -> String {
    let text = e.to_string();
    if e.kind() == std::io::ErrorKind::UnexpectedEof || text.contains("UnexpectedEof") {
        return "the file ends early".into();
    }
    one_line(text.split(" Error: Error {").next().unwrap_or(&text))
}

const SCALAR_TYPES: [&str; 16] = [
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16",
    "uint16", "int32", "uint32", "float32", "float64",
];

/// Checks the header line by line before `ply-rs` reads it (its errors are debug structures,
/// and it unwraps a u64 parse), so a bad header gets one line: the line number, the line, what
/// was expected. Also refuses a face count over the scene limit before anything is read.
fn check_header(bytes: &[u8], what: &str) -> Result<()> {
    let mut ended = false;
    let mut element: Option<String> = None;
    let mut properties: Vec<String> = Vec::new();
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(raw);
        let line = line.trim();
        let bad = |expected: &str| {
            let shown = crate::error::quoted(line);
            Error::input(format!(
                "{what}: header line {}: '{shown}': expected {expected}",
                i + 1
            ))
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            _ if i == 0 => {
                if line != "ply" {
                    return Err(bad("'ply'"));
                }
            }
            ["end_header"] => {
                ended = true;
                break;
            }
            [] => {}
            ["comment" | "obj_info", ..] => {}
            ["format", encoding, version] => {
                if !["ascii", "binary_little_endian", "binary_big_endian"].contains(encoding) {
                    return Err(bad(
                        "format ascii, binary_little_endian or binary_big_endian",
                    ));
                }
                if *version != "1.0" {
                    return Err(bad("format version 1.0"));
                }
            }
            ["element", name, count] => {
                let count: u64 = count
                    .parse()
                    .ok()
                    .filter(|_| count.len() <= 18)
                    .ok_or_else(|| bad("element NAME COUNT with a count below 10^18"))?;
                if *name == "face" {
                    crate::scene::check_triangle_estimate(
                        &format!("{what}: header line {}: element face {count}", i + 1),
                        count,
                    )?;
                }
                element = Some(name.to_string());
                properties.clear();
            }
            ["property", "list", count_type, item_type, name] => {
                for t in [count_type, item_type] {
                    if !SCALAR_TYPES.contains(t) {
                        return Err(bad(&format!(
                            "property list COUNT_TYPE ITEM_TYPE NAME with types among {}",
                            SCALAR_TYPES.join(", ")
                        )));
                    }
                }
                property(&bad, &element, &mut properties, name)?;
            }
            ["property", scalar_type, name] => {
                if !SCALAR_TYPES.contains(scalar_type) {
                    return Err(bad(&format!(
                        "property TYPE NAME with TYPE among {} (or property list ...)",
                        SCALAR_TYPES.join(", ")
                    )));
                }
                property(&bad, &element, &mut properties, name)?;
            }
            _ => {
                return Err(bad(
                    "format, element, property, comment, obj_info or end_header",
                ))
            }
        }
    }
    if !ended {
        return Err(Error::input(format!(
            "{what}: the header has no 'end_header' line"
        )));
    }
    Ok(())
}

/// Records a property of the current element; a property outside an element or given twice is
/// an error.
fn property(
    bad: &dyn Fn(&str) -> Error,
    element: &Option<String>,
    properties: &mut Vec<String>,
    name: &str,
) -> Result<()> {
    if element.is_none() {
        return Err(bad("an 'element' line before the first property"));
    }
    if properties.iter().any(|p| p == name) {
        return Err(bad(&format!(
            "a property name not already used ('{name}' is)"
        )));
    }
    properties.push(name.to_string());
    Ok(())
}

/// Reads the elements of one kind, one by one, so an error says which element (and, in an
/// ascii file, which line) is bad.
struct ElementReader<'a, 'b> {
    what: &'a str,
    reader: &'a mut &'b [u8],
    encoding: &'a Encoding,
    /// Lines read so far (ascii).
    line: &'a mut usize,
}

impl ElementReader<'_, '_> {
    fn read<E: PropertyAccess>(&mut self, def: &ElementDef) -> Result<Vec<E>> {
        let parser = Parser::<E>::new();
        let what = self.what;
        let name = &def.name;
        let mut out = Vec::new();
        for i in 0..def.count {
            let element = match self.encoding {
                Encoding::Ascii => {
                    let mut text = String::new();
                    let n = self.reader.read_line(&mut text).map_err(|e| {
                        Error::input(format!("{what}: line {}: {e}", *self.line + 1))
                    })?;
                    *self.line += 1;
                    if n == 0 {
                        return Err(Error::input(format!(
                            "{what}: file ends at {name} {i} of {} declared",
                            def.count
                        )));
                    }
                    parser.read_ascii_element(&text, def).map_err(|_| {
                        Error::input(format!(
                            "{what}: line {}: {name} {i}: cannot read '{}' as {}",
                            *self.line,
                            text.trim(),
                            property_list(def)
                        ))
                    })?
                }
                Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
                    let read = if *self.encoding == Encoding::BinaryLittleEndian {
                        parser.read_little_endian_element(self.reader, def)
                    } else {
                        parser.read_big_endian_element(self.reader, def)
                    };
                    read.map_err(|e| {
                        let why = binary_error(&e);
                        Error::input(format!("{what}: binary {name} {i} of {}: {why}", def.count))
                    })?
                }
            };
            out.push(element);
        }
        Ok(out)
    }
}

/// `x y z (list vertex_indices)`, the properties an element line holds.
fn property_list(def: &ElementDef) -> String {
    def.properties
        .values()
        .map(|p| match p.data_type {
            PropertyType::Scalar(_) => p.name.clone(),
            PropertyType::List(..) => format!("(list {})", p.name),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

pub(super) fn parse(bytes: &[u8], what: &str, name: &str) -> Result<Vec<Part>> {
    if !bytes.starts_with(b"ply") {
        return Err(Error::input(format!(
            "{what}: not a PLY file (it does not start with 'ply')"
        )));
    }
    check_header(bytes, what)?;
    let mut reader: &[u8] = bytes;
    let header: Header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| Error::input(format!("{what}: bad header: {}", one_line(e))))?;

    let vertex_def = header
        .elements
        .get("vertex")
        .ok_or_else(|| Error::input(format!("{what}: no 'vertex' element")))?;
    for axis in ["x", "y", "z"] {
        if !vertex_def.properties.contains_key(axis) {
            return Err(Error::input(format!(
                "{what}: vertex element has no '{axis}' property"
            )));
        }
    }
    let has_normals = ["nx", "ny", "nz"]
        .iter()
        .all(|n| vertex_def.properties.contains_key(*n));
    let has_colors = ["red", "green", "blue"]
        .iter()
        .all(|n| vertex_def.properties.contains_key(*n));
    let face_def = header.elements.get("face").ok_or_else(|| {
        Error::input(format!(
            "{what}: no 'face' element (point clouds are not supported)"
        ))
    })?;
    let list = ["vertex_indices", "vertex_index"]
        .iter()
        .find_map(|n| face_def.properties.get(*n))
        .ok_or_else(|| {
            Error::input(format!("{what}: face element has no 'vertex_indices' list"))
        })?;
    match &list.data_type {
        PropertyType::List(_, ScalarType::Float | ScalarType::Double) | PropertyType::Scalar(_) => {
            return Err(Error::input(format!(
                "{what}: face '{}' must be a list of integers",
                list.name
            )))
        }
        PropertyType::List(..) => {}
    }

    // File line of the first data line (ascii).
    let mut line = bytes[..bytes.len() - reader.len()]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    for (name, def) in &header.elements {
        let mut r = ElementReader {
            what,
            reader: &mut reader,
            encoding: &header.encoding,
            line: &mut line,
        };
        match name.as_str() {
            "vertex" => vertices = r.read(def)?,
            "face" => faces = r.read(def)?,
            _ => {
                r.read::<Skip>(def)?;
            }
        }
    }
    if header.encoding == Encoding::Ascii {
        // Anything but whitespace after the declared elements means the counts are wrong.
        if !String::from_utf8_lossy(reader).trim().is_empty() {
            return Err(Error::input(format!(
                "{what}: line {}: more data than the header declares",
                line + 1
            )));
        }
    }

    let mut mesh = Mesh {
        positions: vertices
            .iter()
            .map(|v| v.position.map(|c| c as f32))
            .collect(),
        normals: if has_normals {
            vertices
                .iter()
                .map(|v| v.normal.map(|c| c as f32))
                .collect()
        } else {
            Vec::new()
        },
        indices: Vec::new(),
    };
    let n = vertices.len() as i64;
    for (f, face) in faces.iter().enumerate() {
        if let Some(&bad) = face.indices.iter().find(|&&i| i < 0 || i >= n) {
            return Err(Error::input(format!(
                "{what}: face {f}: vertex index {bad} is out of range ({n} vertices)"
            )));
        }
        for k in 2..face.indices.len() {
            mesh.indices.extend_from_slice(&[
                face.indices[0] as u32,
                face.indices[k - 1] as u32,
                face.indices[k] as u32,
            ]);
        }
    }
    let mesh = finish_mesh(mesh, what)?;
    let material = (has_colors && !vertices.is_empty()).then(|| {
        let mut sum = [0.0f64; 3];
        for v in &vertices {
            for (s, c) in sum.iter_mut().zip(v.color) {
                *s += srgb_to_linear(c.clamp(0.0, 1.0) as f32) as f64;
            }
        }
        Material {
            name: name.to_string(),
            color: sum.map(|s| (s / vertices.len() as f64) as f32),
            ..Material::default()
        }
    });
    Ok(vec![(name.to_string(), mesh, material)])
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment tiny\nelement vertex 4\n\
        property float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad_is_fanned() {
        let parts = parse(ASCII.as_bytes(), "q.ply", "q").unwrap();
        let (name, mesh, mat) = &parts[0];
        assert_eq!(name, "q");
        assert!(mat.is_none());
        assert_eq!(mesh.indices, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(mesh.normals.len(), 4);
    }

    #[test]
    fn malformed_inputs_are_one_line_errors() {
        let cases: [(&[u8], &str); 8] = [
            (b"hello", "not a PLY file"),
            (b"ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n", "count below 10^18"),
            (b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n", "no 'vertex' element"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n", "no 'z' property"),
            (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "vertex index 7 is out of range"),
            (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n", "file ends at vertex 2 of 3 declared"),
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x00\x00", "binary vertex 0 of 3: the file ends early"),
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\x00", "binary face 0 of 1: the file ends early"),
        ];
        for (src, needle) in cases {
            let e = parse(src, "bad.ply", "bad").unwrap_err().to_string();
            assert!(
                e.starts_with("bad.ply: ") && e.contains(needle),
                "{needle}: {e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn colors_average_to_material() {
        let src = "ply\nformat ascii 1.0\nelement vertex 3\n\
            property double x\nproperty double y\nproperty double z\n\
            property uchar red\nproperty uchar green\nproperty uchar blue\n\
            element face 1\nproperty list uchar uint vertex_index\nend_header\n\
            0 0 0 255 0 0\n1 0 0 255 0 0\n0 1 0 255 0 255\n3 0 1 2\n";
        let parts = parse(src.as_bytes(), "c.ply", "c").unwrap();
        let m = parts[0].2.as_ref().unwrap();
        assert!((m.color[0] - 1.0).abs() < 1e-6 && m.color[1] == 0.0);
        assert!((m.color[2] - 1.0 / 3.0).abs() < 1e-6);
    }
}
