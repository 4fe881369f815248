//! Run directories that never lose data: atomic file writes and claiming a directory for a
//! new run (refused if it holds one, unless the caller replaces it).

use std::path::{Path, PathBuf};

/// Writes `text` to `path` atomically (a temporary file unique to this process in the same
/// directory, `fsync`, rename): a crash leaves the old file or the new one, never half of one.
pub fn write_atomic(path: &Path, text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".{}.tmp", std::process::id()));
    let tmp = PathBuf::from(tmp);
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(text.as_bytes())?;
        f.sync_all()
    });
    written.and_then(|()| std::fs::rename(&tmp, path)).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Whether `a` and `b` name the same existing directory (or file), however spelt.
pub fn same_path(a: &Path, b: &Path) -> bool {
    a.canonicalize().ok().is_some_and(|a| b.canonicalize().ok() == Some(a))
}

/// `path` made absolute and free of `..` and links where it exists (what a record keeps), else
/// as given.
pub fn recorded_path(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

/// Refuses an output directory path that exists as something else (a file): checked before
/// a run starts, so that no run's work is lost to a typo in `--out`.
pub fn check_not_file(dir: &Path) -> std::io::Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            "--out is a file, not a directory",
        ));
    }
    Ok(())
}

/// The file in a run directory whose lock marks it as being written by a process.
pub const LOCK_FILE: &str = ".centaur.lock";

/// A run directory held by this process: an advisory lock on its [`LOCK_FILE`], released
/// when dropped or when the process ends (a crash or `kill -9` included, so a killed run
/// can be resumed at once). Two processes never write one run directory.
#[derive(Debug)]
pub struct DirLock {
    _file: std::fs::File,
}

/// Locks the existing directory `dir` for this process ([`DirLock`]), or says that another
/// holds it ([`Claim::Busy`]). On a file system without file locks (some network or FUSE
/// mounts) the run goes on unlocked, as it did before locks existed, rather than not at all.
pub fn lock_dir(dir: &Path) -> Result<DirLock, Claim> {
    lock_with(dir, std::fs::File::try_lock)
}

/// Holds the existing run directory `dir` for reading ([`DirLock`], shared): any number of
/// readers hold it together (two comparisons reusing one run's pure-RL agent at once); a
/// writer ([`lock_dir`]) holds it alone, so a reader is refused ([`Claim::Busy`]) while one
/// writes and a writer while any reads. As with [`lock_dir`], a file system without file
/// locks leaves the directory unlocked.
pub fn read_lock_dir(dir: &Path) -> Result<DirLock, Claim> {
    lock_with(dir, std::fs::File::try_lock_shared)
}

/// Opens (creating it) `dir`'s [`LOCK_FILE`] and locks it with `try_lock`.
fn lock_with(
    dir: &Path,
    try_lock: fn(&std::fs::File) -> Result<(), std::fs::TryLockError>,
) -> Result<DirLock, Claim> {
    let path = dir.join(LOCK_FILE);
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|e| Claim::Io(path.clone(), e))?;
    match try_lock(&file) {
        Err(std::fs::TryLockError::WouldBlock) => Err(Claim::Busy),
        Ok(()) | Err(std::fs::TryLockError::Error(_)) => Ok(DirLock { _file: file }),
    }
}

/// Why a directory could not be claimed for a new run.
#[derive(Debug)]
pub enum Claim {
    /// It holds a run: the first of the run's files found there.
    Taken(&'static str),
    /// Another process is writing a run there (it holds the [`LOCK_FILE`]).
    Busy,
    /// The file system refused (or `dir` is a file).
    Io(PathBuf, std::io::Error),
}

/// Claims `dir` for a new run whose files and folders are `files`: creates it and locks it
/// for this process ([`lock_dir`]; refused with [`Claim::Busy`] while another holds it); if
/// it holds any of the files, refuses ([`Claim::Taken`]) unless `replace`, which removes
/// those (and nothing else). The run keeps the lock until it ends.
pub fn claim(dir: &Path, files: &[&'static str], replace: bool) -> Result<DirLock, Claim> {
    check_not_file(dir).map_err(|e| Claim::Io(dir.to_path_buf(), e))?;
    std::fs::create_dir_all(dir).map_err(|e| Claim::Io(dir.to_path_buf(), e))?;
    let lock = lock_dir(dir)?;
    if let Some(&file) = files.iter().find(|f| dir.join(f).exists()) {
        if !replace {
            return Err(Claim::Taken(file));
        }
        for f in files {
            let path = dir.join(f);
            let removed =
                if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
            match removed {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(Claim::Io(path, e)),
                _ => {}
            }
        }
    }
    Ok(lock)
}

/// Why a text file was not read ([`read_text_bounded`]).
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// It could not be opened or read.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// It is larger than the bound.
    #[error("larger than {} KiB; not a config file", .0 >> 10)]
    TooLarge(u64),
    /// It is not UTF-8 text.
    #[error("not UTF-8 text")]
    NotText,
}

/// A text file read once, at most `max` bytes: `/dev/zero` or a huge file is refused, not read
/// forever (config files, run specs, run records).
pub fn read_text_bounded(path: &Path, max: u64) -> Result<String, ReadError> {
    use std::io::Read as _;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(ReadError::TooLarge(max));
    }
    String::from_utf8(bytes).map_err(|_| ReadError::NotText)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_directory_spelt_two_ways_is_the_same_path() {
        let dir = std::env::temp_dir().join(format!("centaur-same-path-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        assert!(same_path(&dir, &dir.join("sub").join("..")));
        assert!(!same_path(&dir, &dir.join("sub")));
        assert!(!same_path(&dir.join("absent"), &dir.join("absent")), "nothing there is no same place");
        assert_eq!(recorded_path(&dir.join("sub").join("..")), dir.canonicalize().unwrap());
        assert_eq!(recorded_path(Path::new("no/such/dir")), Path::new("no/such/dir"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_claimed_directory_is_refused_then_replaced_keeping_other_files() {
        let dir = std::env::temp_dir().join(format!("centaur-rundir-{}", std::process::id()));
        let files = ["run.json", "agent"];
        claim(&dir, &files, false).unwrap();
        write_atomic(&dir.join("run.json"), "{}").unwrap();
        std::fs::create_dir_all(dir.join("agent")).unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        assert!(matches!(claim(&dir, &files, false), Err(Claim::Taken("run.json"))));
        // While one claim holds the directory, no other (even replacing) gets it.
        let held = lock_dir(&dir).unwrap();
        assert!(matches!(claim(&dir, &files, true), Err(Claim::Busy)));
        assert!(matches!(lock_dir(&dir), Err(Claim::Busy)));
        assert!(dir.join("run.json").exists(), "a refused claim removed a file");
        drop(held);
        claim(&dir, &files, true).unwrap();
        assert!(!dir.join("run.json").exists() && !dir.join("agent").exists());
        assert_eq!(std::fs::read_to_string(dir.join("notes.txt")).unwrap(), "mine");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        let left: Vec<_> = left.iter().filter(|f| *f != LOCK_FILE).collect();
        assert_eq!(left.len(), 1, "temporary files left: {left:?}");
        assert!(matches!(claim(&dir.join("notes.txt"), &files, true), Err(Claim::Io(..))));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn readers_share_a_directory_that_a_writer_holds_alone() {
        let dir = std::env::temp_dir().join(format!("centaur-readers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let first = read_lock_dir(&dir).unwrap();
        let second = read_lock_dir(&dir).expect("a second reader was refused");
        assert!(matches!(lock_dir(&dir), Err(Claim::Busy)), "a writer got a directory being read");
        drop(first);
        assert!(matches!(lock_dir(&dir), Err(Claim::Busy)), "one reader still holds it");
        drop(second);
        let writer = lock_dir(&dir).unwrap();
        assert!(matches!(read_lock_dir(&dir), Err(Claim::Busy)), "a reader got a directory being written");
        drop(writer);
        read_lock_dir(&dir).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
