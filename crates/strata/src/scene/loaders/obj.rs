//! Wavefront OBJ (+ MTL) through `tobj`.
//!
//! Polygons are fan-triangulated, points and lines ignored. Each OBJ object/group/material run
//! becomes one part named after its `o`/`g` name. MTL: `Kd` → color, `d` → opacity (or
//! `Tr` → 1 − opacity); other fields are ignored, and a material without `d`/`Tr` keeps the
//! default opacity (0.5) so a model stays see-through. A missing or unreadable `.mtl` is a
//! warning, not an error. Face indices are checked before `tobj` sees them, so a bad index is a
//! one-line error with its line number instead of a panic.

use std::cell::RefCell;
use std::io::{BufRead, Read};
use std::path::Path;

use super::{finish_mesh, Part};
use crate::error::{Error, Result};
use crate::scene::{Material, Mesh};

/// What the material-library callback found for an `mtllib` reference.
pub(crate) enum MtlLookup {
    /// The library's text.
    Text(String),
    /// Not available; the reason becomes a warning.
    Missing(String),
    /// Not available, and that is expected (embedded models): no warning.
    Skip,
}

/// Parses an OBJ file's bytes (`what` names it); `.mtl` libraries are looked up under `dir`.
pub(super) fn parse_bytes(
    bytes: &[u8],
    what: &str,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let text = String::from_utf8_lossy(bytes);
    let lookup = |lib: &Path| {
        let full = dir.join(lib);
        match super::read_capped(&full, super::MAX_MTL_BYTES) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(t) => MtlLookup::Text(t),
                Err(_) => MtlLookup::Missing(format!("'{}' is not UTF-8 text", full.display())),
            },
            Err(why) => MtlLookup::Missing(format!("'{}' {why}", full.display())),
        }
    };
    parse_obj_text(&text, what, &lookup, warnings)
}

/// Parses OBJ text; `what` names it in errors and warnings. Parts have normals and are valid.
pub(crate) fn parse_obj_text(
    text: &str,
    what: &str,
    mtl: &dyn Fn(&Path) -> MtlLookup,
    warnings: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let degenerate = check_face_indices(text, what)?;
    let kept: String;
    let text = match degenerate.first() {
        None => text,
        Some(first) => {
            warnings.push(format!(
                "{what}: skipped {} face(s) with fewer than 3 vertices (the first at line {}; a line is 'l')",
                degenerate.len(),
                first + 1
            ));
            // Blank lines keep the others' numbers for later messages.
            kept = text
                .lines()
                .enumerate()
                .map(|(i, line)| match degenerate.binary_search(&i) {
                    Ok(_) => "",
                    Err(_) => line,
                })
                .collect::<Vec<_>>()
                .join("\n");
            &kept
        }
    };
    let mtl_warnings = RefCell::new(Vec::new());
    let loader = |lib: &Path| -> tobj::MTLLoadResult {
        let fail = |msg: String| {
            mtl_warnings.borrow_mut().push(format!(
                "{what}: material library '{}' not used ({msg}); using default materials",
                lib.display()
            ));
            Err(tobj::LoadError::OpenFileFailed)
        };
        match mtl(lib) {
            MtlLookup::Skip => Err(tobj::LoadError::OpenFileFailed),
            MtlLookup::Missing(msg) => fail(msg),
            MtlLookup::Text(t) => match check_mtl(&t) {
                Err(msg) => fail(msg),
                Ok(()) => {
                    let mut reader = LineCounter::new(t.as_bytes());
                    tobj::load_mtl_buf(&mut reader)
                        .or_else(|e| fail(format!("line {}: {e}", reader.line())))
                }
            },
        }
    };
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = LineCounter::new(text.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, loader)
        .map_err(|e| Error::input(format!("{what}: line {}: {e}", reader.line())))?;
    warnings.extend(mtl_warnings.into_inner());
    let materials = materials.unwrap_or_default();

    let stem = what
        .rsplit(['/', '\\', ':'])
        .next()
        .unwrap_or(what)
        .trim_end_matches(".obj")
        .to_string();
    let mut parts = Vec::new();
    for model in models {
        let m = model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let name = if model.name.is_empty() || model.name == "unnamed_object" {
            stem.clone()
        } else {
            model.name
        };
        let mesh = Mesh {
            positions: m
                .positions
                .chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]])
                .collect(),
            normals: m
                .normals
                .chunks_exact(3)
                .map(|n| [n[0], n[1], n[2]])
                .collect(),
            indices: m.indices,
        };
        let mesh = finish_mesh(mesh, &format!("{what}: object '{name}'"))?;
        let material = m
            .material_id
            .and_then(|i| materials.get(i))
            .map(|mat| convert_material(mat, what, warnings));
        parts.push((name, mesh, material));
    }
    Ok(parts)
}

fn convert_material(m: &tobj::Material, what: &str, warnings: &mut Vec<String>) -> Material {
    let mut out = Material {
        name: m.name.clone(),
        ..Material::default()
    };
    if let Some(kd) = m.diffuse {
        if kd.iter().all(|c| c.is_finite() && *c >= 0.0) {
            out.color = kd;
        } else {
            warnings.push(format!(
                "{what}: material '{}': Kd {kd:?} is not a color; using the default",
                m.name
            ));
        }
    }
    let opacity = m.dissolve.map(|d| ("d", d)).or_else(|| {
        let tr = m.unknown_param.get("Tr")?.split_whitespace().next()?;
        tr.parse::<f32>().ok().map(|t| ("Tr", 1.0 - t))
    });
    if let Some((key, a)) = opacity {
        if (0.0..=1.0).contains(&a) {
            out.opacity = a;
        } else {
            let clamped = if a.is_nan() { 1.0 } else { a.clamp(0.0, 1.0) };
            warnings.push(format!(
                "{what}: material '{}': {key} gives opacity {a}, outside [0, 1]; using {clamped}",
                m.name
            ));
            out.opacity = clamped;
        }
    }
    out
}

/// Checks every face's position/texcoord/normal references against what is defined so far
/// (`tobj` would return a less precise error for positions, and can overflow on a texcoord or
/// normal index of 0); returns the lines (from 0) of the faces with fewer than 3 corners, which
/// draw nothing and are skipped.
fn check_face_indices(text: &str, what: &str) -> Result<Vec<usize>> {
    let mut degenerate = Vec::new();
    let mut counts = [0i64; 3];
    const KINDS: [&str; 3] = ["vertex", "texcoord", "normal"];
    const PLURALS: [&str; 3] = ["vertices", "texcoords", "normals"];
    for (line_no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some(kind @ ("f" | "l")) => {
                let corners = words.clone().take_while(|w| !w.starts_with('#')).count();
                if kind == "f" && corners < 3 {
                    degenerate.push(line_no);
                    continue;
                }
                for word in words {
                    for (k, field) in word.split('/').take(3).enumerate() {
                        let Ok(x) = field.parse::<i64>() else {
                            // Empty (v//vn) or malformed: tobj reports the latter.
                            continue;
                        };
                        let n = counts[k];
                        if k > 0 && n == 0 {
                            // tobj ignores texcoord/normal references when there are none.
                            continue;
                        }
                        let resolved = if x < 0 { n + x } else { x - 1 };
                        if x == 0 || resolved < 0 || resolved >= n {
                            return Err(Error::input(format!(
                                "{what}: line {}: face {} index {x} is out of range ({n} {} defined before it)",
                                line_no + 1,
                                KINDS[k],
                                PLURALS[k]
                            )));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(degenerate)
}

/// Rejects what would make `tobj` panic in an MTL file: a color line with fewer than three
/// values.
fn check_mtl(text: &str) -> std::result::Result<(), String> {
    for (line_no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            if words.count() < 3 {
                return Err(format!("line {}: {key} needs three values", line_no + 1));
            }
        }
    }
    Ok(())
}

/// A `BufRead` over bytes that knows which line it has read up to, to put line numbers on
/// `tobj`'s errors.
struct LineCounter<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> LineCounter<'a> {
    fn new(data: &'a [u8]) -> Self {
        LineCounter { data, pos: 0 }
    }

    /// 1-based number of the last line read.
    fn line(&self) -> usize {
        let read = &self.data[..self.pos];
        let newlines = read.iter().filter(|&&b| b == b'\n').count();
        if read.last().is_none_or(|&b| b == b'\n') {
            newlines.max(1)
        } else {
            newlines + 1
        }
    }
}

impl Read for LineCounter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = (&self.data[self.pos..]).read(buf)?;
        self.pos += n;
        Ok(n)
    }
}

impl BufRead for LineCounter<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.data[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.data.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<Part>> {
        parse_obj_text(text, "t.obj", &|_| MtlLookup::Skip, &mut Vec::new())
    }

    #[test]
    fn quads_and_polygons_are_triangulated_with_normals() {
        let parts =
            parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nf 1 2 3 4\nf 1 2 3 5 4\n")
                .unwrap();
        assert_eq!(parts.len(), 1);
        let (name, mesh, mat) = &parts[0];
        assert_eq!(name, "t");
        assert!(mat.is_none());
        assert_eq!(mesh.triangle_count(), 2 + 3);
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        for n in &mesh.normals {
            assert!((n[2] - 1.0).abs() < 1e-6, "{n:?}");
        }
    }

    #[test]
    fn bad_indices_never_panic() {
        for (src, needle) in [
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
                "line 4: face vertex index 4",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
                "face vertex index 0",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n",
                "face vertex index -4",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/0 2/1 3/1\n",
                "face texcoord index 0",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//2 2//1 3//1\n",
                "face normal index 2",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
                "line 4: face parse error",
            ),
            ("v 0 0\n", "line 1: position parse error"),
        ] {
            let e = parse(src).unwrap_err().to_string();
            assert!(
                e.starts_with("t.obj: ") && e.contains(needle),
                "{src:?}: {e}"
            );
            assert!(!e.contains('\n'));
        }
    }

    #[test]
    fn relative_indices_and_colors_from_mtl() {
        let mtl = "newmtl red\nKd 1 0 0\nd 0.25\nnewmtl blue\nKd 0 0 1\nTr 0.6\nnewmtl plain\n";
        let lookup = |_: &Path| MtlLookup::Text(mtl.to_string());
        let src = "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf -3 -2 -1\n\
                   usemtl blue\nf 1 2 3\nusemtl plain\nf 3 2 1\n";
        let parts = parse_obj_text(src, "t.obj", &lookup, &mut Vec::new()).unwrap();
        assert_eq!(parts.len(), 3);
        let red = parts[0].2.as_ref().unwrap();
        assert_eq!(
            (red.name.as_str(), red.color, red.opacity),
            ("red", [1.0, 0.0, 0.0], 0.25)
        );
        let blue = parts[1].2.as_ref().unwrap();
        assert!((blue.opacity - 0.4).abs() < 1e-6);
        let plain = parts[2].2.as_ref().unwrap();
        assert_eq!(plain.opacity, Material::default().opacity);
    }

    #[test]
    fn short_color_line_in_mtl_is_a_warning() {
        let lookup = |_: &Path| MtlLookup::Text("newmtl a\nKd 1 0\n".to_string());
        let mut w = Vec::new();
        let src = "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
        let parts = parse_obj_text(src, "t.obj", &lookup, &mut w).unwrap();
        assert!(parts[0].2.is_none());
        assert_eq!(w.len(), 1);
        assert!(
            w[0].contains("x.mtl") && w[0].contains("Kd needs three values"),
            "{w:?}"
        );
    }

    #[test]
    fn line_counter_counts() {
        let mut r = LineCounter::new(b"a\nbb\nc");
        let mut s = String::new();
        r.read_line(&mut s).unwrap();
        assert_eq!(r.line(), 1);
        r.read_line(&mut s).unwrap();
        assert_eq!(r.line(), 2);
        r.read_line(&mut s).unwrap();
        assert_eq!(r.line(), 3);
    }
}
