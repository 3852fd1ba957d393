//! Decompositions kept between runs: one file per geometry in a directory the user names
//! (`--cache-dir`), read instead of repeating a preprocess that takes seconds on large meshes.
//!
//! A file is named by a stable hash of the triangles (FNV-1a over their coordinates' bits) and
//! their count, and begins with a magic, the format version and the preprocess's parameters:
//! a file written by another version, for other triangles or with other parameters is not
//! read. Files are written to a temporary name and renamed, so a reader never sees half of one;
//! a file that does not parse is reported (a warning) and made again. Little-endian binary:
//! header, statistics as JSON (and the preprocess time as bits), groups (parts, triangles, box, centroid, distinct vertices),
//! then the relations of overlapping pairs.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::decompose::{
    Decomposition, DecompositionStats, Group, Relation, Relations, Separation, MAX_PART_TRIANGLES,
    TOUCHING_CANDIDATES,
};

const MAGIC: &[u8; 8] = b"STRATAcx";
/// Bumped whenever the decomposition's algorithm or this layout changes.
const FORMAT_VERSION: u32 = 4;

/// What identifies a geometry's decomposition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Key {
    /// A hash of the triangles' positions.
    pub hash: u64,
    /// Triangles of the geometry.
    pub triangles: u64,
}

impl Key {
    /// FNV-1a over every coordinate's bits: the same on every run and platform.
    pub fn of(triangles: &[[Vec3; 3]]) -> Key {
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for t in triangles {
            for p in t {
                for c in p.to_array() {
                    for b in c.to_bits().to_le_bytes() {
                        hash = (hash ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
                    }
                }
            }
        }
        Key {
            hash,
            triangles: triangles.len() as u64,
        }
    }

    /// The file holding this geometry's decomposition in `dir`.
    pub fn path(&self, dir: &Path) -> PathBuf {
        dir.join(format!("convex-{:016x}-{}.bin", self.hash, self.triangles))
    }
}

/// The decomposition stored in `dir` for `key`: `Ok(None)` when there is none, `Err` (why)
/// when a file is there but cannot be used.
pub fn read(dir: &Path, key: Key) -> Result<Option<Decomposition>, String> {
    let path = key.path(dir);
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    decode(&bytes, key)
        .map(Some)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Stores `d` in `dir` for `key` (creating `dir`), through a temporary file and a rename.
pub fn write(dir: &Path, key: Key, d: &Decomposition) -> Result<(), String> {
    let path = key.path(dir);
    let fail = |e: std::io::Error| format!("{}: {e}", path.display());
    std::fs::create_dir_all(dir).map_err(fail)?;
    let temporary = dir.join(format!(
        ".convex-{:016x}-{}.{}.tmp",
        key.hash,
        key.triangles,
        std::process::id()
    ));
    let written = std::fs::File::create(&temporary)
        .and_then(|mut f| f.write_all(&encode(key, d)).and_then(|_| f.sync_all()))
        .and_then(|_| std::fs::rename(&temporary, &path));
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written.map_err(fail)
}

fn parameters() -> [u32; 2] {
    [MAX_PART_TRIANGLES as u32, TOUCHING_CANDIDATES as u32]
}

fn encode(key: Key, d: &Decomposition) -> Vec<u8> {
    let mut out = Writer::default();
    out.bytes(MAGIC);
    out.u32(FORMAT_VERSION);
    for p in parameters() {
        out.u32(p);
    }
    out.u64(key.hash);
    out.u64(key.triangles);
    out.f32(d.tolerance);
    let s = &d.stats;
    out.u64(s.triangles);
    for v in [s.parts, s.groups, s.paired, s.layers_per_group] {
        out.u32(v);
    }
    for v in [s.overlapping_pairs, s.nested, s.unseparated] {
        out.u64(v);
    }
    out.u64(s.preprocess_ms.to_bits());
    out.u32(d.groups.len() as u32);
    for g in &d.groups {
        out.u32(g.parts);
        out.u32s(&g.triangles);
        for v in [g.lo, g.hi, g.centroid] {
            out.vec3(v);
        }
        out.u32(g.points.len() as u32);
        for &p in &g.points {
            out.vec3(p);
        }
    }
    // In pair order, so the same decomposition always writes the same bytes.
    out.u64(d.relations.len() as u64);
    for ((i, j), r) in d.relations.iter() {
        out.u32(i);
        out.u32(j);
        match r {
            Relation::Plane(s) => {
                out.u32(0);
                out.vec3(s.normal);
                out.f32(s.offset);
            }
            Relation::Contains => out.u32(1),
            Relation::Inside => out.u32(2),
            Relation::Inseparable => out.u32(3),
            Relation::Coplanar => out.u32(4),
        }
    }
    out.0
}

fn decode(bytes: &[u8], key: Key) -> Result<Decomposition, String> {
    let mut r = Reader(bytes);
    if r.take(MAGIC.len())? != MAGIC {
        return Err("not a strata convex decomposition".into());
    }
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "format version {version}, this strata reads {FORMAT_VERSION}"
        ));
    }
    if [r.u32()?, r.u32()?] != parameters() {
        return Err("made with other preprocess parameters".into());
    }
    if (Key {
        hash: r.u64()?,
        triangles: r.u64()?,
    }) != key
    {
        return Err("made for other triangles".into());
    }
    let tolerance = r.f32()?;
    let triangles = r.u64()?;
    let [parts, groups, paired, layers_per_group] = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
    let [overlapping_pairs, nested, unseparated] = [r.u64()?, r.u64()?, r.u64()?];
    let stats = DecompositionStats {
        triangles,
        parts,
        groups,
        paired,
        overlapping_pairs,
        nested,
        unseparated,
        layers_per_group,
        preprocess_ms: f64::from_bits(r.u64()?),
        read_from_cache_ms: None,
    };
    let group_count = r.u32()? as usize;
    let mut groups = Vec::with_capacity(group_count.min(bytes.len()));
    for _ in 0..group_count {
        let parts = r.u32()?;
        let triangles = r.u32s()?;
        if let Some(&t) = triangles.iter().find(|&&t| t as u64 >= key.triangles) {
            return Err(format!("triangle {t} out of range"));
        }
        let (lo, hi, centroid) = (r.vec3()?, r.vec3()?, r.vec3()?);
        let point_count = r.u32()? as usize;
        let points = (0..point_count)
            .map(|_| r.vec3())
            .collect::<Result<Vec<_>, _>>()?;
        groups.push(Group {
            parts,
            triangles,
            lo,
            hi,
            centroid,
            points,
        });
    }
    let pair_count = r.u64()?;
    let mut pairs = Vec::new();
    for _ in 0..pair_count {
        let (i, j) = (r.u32()?, r.u32()?);
        if i >= j || j as usize >= groups.len() {
            return Err(format!("pair ({i}, {j}) of {} groups", groups.len()));
        }
        if pairs.last().is_some_and(|&(last, _)| last >= (i, j)) {
            return Err(format!("pair ({i}, {j}) out of order"));
        }
        let relation = match r.u32()? {
            0 => Relation::Plane(Separation {
                normal: r.vec3()?,
                offset: r.f32()?,
            }),
            1 => Relation::Contains,
            2 => Relation::Inside,
            3 => Relation::Inseparable,
            4 => Relation::Coplanar,
            tag => return Err(format!("unknown relation {tag}")),
        };
        pairs.push(((i, j), relation));
    }
    let relations = Relations::from_pairs(pairs);
    if !r.0.is_empty() {
        return Err(format!("{} bytes past the end", r.0.len()));
    }
    Ok(Decomposition::from_parts(
        groups, relations, tolerance, stats,
    ))
}

#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    fn vec3(&mut self, v: Vec3) {
        for c in v.to_array() {
            self.f32(c);
        }
    }
    fn u32s(&mut self, v: &[u32]) {
        self.u32(v.len() as u32);
        for &x in v {
            self.u32(x);
        }
    }
}

struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.0.len() {
            return Err("truncated".into());
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(head)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn f32(&mut self) -> Result<f32, String> {
        self.u32().map(f32::from_bits)
    }
    fn vec3(&mut self) -> Result<Vec3, String> {
        Ok(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }
    fn u32s(&mut self) -> Result<Vec<u32>, String> {
        let n = self.u32()? as usize;
        let raw = self.take(n.checked_mul(4).ok_or("truncated")?)?;
        Ok(raw
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }
}
