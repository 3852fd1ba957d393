//! What the CLI's test files share.

use std::path::{Path, PathBuf};

/// An empty folder `GROUP/NAME` under the tests' temporary directory (emptied when it was there).
pub fn workdir(group: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
