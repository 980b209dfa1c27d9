//! A run's output directory (`--out`), written so that it always holds exactly one run.
//!
//! The run writes into a fresh staging directory next to the target
//! (`.<name>.partial-<pid>` in the same parent, so the final rename stays on one file
//! system). Then:
//!
//! * a completed run replaces the target whole ([`StagedDir::commit`]): nothing of a
//!   previous run survives beside the new files;
//! * a failed or interrupted run ([`StagedDir::keep_incomplete`]) becomes the target if the
//!   target was free, and otherwise goes to `<name>.incomplete`, so that the previous run
//!   stays intact;
//! * a run refused before it computed anything ([`StagedDir::discard`], or a drop without
//!   either of the above) leaves no trace.
//!
//! An existing non-empty target is refused unless `replace` (`--force`) is given, and even
//! then only if it looks like an output of tlsmpm (it holds one of [`RUN_MARKERS`]), so a
//! mistyped `--out` never deletes someone's data.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Files by which a directory is recognised as an output of `tlsmpm run` / `study` /
/// `reproduce`.
pub const RUN_MARKERS: [&str; 3] = ["summary.json", "study.csv", "report.md"];

/// A staging directory for one run into `target`.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    finished: bool,
}

/// Whether `dir` is missing or an empty directory.
fn is_free(dir: &Path) -> bool {
    match std::fs::read_dir(dir) {
        Ok(mut entries) => entries.next().is_none(),
        Err(_) => !dir.exists(),
    }
}

/// `parent/.<name>.<tag>-<pid>`.
fn sibling(parent: &Path, name: &str, tag: &str) -> PathBuf {
    parent.join(format!(".{name}.{tag}-{}", std::process::id()))
}

impl StagedDir {
    /// Check `target` and create the staging directory beside it. `replace` allows a
    /// non-empty target that holds a previous run.
    pub fn create(target: &Path, replace: bool) -> Result<Self> {
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| n != "." && n != "..")
            .ok_or_else(|| {
                Error::invalid(
                    "--out",
                    target.display(),
                    "name a directory of its own (not `.`, `..` or `/`)",
                )
            })?;
        if target.exists() && !target.is_dir() {
            return Err(Error::invalid(
                "--out",
                target.display(),
                "exists and is not a directory",
            ));
        }
        if !is_free(target) {
            if !RUN_MARKERS.iter().any(|m| target.join(m).exists()) {
                return Err(Error::invalid(
                    "--out",
                    target.display(),
                    "is a non-empty directory that does not hold a tlsmpm run (no summary.json, \
                     study.csv or report.md); choose another directory",
                ));
            }
            if !replace {
                return Err(Error::invalid(
                    "--out",
                    target.display(),
                    "already holds a run; choose another directory or pass --force to replace it whole",
                ));
            }
        }
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(|e| Error::write(target, e))?;
        let staging = sibling(&parent, &name, "partial");
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(|e| Error::write(&staging, e))?;
        }
        std::fs::create_dir(&staging).map_err(|e| Error::write(target, e))?;
        Ok(Self {
            target: target.to_path_buf(),
            staging,
            finished: false,
        })
    }

    /// The directory the run writes into.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The `--out` directory.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The run completed: it replaces the target whole.
    pub fn commit(mut self) -> Result<PathBuf> {
        self.finished = true;
        self.move_to(&self.target)?;
        Ok(self.target.clone())
    }

    /// The run failed or was interrupted after writing its partial output: it becomes the
    /// target if that is free, and `<target>.incomplete` otherwise (the previous run stays).
    /// Returns where it went.
    pub fn keep_incomplete(mut self) -> Result<PathBuf> {
        self.finished = true;
        let destination = if is_free(&self.target) {
            self.target.clone()
        } else {
            let mut name = self.target.as_os_str().to_owned();
            name.push(".incomplete");
            PathBuf::from(name)
        };
        self.move_to(&destination)?;
        Ok(destination)
    }

    /// Nothing worth keeping was written: remove the staging directory.
    pub fn discard(mut self) {
        self.finished = true;
        let _ = std::fs::remove_dir_all(&self.staging);
    }

    /// Rename the staging directory to `destination`, replacing what is there whole: the
    /// old directory is first renamed aside, so a failed rename can put it back.
    fn move_to(&self, destination: &Path) -> Result<()> {
        let aside = self.staging.with_file_name(format!(
            ".{}.old-{}",
            destination
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            std::process::id()
        ));
        let had_old = destination.exists();
        if had_old {
            std::fs::rename(destination, &aside).map_err(|e| Error::write(destination, e))?;
        }
        if let Err(e) = std::fs::rename(&self.staging, destination) {
            if had_old {
                let _ = std::fs::rename(&aside, destination);
            }
            return Err(Error::write(destination, e));
        }
        if had_old {
            std::fs::remove_dir_all(&aside).map_err(|e| Error::write(&aside, e))?;
        }
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.finished {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_completed_run_replaces_the_previous_one_whole() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("summary.json"), "old").unwrap();
        std::fs::write(out.join("pore_pressure.svg"), "old").unwrap();
        let refused = StagedDir::create(&out, false).unwrap_err();
        assert_eq!(refused.exit_code(), 2);
        assert!(refused.to_string().contains("--force"), "{refused}");
        let staged = StagedDir::create(&out, true).unwrap();
        std::fs::write(staged.path().join("summary.json"), "new").unwrap();
        assert_eq!(staged.commit().unwrap(), out);
        assert_eq!(names(&out), ["summary.json"]);
        assert_eq!(
            std::fs::read_to_string(out.join("summary.json")).unwrap(),
            "new"
        );
        assert_eq!(names(root.path()), ["out"]);
    }

    #[test]
    fn an_incomplete_run_never_replaces_a_previous_one() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("summary.json"), "old").unwrap();
        let staged = StagedDir::create(&out, true).unwrap();
        std::fs::write(staged.path().join("summary.json"), "partial").unwrap();
        let kept = staged.keep_incomplete().unwrap();
        assert_eq!(kept, root.path().join("out.incomplete"));
        assert_eq!(
            std::fs::read_to_string(out.join("summary.json")).unwrap(),
            "old"
        );
        assert_eq!(
            std::fs::read_to_string(kept.join("summary.json")).unwrap(),
            "partial"
        );
        // Into a free target, the partial output is the run's directory.
        let fresh = root.path().join("fresh");
        let staged = StagedDir::create(&fresh, false).unwrap();
        std::fs::write(staged.path().join("summary.json"), "partial").unwrap();
        assert_eq!(staged.keep_incomplete().unwrap(), fresh);
        assert_eq!(names(root.path()), ["fresh", "out", "out.incomplete"]);
    }

    #[test]
    fn a_discarded_or_dropped_run_leaves_no_trace() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("nested").join("out");
        StagedDir::create(&out, false).unwrap().discard();
        drop(StagedDir::create(&out, false).unwrap());
        assert_eq!(names(&root.path().join("nested")), Vec::<String>::new());
    }

    #[test]
    fn directories_that_are_not_runs_are_never_replaced() {
        let root = tempfile::tempdir().unwrap();
        std::fs::write(root.path().join("thesis.tex"), "precious").unwrap();
        let err = StagedDir::create(root.path(), true).unwrap_err();
        assert!(
            err.to_string().contains("does not hold a tlsmpm run"),
            "{err}"
        );
        let file = root.path().join("thesis.tex");
        assert!(StagedDir::create(&file, true).is_err());
        assert!(StagedDir::create(Path::new("."), true).is_err());
        assert_eq!(names(root.path()), ["thesis.tex"]);
    }
}
