//! One writer per directory: an advisory lock (`flock`) on [`LOCK_FILE`] in the directory, held
//! for the writer's whole life (a run, a restart, a study), with the holder's pid, host and
//! command written into the file so that a refused start can name it. The kernel releases the lock
//! when the holder ends, however it ends, so a killed run never leaves a stale lock behind.

use crate::io::IoError;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// Name of the lock file in a locked directory (kept after the holder ends; only the lock on it
/// counts, not its existence).
pub const LOCK_FILE: &str = ".nurbs-contact.lock";

/// A held lock on a directory; released when dropped.
#[derive(Debug)]
pub struct DirLock {
    /// Kept open: closing the file releases the lock.
    _file: File,
    path: PathBuf,
}

impl DirLock {
    /// Takes the exclusive lock of the existing directory `dir` at once, and records this process
    /// in the lock file; refuses, naming the holder, when another process holds it.
    pub fn exclusive(dir: &Path) -> Result<DirLock, IoError> {
        let path = dir.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .custom_flags_nofollow()
            .open(&path)
            .map_err(|e| nofollow_error(&path, "create the lock file", e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => return Err(held(dir, &mut file)),
            Err(TryLockError::Error(source)) => {
                return Err(IoError::File {
                    path,
                    op: "lock",
                    source,
                })
            }
        }
        let record = format!(
            "pid {}\nhost {}\ncommand {}\n",
            std::process::id(),
            host(),
            command()
        );
        let io = |source| IoError::File {
            path: path.clone(),
            op: "record the lock's holder in",
            source,
        };
        file.set_len(0).map_err(io)?;
        file.rewind().map_err(io)?;
        file.write_all(record.as_bytes()).map_err(io)?;
        Ok(DirLock { _file: file, path })
    }

    /// Takes a shared lock of `dir` for reading it (e.g. the checkpoint a restart continues into
    /// another directory): refused, naming the holder, while a writer holds the directory. `None`
    /// when the directory has no lock file (no writer of this program has used it), so that a
    /// read-only directory can be read.
    pub fn shared(dir: &Path) -> Result<Option<DirLock>, IoError> {
        let path = dir.join(LOCK_FILE);
        let mut file = match OpenOptions::new()
            .read(true)
            .custom_flags_nofollow()
            .open(&path)
        {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(nofollow_error(&path, "open the lock file", e)),
        };
        match file.try_lock_shared() {
            Ok(()) => Ok(Some(DirLock { _file: file, path })),
            Err(TryLockError::WouldBlock) => Err(held(dir, &mut file)),
            Err(TryLockError::Error(source)) => Err(IoError::File {
                path,
                op: "lock",
                source,
            }),
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// The refusal of a directory whose lock `file` another process holds, naming that process as
/// its lock file records it.
fn held(dir: &Path, file: &mut File) -> IoError {
    let mut text = String::new();
    let _ = file.read_to_string(&mut text);
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key)?.strip_prefix(' '))
            .map(str::to_string)
    };
    let holder = match (field("pid"), field("host"), field("command")) {
        (Some(pid), host, command) => format!(
            "process {pid} on {}{}",
            host.unwrap_or_else(|| "an unrecorded host".into()),
            command.map_or(String::new(), |c| format!(" (`{c}`)"))
        ),
        _ => "another process, which has not recorded itself yet".to_string(),
    };
    IoError::Locked {
        path: dir.to_path_buf(),
        holder,
    }
}

/// The host name (Linux; "an unknown host" elsewhere).
fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "an unknown host".to_string())
}

/// This process's command line, on one line.
fn command() -> String {
    std::env::args()
        .map(|a| {
            if a.is_empty() || a.contains(char::is_whitespace) {
                format!("'{a}'")
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
        .replace(['\n', '\r'], " ")
}

/// `O_NOFOLLOW` on an [`OpenOptions`]: the open fails instead of following a symbolic link at the
/// path's last component.
pub trait NoFollow {
    fn custom_flags_nofollow(&mut self) -> &mut Self;
}

impl NoFollow for OpenOptions {
    fn custom_flags_nofollow(&mut self) -> &mut Self {
        use std::os::unix::fs::OpenOptionsExt;
        self.custom_flags(libc::O_NOFOLLOW)
    }
}

/// The error of an `O_NOFOLLOW` open of `path`: a symbolic link there is named as such.
pub fn nofollow_error(path: &Path, op: &'static str, source: std::io::Error) -> IoError {
    let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
    if is_link || source.raw_os_error() == Some(libc::ELOOP) {
        IoError::Symlink {
            path: path.to_path_buf(),
        }
    } else {
        IoError::File {
            path: path.to_path_buf(),
            op,
            source,
        }
    }
}

/// Creates (or truncates) the file `path` for writing without following a symbolic link there.
pub fn create_nofollow(path: &Path) -> Result<File, IoError> {
    OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .custom_flags_nofollow()
        .open(path)
        .map_err(|e| nofollow_error(path, "create", e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("nc_lock_{}_{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_second_exclusive_lock_is_refused_naming_the_holder_until_the_first_is_dropped() {
        let d = scratch("excl");
        let first = DirLock::exclusive(&d).unwrap();
        // a second open file description in this process conflicts like another process would
        let e = DirLock::exclusive(&d).unwrap_err().to_string();
        assert!(e.contains(&d.display().to_string()), "{e}");
        assert!(
            e.contains(&format!("process {}", std::process::id())),
            "{e}"
        );
        assert!(e.contains(&host()), "{e}");
        let e = DirLock::shared(&d).unwrap_err().to_string();
        assert!(e.contains("in use by process"), "{e}");
        drop(first);
        let again = DirLock::exclusive(&d).unwrap();
        assert_eq!(again.path(), d.join(LOCK_FILE));
        drop(again);
        assert!(DirLock::shared(&d).unwrap().is_some());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn shared_locks_coexist_and_a_directory_without_lock_file_needs_none() {
        let d = scratch("shared");
        assert!(DirLock::shared(&d).unwrap().is_none());
        std::fs::write(d.join(LOCK_FILE), "").unwrap();
        let a = DirLock::shared(&d).unwrap();
        let b = DirLock::shared(&d).unwrap();
        assert!(a.is_some() && b.is_some());
        let e = DirLock::exclusive(&d).unwrap_err().to_string();
        assert!(e.contains("not recorded itself"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn files_are_not_written_through_symbolic_links() {
        let d = scratch("link");
        let outside = d.join("outside.txt");
        std::fs::write(&outside, "keep").unwrap();
        std::os::unix::fs::symlink(&outside, d.join("history.csv")).unwrap();
        let e = create_nofollow(&d.join("history.csv")).unwrap_err();
        assert!(matches!(e, IoError::Symlink { .. }), "{e}");
        assert!(e.to_string().contains("history.csv"), "{e}");
        std::os::unix::fs::symlink(&outside, d.join(LOCK_FILE)).unwrap();
        let e = DirLock::exclusive(&d).unwrap_err();
        assert!(matches!(e, IoError::Symlink { .. }), "{e}");
        assert_eq!(std::fs::read_to_string(&outside).unwrap(), "keep");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
