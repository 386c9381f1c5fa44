//! A test's scratch directory, `omnikin-SUITE-PID-NAME` under the system's temporary
//! directory, removed when the test passes and kept when it fails (its path is printed, for
//! debugging). Each suite made such directories and never removed them: /tmp grew by some
//! 100 MB per run of the test command.
//!
//! The suites that share `common/` reach it as `common::test_dir`; the others include this file
//! alone (`#[path = "common/test_dir.rs"] mod test_dir;`).
#![allow(dead_code)] // each test binary uses its own subset

use std::path::{Path, PathBuf};

/// A scratch directory (or a file in one) that lives as long as the value: dropped while the
/// test passes, the directory and everything in it are removed; dropped while the test panics
/// (a failed assertion), it is kept. Dereferences to its path.
#[derive(Debug)]
pub struct TestDir {
    /// The directory removed on drop.
    dir: PathBuf,
    /// What the value stands for: `dir`, or a file in it ([`TestDir::file`]).
    path: PathBuf,
}

impl TestDir {
    /// A fresh, empty directory `omnikin-SUITE-PID-NAME` (what a previous run of the same
    /// process id left there is removed first).
    pub fn new(suite: &str, name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("omnikin-{suite}-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self {
            path: dir.clone(),
            dir,
        }
    }

    /// The path `NAME` (not created) in a fresh directory of its own, [`TestDir::new`]`(suite,
    /// name)`: for a test that needs one output file.
    pub fn file(suite: &str, name: &str) -> Self {
        let d = Self::new(suite, name);
        Self {
            path: d.dir.join(name),
            dir: d.keep(),
        }
    }

    /// The path this stands for.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Keeps the directory (a failure found without a panic, reported later): returns it, no
    /// longer removed on drop.
    pub fn keep(mut self) -> PathBuf {
        std::mem::take(&mut self.dir)
    }
}

impl std::ops::Deref for TestDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for TestDir {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        if self.dir.as_os_str().is_empty() {
            return;
        }
        if std::thread::panicking() {
            eprintln!("test failed: its files are kept in {}", self.dir.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}
