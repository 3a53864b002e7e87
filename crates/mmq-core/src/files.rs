//! Bounded reads of input files: every file mmq reads goes through [`read_bounded`], which
//! refuses what is not a regular file (a FIFO would block forever, `/dev/zero` would
//! never end) and stops after a size limit, so no input can hang a run or take its memory.

use std::io::Read as _;
use std::path::Path;

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
}
