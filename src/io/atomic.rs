//! Complete-or-absent files: write under `<name>.partial`, then `rename` onto the final name, which
//! is atomic on one POSIX file system. A crash leaves only the `.partial` file behind.

use crate::io::IoError;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `dir/results.h5` -> `dir/results.h5.partial`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    PathBuf::from(s)
}

/// Move a finished `partial` file onto `target`, replacing any older `target`.
pub fn commit(partial: &Path, target: &Path) -> Result<(), IoError> {
    std::fs::rename(partial, target).map_err(|source| IoError::File {
        path: target.to_path_buf(),
        op: "rename the finished .partial file onto it",
        source,
    })
}

/// Write `bytes` to `path` atomically: to `path.partial`, synced to disk, then renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let tmp = partial_path(path);
    let err = |op: &'static str| {
        let tmp = tmp.clone();
        move |source| IoError::File {
            path: tmp,
            op,
            source,
        }
    };
    // not through a symbolic link at the temporary name (the rename replaces one at `path` itself)
    let mut f = crate::io::create_nofollow(&tmp)?;
    f.write_all(bytes).map_err(err("write"))?;
    // Sync before the rename, or a power cut could leave a complete name over incomplete data.
    f.sync_all().map_err(err("sync"))?;
    drop(f);
    commit(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_atomic_leaves_only_the_final_file() {
        let dir = std::env::temp_dir().join(format!("io_atomic_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.json");
        write_atomic(&p, b"first").unwrap();
        write_atomic(&p, b"second").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "second");
        assert!(!partial_path(&p).exists());
        assert_eq!(partial_path(&p), dir.join("a.json.partial"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn write_atomic_into_missing_directory_names_the_path() {
        let p = Path::new("/nonexistent_dir_xyz/summary.json");
        let e = write_atomic(p, b"x").unwrap_err();
        assert!(
            e.to_string()
                .contains("/nonexistent_dir_xyz/summary.json.partial"),
            "{e}"
        );
    }
}
