//! Output files that appear whole or not at all.
//!
//! A command's outputs (the PNG, its statistics, a diff image) are gathered in an [`Outputs`] and
//! written together by [`Outputs::commit`]: every file first goes to a temporary file beside its
//! target, and only when all of them are complete are they renamed over their targets. A failure
//! before that point leaves nothing behind — no partial file, no temporary, and none of the other
//! outputs.
//!
//! Targets are checked before anything is rendered ([`check_target`]): a new path, or an
//! existing regular file (replaced). Directories, devices, FIFOs and sockets are refused with
//! their kind named — writing a PNG "to" `/dev/null` must never replace the device node. A
//! symbolic link is written *through*: the file it points to is replaced and the link stays (a
//! link to something that is not a regular file, or a dangling one whose target directory is
//! missing, is refused like its target would be). Every error is [`Error::Input`], so the CLI
//! exits with status 2.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use image::RgbaImage;

use crate::error::{Error, Result};

/// Symbolic links followed before giving up (a loop is refused, not followed forever).
const MAX_LINK_DEPTH: usize = 32;

/// The file a write to `path` replaces or creates: `path` itself, or the end of its chain of
/// symbolic links. Refuses what is not a regular file, and a missing parent directory.
pub fn check_target(path: &Path) -> Result<PathBuf> {
    let bad = |why: String| Error::input(format!("cannot write '{}': {why}", path.display()));
    if path.as_os_str().is_empty() {
        return Err(bad("empty path".into()));
    }
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINK_DEPTH {
        match std::fs::symlink_metadata(&current) {
            Ok(md) if md.file_type().is_symlink() => {
                let link = std::fs::read_link(&current).map_err(|e| bad(e.to_string()))?;
                current = match current.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            Ok(md) if md.is_file() => return Ok(current),
            Ok(md) if current == path => return Err(bad(format!("it is {}", kind_of(&md)))),
            Ok(md) => {
                return Err(bad(format!(
                    "it links to {}, which is {}",
                    current.display(),
                    kind_of(&md)
                )))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let dir = directory_of(&current);
                return match std::fs::metadata(dir) {
                    Ok(md) if md.is_dir() => Ok(current),
                    Ok(_) => Err(bad(format!("{} is not a directory", dir.display()))),
                    Err(_) => Err(bad(format!("directory {} does not exist", dir.display()))),
                };
            }
            Err(e) => return Err(bad(e.to_string())),
        }
    }
    Err(bad(format!(
        "more than {MAX_LINK_DEPTH} symbolic links (a loop?)"
    )))
}

/// The directory a file at `path` lives in (`.` for a bare name).
fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

fn kind_of(md: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = md.file_type();
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if md.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

struct Pending {
    /// What the user named (for messages).
    shown: PathBuf,
    /// What is replaced or created (`shown` with its links followed).
    target: PathBuf,
    bytes: Vec<u8>,
}

/// A command's output files, written together by [`Outputs::commit`].
#[derive(Default)]
pub struct Outputs {
    pending: Vec<Pending>,
}

impl Outputs {
    /// No files yet.
    pub fn new() -> Outputs {
        Outputs::default()
    }

    /// Adds a file of `bytes` at `path` (checked now; written on commit).
    pub fn add(&mut self, path: &Path, bytes: Vec<u8>) -> Result<()> {
        let target = check_target(path)?;
        if let Some(other) = self.pending.iter().find(|p| same_file(&p.target, &target)) {
            return Err(Error::input(format!(
                "'{}' and '{}' name the same output file",
                other.shown.display(),
                path.display()
            )));
        }
        self.pending.push(Pending {
            shown: path.to_path_buf(),
            target,
            bytes,
        });
        Ok(())
    }

    /// Adds `img` as an 8-bit RGBA PNG.
    pub fn add_png(&mut self, path: &Path, img: &RgbaImage) -> Result<()> {
        // What is wrong with the target itself (a directory, a device) comes first.
        check_target(path)?;
        check_png_name(path)?;
        self.add(path, encode_png(img)?)
    }

    /// Adds `value` as pretty-printed JSON with a final newline.
    pub fn add_json(&mut self, path: &Path, value: &impl serde::Serialize) -> Result<()> {
        let text = serde_json::to_string_pretty(value)
            .map_err(|e| Error::runtime(format!("cannot encode {}: {e}", path.display())))?;
        self.add(path, (text + "\n").into_bytes())
    }

    /// Writes every file to a temporary beside its target, then renames them all into place.
    /// Nothing is left behind when a write fails.
    pub fn commit(self) -> Result<()> {
        let mut written: Vec<(PathBuf, &Pending)> = Vec::with_capacity(self.pending.len());
        let cleanup = |written: &[(PathBuf, &Pending)]| {
            for (tmp, _) in written {
                let _ = std::fs::remove_file(tmp);
            }
        };
        for p in &self.pending {
            match write_temporary(&p.target, &p.bytes) {
                Ok(tmp) => written.push((tmp, p)),
                Err(e) => {
                    cleanup(&written);
                    return Err(Error::input(format!(
                        "cannot write '{}': {e}",
                        p.shown.display()
                    )));
                }
            }
        }
        for (i, (tmp, p)) in written.iter().enumerate() {
            // The target may have changed since it was checked; check again right before.
            let renamed = check_target(&p.shown).and_then(|target| {
                std::fs::rename(tmp, &target)
                    .map_err(|e| Error::input(format!("cannot write '{}': {e}", p.shown.display())))
            });
            if let Err(e) = renamed {
                cleanup(&written[i..]);
                return Err(e);
            }
        }
        Ok(())
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    let canonical = |p: &Path| {
        let dir = std::fs::canonicalize(directory_of(p)).ok();
        dir.zip(p.file_name()).map(|(d, f)| d.join(f))
    };
    a == b || matches!((canonical(a), canonical(b)), (Some(x), Some(y)) if x == y)
}

/// A new temporary file beside `target` holding `bytes`; its path.
fn write_temporary(target: &Path, bytes: &[u8]) -> std::io::Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = directory_of(target);
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    for _ in 0..16 {
        let tmp = dir.join(format!(
            ".{name}.{}-{}.strata-tmp",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let mut file = match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        };
        let done = file.write_all(bytes).and_then(|()| file.flush());
        if let Err(e) = done {
            drop(file);
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        return Ok(tmp);
    }
    Err(std::io::Error::other("no free temporary file name"))
}

/// Refuses a PNG's path unless its name ends in `.png` (any case): a picture under another
/// extension would be misread by whatever opens it.
pub fn check_png_name(path: &Path) -> Result<()> {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        Ok(())
    } else {
        Err(Error::input(format!(
            "cannot write '{}': strata writes PNG images, and the name must end in .png",
            path.display()
        )))
    }
}

/// `img` encoded as an 8-bit RGBA PNG.
pub fn encode_png(img: &RgbaImage) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::runtime(format!("cannot encode PNG: {e}")))?;
    Ok(bytes)
}

/// Writes `img` as an 8-bit RGBA PNG, whole or not at all (see the module docs for what a
/// target may be). Errors are [`Error::Input`] naming the path.
pub fn save_png(img: &RgbaImage, path: &Path) -> Result<()> {
    let mut out = Outputs::new();
    out.add_png(path, img)?;
    out.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("strata-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn outputs_appear_together_or_not_at_all() {
        let dir = scratch("together");
        let mut out = Outputs::new();
        out.add(&dir.join("a.txt"), b"a".to_vec()).unwrap();
        out.add(&dir.join("b.txt"), b"b".to_vec()).unwrap();
        out.commit().unwrap();
        assert_eq!(entries(&dir), ["a.txt", "b.txt"]);

        // The second file's directory disappears after the check: the first must not appear.
        let sub = dir.join("sub");
        std::fs::create_dir(&sub).unwrap();
        let mut out = Outputs::new();
        out.add(&dir.join("c.txt"), b"c".to_vec()).unwrap();
        out.add(&sub.join("d.txt"), b"d".to_vec()).unwrap();
        std::fs::remove_dir(&sub).unwrap();
        let e = out.commit().unwrap_err().to_string();
        assert!(e.contains("d.txt"), "{e}");
        assert_eq!(
            entries(&dir),
            ["a.txt", "b.txt"],
            "no partial output, no temporary"
        );
    }

    #[test]
    fn targets_that_are_not_regular_files_are_refused() {
        let dir = scratch("kinds");
        let e = check_target(&dir).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = check_target(Path::new("/dev/null"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("/dev/null") && e.contains("a device"), "{e}");
        }
        let e = check_target(&dir.join("missing").join("x.png"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        let mut out = Outputs::new();
        out.add(&dir.join("x.png"), vec![1]).unwrap();
        let e = out
            .add(&dir.join("./x.png"), vec![2])
            .unwrap_err()
            .to_string();
        assert!(e.contains("same output file"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_are_written_through() {
        let dir = scratch("links");
        let real = dir.join("real.txt");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        let mut out = Outputs::new();
        out.add(&link, b"new".to_vec()).unwrap();
        out.commit().unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");

        let to_device = dir.join("null.png");
        std::os::unix::fs::symlink("/dev/null", &to_device).unwrap();
        let e = check_target(&to_device).unwrap_err().to_string();
        assert!(e.contains("a device"), "{e}");
        let looped = dir.join("loop");
        std::os::unix::fs::symlink("loop", &looped).unwrap();
        let e = check_target(&looped).unwrap_err().to_string();
        assert!(e.contains("symbolic links"), "{e}");
    }
}
