//! One process per output folder: [`lock_out_dir`] takes a folder's lock before a study
//! (a run, a report, a sweep) writes there, and the guard it returns gives the lock back
//! when dropped, whichever way the study ends (success, error, stop request).
//!
//! The lock is the file [`LOCK_FILE`] in the folder, holding the holder's process id, and
//! locked with the operating system's advisory lock (`flock`). The system releases that
//! lock when its process ends, however it ends, so the file a killed process left behind
//! is taken over, never obeyed, and a process id that was reused by another program
//! cannot hold a folder. The guard removes the file when it lets go; a holder that finds
//! the file gone or replaced between opening and locking it tries again.

use std::io::{Read as _, Seek as _, Write as _};
use std::path::{Path, PathBuf};

use crate::error::LabError;

/// The lock file's name inside an output folder.
pub const LOCK_FILE: &str = ".mmq.lock";

/// Whether `name` (a file name inside an output folder) is the lock file.
pub fn is_lock_file(name: &str) -> bool {
    name == LOCK_FILE
}

/// The lock of one output folder, held until dropped.
#[derive(Debug)]
pub struct OutLock {
    path: PathBuf,
    _held: sys::Held,
}

impl OutLock {
    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutLock {
    fn drop(&mut self) {
        // Removed while still locked: a process that opened this file meanwhile finds,
        // once it holds the lock, that the name no longer leads to it, and starts over.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Takes the lock of the output folder `dir` (created if missing) for this process.
/// A folder another live process holds is refused ([`LabError::OutDirLocked`], naming
/// its process id); a lock file whose process has ended is taken over.
pub fn lock_out_dir(dir: &Path) -> Result<OutLock, LabError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| LabError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let path = dir.join(LOCK_FILE);
    // Each round loses only to a holder that removed the file in between: a few rounds
    // are plenty.
    for _ in 0..16 {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io(&path))?;
        match sys::try_lock(file) {
            Ok(mut held) => {
                if !sys::is_still(&held, &path) {
                    continue;
                }
                let f = held.file();
                f.set_len(0).map_err(io(&path))?;
                f.rewind().map_err(io(&path))?;
                writeln!(f, "{}", std::process::id()).map_err(io(&path))?;
                return Ok(OutLock { path, _held: held });
            }
            Err(sys::Busy::Held(file)) => {
                return Err(LabError::OutDirLocked { path: dir.to_path_buf(), pid: holder(file) });
            }
            Err(sys::Busy::Failed(source)) => return Err(LabError::Io { path, source }),
        }
    }
    Err(LabError::OutDirLocked { path: dir.to_path_buf(), pid: None })
}

/// The process id written in a held lock file (the holder writes it right after
/// locking: a moment's wait covers a holder that has only just started).
fn holder(mut file: std::fs::File) -> Option<u32> {
    for _ in 0..10 {
        let mut text = String::new();
        if file.rewind().is_ok()
            && file.read_to_string(&mut text).is_ok()
            && let Ok(pid) = text.trim().parse()
        {
            return Some(pid);
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    None
}

#[cfg(unix)]
mod sys {
    //! The lock on Unix: `flock`, released by the system when its process ends.
    use std::os::unix::fs::MetadataExt as _;
    use std::path::Path;

    use nix::errno::Errno;
    use nix::fcntl::{Flock, FlockArg};

    /// A locked lock file.
    #[derive(Debug)]
    pub struct Held(Flock<std::fs::File>);

    impl Held {
        pub fn file(&mut self) -> &mut std::fs::File {
            &mut self.0
        }
    }

    /// Why a file could not be locked.
    pub enum Busy {
        /// Another process holds it (the file, to read its process id).
        Held(std::fs::File),
        /// The file system refused.
        Failed(std::io::Error),
    }

    pub fn try_lock(file: std::fs::File) -> Result<Held, Busy> {
        match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
            Ok(held) => Ok(Held(held)),
            Err((file, Errno::EWOULDBLOCK)) => Err(Busy::Held(file)),
            Err((_, e)) => Err(Busy::Failed(e.into())),
        }
    }

    /// Whether `path` still names the locked file (its previous holder may have removed
    /// it between our opening and our locking it).
    pub fn is_still(held: &Held, path: &Path) -> bool {
        match (held.0.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
}

#[cfg(not(unix))]
mod sys {
    //! Elsewhere: the file's existence is the lock (created only if absent), and a file
    //! left by a process that ended must be removed by hand (the error names it).
    use std::path::Path;

    #[derive(Debug)]
    pub struct Held(std::fs::File);

    impl Held {
        pub fn file(&mut self) -> &mut std::fs::File {
            &mut self.0
        }
    }

    pub enum Busy {
        Held(std::fs::File),
        Failed(std::io::Error),
    }

    pub fn try_lock(file: std::fs::File) -> Result<Held, Busy> {
        let len = file.metadata().map_err(Busy::Failed)?.len();
        if len > 0 { Err(Busy::Held(file)) } else { Ok(Held(file)) }
    }

    pub fn is_still(_: &Held, path: &Path) -> bool {
        path.is_file()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_is_held_once_and_given_back_on_drop() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("new/run");
        let lock = lock_out_dir(&out).unwrap();
        let text = std::fs::read_to_string(lock.path()).unwrap();
        assert_eq!(text.trim(), std::process::id().to_string());
        // A second taker (another open file, as another process would have) is refused,
        // naming the holder.
        let e = lock_out_dir(&out).unwrap_err();
        assert!(matches!(e, LabError::OutDirLocked { pid: Some(p), .. } if p == std::process::id()), "{e}");
        assert!(e.is_input_error() && e.names_fields());
        let msg = e.to_string();
        assert!(msg.contains(&format!("PID {}", std::process::id())) && msg.contains("`out`"), "{msg}");
        drop(lock);
        assert!(!out.join(LOCK_FILE).exists(), "the lock file is removed when given back");
        let again = lock_out_dir(&out).unwrap();
        drop(again);
    }

    /// A lock file whose process has ended (nothing holds its system lock) is taken over.
    #[cfg(unix)]
    #[test]
    fn a_stale_lock_file_is_taken_over() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join(LOCK_FILE), "4294967295\n").unwrap();
        let lock = lock_out_dir(d.path()).unwrap();
        let text = std::fs::read_to_string(lock.path()).unwrap();
        assert_eq!(text, format!("{}\n", std::process::id()));
    }
}
