//! What the report generators share: where the real data is, and listing it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The data folder: the first argument, or `../shared/data` beside the repository. Also returns
/// how to show it, relative by default, so a report is the same from any clone.
pub fn data_dir() -> (PathBuf, String) {
    let arg = std::env::args().nth(1);
    let shown = arg.clone().unwrap_or_else(|| "../shared/data".to_string());
    let data = arg.map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data")),
        PathBuf::from,
    );
    (data, shown)
}

/// A path's file name, as text.
pub fn file_name(p: &Path) -> String {
    p.file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
}

/// The files in `dir` with extension `ext`, sorted.
pub fn sorted_files(dir: &Path, ext: &str) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    Ok(v)
}
