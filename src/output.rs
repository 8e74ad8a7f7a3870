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

/// Refuse at once an output that could not be written, before any work is spent on it: a render
/// that ran for hours and only then found its directory missing has lost that work (a cluster
/// job too, and its retry would lose it again). It creates the same temporary file that
/// [`write_atomic`] will (unnamed, so nothing is left behind; a named one, removed at once,
/// where unnamed files are not supported) and refuses a directory where a file is asked for.
/// The target itself is not touched: an existing output stays until the new one replaces it.
pub fn check_writable(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(Error::in_file(path, "cannot write: is a directory"));
    }
    probe(target_dir(path), &temp_path(path), path)
}

/// Create (and drop) a temporary file in `dir`, unnamed or else named `tmp`; errors name `shown`.
fn probe(dir: &Path, tmp: &Path, shown: &Path) -> Result<()> {
    #[cfg(target_os = "linux")]
    if open_unnamed(dir).is_ok() {
        return Ok(());
    }
    let cannot = |e: std::io::Error| Error::in_file(shown, format!("cannot write: {e}"));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(tmp)
        .map_err(cannot)?;
    std::fs::remove_file(tmp).map_err(cannot)
}

/// [`check_writable`] for every output a tool was asked for (absent optional ones are skipped).
pub fn check_all_writable<'a>(paths: impl IntoIterator<Item = Option<&'a PathBuf>>) -> Result<()> {
    paths
        .into_iter()
        .flatten()
        .try_for_each(|p| check_writable(p))
}

/// An output directory (`--keep`, `--inspect`, `mixmc-study -o`): created if missing, then checked
/// as [`check_writable`] checks a file's, before any work is done for it.
pub fn prepare_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::in_file(dir, format!("cannot create: {e}")))?;
    probe(dir, &temp_path(&dir.join("check")), dir)
}

/// The directory a file is written in (`.` for a bare name).
fn target_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// An unnamed file in `dir`, freed by the kernel when closed unless it is linked to a name.
#[cfg(target_os = "linux")]
fn open_unnamed(dir: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_TMPFILE)
        .mode(0o666)
        .open(dir)
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
    let Ok(file) = open_unnamed(target_dir(path)) else {
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
    fn check_writable_refuses_missing_dirs_and_directories_and_leaves_nothing() {
        let dir = std::env::temp_dir().join(format!("mixmc-check-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        check_writable(&dir.join("a.exr")).unwrap();
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        let missing = check_writable(&dir.join("no/such/a.exr")).unwrap_err();
        assert!(missing.to_string().contains("cannot write"), "{missing}");
        let is_dir = check_writable(&dir).unwrap_err();
        assert!(is_dir.to_string().contains("is a directory"), "{is_dir}");
        prepare_dir(&dir.join("made")).unwrap();
        assert!(dir.join("made").is_dir());
        assert_eq!(std::fs::read_dir(dir.join("made")).unwrap().count(), 0);
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
