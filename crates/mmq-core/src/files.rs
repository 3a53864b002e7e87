//! Files in and out. Bounded reads: every file mmq reads goes through [`read_bounded`],
//! which refuses what is not a regular file (a FIFO would block forever, `/dev/zero` would
//! never end) and stops after a size limit, so no input can hang a run or take its memory.
//! Atomic writes: every finished output goes through [`write_atomic`], so it appears whole
//! under its name or not at all.

use std::io::{Read as _, Write as _};
use std::path::{Path, PathBuf};

/// Why a file was not read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The operating system refused (not found, no permission, ...).
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// A FIFO, a device, a socket or a folder.
    #[error("not a regular file (a FIFO, device or folder); give the path of a file")]
    NotAFile,
    /// Larger than the limit.
    #[error("larger than {limit} bytes, more than such a file can hold; is it the right file?")]
    TooLarge {
        /// The limit, bytes.
        limit: u64,
    },
}

/// Reads the regular file at `path` (links followed) if it holds at most `limit` bytes.
pub fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    // Looked at before opening: opening a FIFO for reading blocks until a writer comes.
    if !std::fs::metadata(path)?.is_file() {
        return Err(ReadError::NotAFile);
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge { limit });
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
pub fn read_text_bounded(path: &Path, limit: u64) -> Result<String, ReadError> {
    let bytes = read_bounded(path, limit)?;
    String::from_utf8(bytes)
        .map_err(|e| ReadError::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
}

/// The temporary name `path` is written under before [`write_atomic`] renames it: a hidden
/// file in the same folder, `.NAME.tmpPID` (the rename stays on one file system).
pub fn temporary_name(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Writes `bytes` to `path` atomically: to a temporary file in the same folder, synced,
/// then renamed over `path`. A kill at any instant leaves the old file or the new one; a
/// failed write (a full disk, a file-size limit) leaves no temporary file and returns the
/// error. The folder must exist.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    via_temporary(path, bytes, true)
}

/// [`write_atomic`] without waiting for the disk (no fsync): readers still see the old
/// file or the new one, never a part, but a crash of the machine may leave the file
/// empty. For many small files that are cheap to redo (a sweep's job results).
pub fn write_renamed(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    via_temporary(path, bytes, false)
}

fn via_temporary(path: &Path, bytes: &[u8], sync: bool) -> std::io::Result<()> {
    let tmp = temporary_name(path);
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        if sync { f.sync_all() } else { Ok(()) }
    });
    written.and_then(|()| std::fs::rename(&tmp, path)).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_devices_folders_and_sizes() {
        let d = std::env::temp_dir().join(format!("mmq-files-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("f.txt");
        std::fs::write(&f, "12345").unwrap();
        assert_eq!(read_text_bounded(&f, 5).unwrap(), "12345");
        assert!(matches!(read_bounded(&f, 4), Err(ReadError::TooLarge { limit: 4 })));
        assert!(matches!(read_bounded(&d, 100), Err(ReadError::NotAFile)));
        if Path::new("/dev/zero").exists() {
            assert!(matches!(read_bounded(Path::new("/dev/zero"), 100), Err(ReadError::NotAFile)));
        }
        assert!(matches!(read_bounded(&d.join("missing"), 100), Err(ReadError::Io(_))));
        std::fs::remove_dir_all(&d).unwrap();
    }
    #[test]
    fn atomic_writes_replace_whole_files_and_leave_nothing_on_failure() {
        let d = std::env::temp_dir().join(format!("mmq-atomic-{}", std::process::id()));
        let f = d.join("sub").join("out.csv");
        assert!(write_atomic(&f, b"x").is_err(), "no folder: an error, as for a plain write");
        std::fs::create_dir_all(d.join("sub")).unwrap();
        write_atomic(&f, b"old").unwrap();
        write_atomic(&f, b"new").unwrap();
        assert_eq!(std::fs::read(&f).unwrap(), b"new");
        // A folder in the way: the rename fails, the error is returned, no temporary stays.
        let blocked = d.join("sub").join("a-folder");
        std::fs::create_dir_all(blocked.join("inside")).unwrap();
        assert!(write_atomic(&blocked, b"x").is_err());
        let names: Vec<String> = std::fs::read_dir(d.join("sub"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
