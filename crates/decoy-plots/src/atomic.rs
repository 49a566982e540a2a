//! Files written whole or not at all.
//!
//! A file is written under a temporary name beside its own, `<name>.partial`
//! ([`partial_path`]), and renamed to its name once complete. A rename within
//! one directory replaces the old file in one step, so a reader (or a run that
//! was killed half-way) finds the earlier file or the complete new one under the
//! name, never part of one; at worst a `.partial` file is left beside it, which
//! the next run into the directory removes (`decoy_sim::run::clear_output_dir`).
//!
//! [`write_atomically`] writes bytes held in memory (the plots, a summary);
//! [`AtomicFile`] a file written piece by piece (a CSV written row by row while
//! a run goes on). Both are used by every command that writes an output
//! directory.

use std::ffi::OsString;
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

/// The suffix of a file being written: `summary.json` is written as
/// `summary.json.partial` and renamed when complete.
pub const PARTIAL_SUFFIX: &str = ".partial";

/// Where `path` is written until it is complete: `<path>.partial`, in the same
/// directory (so that the final rename stays within one file system).
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = OsString::from(path.as_os_str());
    name.push(PARTIAL_SUFFIX);
    PathBuf::from(name)
}

/// Writes `bytes` to `path` whole: to [`partial_path`] first, then renamed over
/// `path`. On an error the partial file is removed and `path` is unchanged.
///
/// # Errors
///
/// The operating system's error of creating, writing or renaming the file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let partial = partial_path(path);
    let written = std::fs::write(&partial, bytes).and_then(|()| std::fs::rename(&partial, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    written
}

/// A file written piece by piece under its [`partial_path`] and renamed to its
/// name by [`AtomicFile::commit`]. Dropped without a commit (an error, a panic),
/// it removes its partial file: the name never holds part of a file.
#[derive(Debug)]
pub struct AtomicFile {
    /// The partial file, buffered; `None` once committed.
    file: Option<BufWriter<File>>,
    /// The final name.
    path: PathBuf,
    /// The name while it is written.
    partial: PathBuf,
}

impl AtomicFile {
    /// Creates (truncates) the partial file of `path`.
    ///
    /// # Errors
    ///
    /// The operating system's error of creating the file.
    pub fn create(path: impl Into<PathBuf>) -> std::io::Result<Self> {
        let path = path.into();
        let partial = partial_path(&path);
        let file = File::create(&partial)?;
        Ok(AtomicFile {
            file: Some(BufWriter::new(file)),
            path,
            partial,
        })
    }

    /// The name the file gets when committed.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `bytes`.
    ///
    /// # Errors
    ///
    /// The operating system's error of writing, or [`std::io::ErrorKind::Other`]
    /// after a commit.
    pub fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match &mut self.file {
            Some(file) => file.write_all(bytes),
            None => Err(std::io::Error::other("the file is already committed")),
        }
    }

    /// Flushes what was written and renames the partial file to the file's name
    /// (replacing an earlier file of that name). Committing twice does nothing.
    ///
    /// # Errors
    ///
    /// The operating system's error of flushing or renaming; the partial file is
    /// then removed.
    pub fn commit(&mut self) -> std::io::Result<()> {
        let Some(file) = self.file.take() else {
            return Ok(());
        };
        let done = file
            .into_inner()
            .map_err(std::io::IntoInnerError::into_error)
            .and_then(|f| {
                drop(f);
                std::fs::rename(&self.partial, &self.path)
            });
        if done.is_err() {
            let _ = std::fs::remove_file(&self.partial);
        }
        done
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("decoy-plots-atomic-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_file_appears_only_when_complete() {
        let dir = scratch("stream");
        let path = dir.join("rows.csv");
        std::fs::write(&path, "old\n").unwrap();
        let mut file = AtomicFile::create(&path).unwrap();
        file.write_all(b"a,b\n").unwrap();
        // While it is written the name holds the earlier file.
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        assert_eq!(names(&dir), ["rows.csv", "rows.csv.partial"]);
        file.write_all(b"1,2\n").unwrap();
        file.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
        assert_eq!(names(&dir), ["rows.csv"]);
        assert!(file.write_all(b"late").is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_abandoned_file_leaves_nothing() {
        let dir = scratch("abandoned");
        let mut file = AtomicFile::create(dir.join("rows.csv")).unwrap();
        file.write_all(b"a,b\n").unwrap();
        drop(file);
        assert!(names(&dir).is_empty());
        write_atomically(&dir.join("whole.json"), b"{}\n").unwrap();
        assert_eq!(names(&dir), ["whole.json"]);
        // A directory that does not exist: the error, and nothing written.
        assert!(write_atomically(&dir.join("missing/x.json"), b"{}").is_err());
        assert_eq!(names(&dir), ["whole.json"]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
