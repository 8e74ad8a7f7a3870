//! Writing files so that no reader ever sees half of one and no killed process leaves debris:
//! the data goes into an unnamed file (Linux `O_TMPFILE`) in the target's directory, which gets a
//! name only once it is complete and is then renamed over the target. A process killed while
//! writing (SIGKILL, a second Ctrl-C) leaves the old target and nothing else; the kernel frees the
//! unnamed file. Where unnamed files are not supported, a hidden named temporary file is used.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Write `path` by calling `write` on a temporary file in the same directory and renaming it over
/// the target; on any failure the temporary file is removed and the target is left untouched.
/// `write` gets a path to create and write (for the unnamed file, its `/proc/self/fd` link).
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    let result = match write_unnamed(path, &tmp, write) {
        Ok(written) => written,
        Err(write) => write(&tmp),
    }
    .and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|e| Error::in_file(path, format!("cannot write: {e}")))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Write into an unnamed file in the target's directory and, once `write` succeeded, name it
/// `tmp`. Hands `write` back where the system or filesystem has no unnamed files.
#[cfg(target_os = "linux")]
fn write_unnamed<W: FnOnce(&Path) -> Result<()>>(
    path: &Path,
    tmp: &Path,
    write: W,
) -> std::result::Result<Result<()>, W> {
    use std::ffi::CString;
    use std::os::fd::AsRawFd;
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::fs::OpenOptionsExt;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(file) = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_TMPFILE)
        .mode(0o666)
        .open(dir)
    else {
        return Err(write);
    };
    let fd_path = PathBuf::from(format!("/proc/self/fd/{}", file.as_raw_fd()));
    Ok(write(&fd_path).and_then(|()| {
        let cannot = |e: std::io::Error| Error::in_file(path, format!("cannot write: {e}"));
        let from = CString::new(fd_path.as_os_str().as_bytes()).map_err(|e| cannot(e.into()))?;
        let to = CString::new(tmp.as_os_str().as_bytes()).map_err(|e| cannot(e.into()))?;
        // SAFETY: both arguments are NUL-terminated strings that outlive the call.
        let rc = unsafe {
            libc::linkat(
                libc::AT_FDCWD,
                from.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                libc::AT_SYMLINK_FOLLOW,
            )
        };
        if rc == 0 {
            Ok(())
        } else {
            Err(cannot(std::io::Error::last_os_error()))
        }
    }))
}

#[cfg(not(target_os = "linux"))]
fn write_unnamed<W: FnOnce(&Path) -> Result<()>>(
    _: &Path,
    _: &Path,
    write: W,
) -> std::result::Result<Result<()>, W> {
    Err(write)
}

/// `dir/.name.PID.tmp`: hidden, unique per process, on the same filesystem as the target so
/// the rename is atomic.
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write bytes atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| Error::in_file(path, format!("cannot write: {e}")))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failure_leaves_target_and_no_temp() {
        let dir = std::env::temp_dir().join(format!("mixmc-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("a.txt");
        std::fs::write(&target, "old").unwrap();
        let r = write_atomic(&target, |tmp| {
            std::fs::write(tmp, "half").unwrap();
            Err(Error::new("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        write_bytes(&target, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn nothing_is_named_in_the_directory_while_writing() {
        let dir = std::env::temp_dir().join(format!("mixmc-unnamed-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("b.txt");
        std::fs::write(&target, "old").unwrap();
        write_atomic(&target, |tmp| {
            std::fs::write(tmp, "new").unwrap();
            // A process killed here would leave only the old target behind.
            let names: Vec<_> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().file_name())
                .collect();
            assert_eq!(names, ["b.txt"]);
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
