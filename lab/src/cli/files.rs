//! The commands' files: written whole or not at all, and named below their folder.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Writes a file whole or not at all: to a temporary file beside it, then renamed over
/// it, so a file already there (a trained model) is replaced only by a complete one.
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    let mut partial = path.as_os_str().to_owned();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    std::fs::write(&partial, bytes).with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, path).with_context(|| format!("writing {}", path.display()))
}

/// A photo's path below the photos' folder, with `/` between folders (its file name when
/// it is not below it).
pub(crate) fn relative_name(path: &Path, images: &Path) -> String {
    match path.strip_prefix(images) {
        Ok(rel) => rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join("/"),
        Err(_) => path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_photo_is_named_below_its_folder() {
        let images = Path::new("/data/set");
        assert_eq!(
            relative_name(Path::new("/data/set/e1/r2/a.jpg"), images),
            "e1/r2/a.jpg"
        );
        assert_eq!(relative_name(Path::new("/other/b.png"), images), "b.png");
    }

    #[test]
    fn a_file_is_written_whole_and_replaces_the_old_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/model.bin");
        write_file(&path, b"one").unwrap();
        write_file(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        assert!(!dir.path().join("sub/model.bin.partial").exists());
    }
}
