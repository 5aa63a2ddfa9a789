//! Report bundles: a report's files rendered in memory, then written into one folder together, so a
//! failed run never leaves half a report behind.
use std::path::{Path, PathBuf};

use riskscore_output::OutputDir;

use super::report::{write_folds_csv, CvReport, FoldResult};

/// One rendered file of a report: its name inside the report folder and its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportFile {
    pub name: String,
    pub bytes: Vec<u8>,
}

/// A report could not be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error("{name}: {source}")]
    Table {
        name: String,
        #[source]
        source: csv::Error,
    },
    #[error("{name}: {source}")]
    Json {
        name: String,
        #[source]
        source: serde_json::Error,
    },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The output layer's own errors already name the folder.
    #[error(transparent)]
    Folder(std::io::Error),
}

/// The files of one report folder, in the order they were added.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReportBundle {
    pub files: Vec<ReportFile>,
}

impl ReportBundle {
    /// Adds a file with these bytes.
    pub fn add(&mut self, name: &str, bytes: impl Into<Vec<u8>>) {
        self.files.push(ReportFile {
            name: name.to_owned(),
            bytes: bytes.into(),
        });
    }

    /// Adds a CSV table rendered by `write`.
    pub fn add_csv(
        &mut self,
        name: &str,
        write: impl FnOnce(&mut Vec<u8>) -> csv::Result<()>,
    ) -> Result<(), BundleError> {
        let mut bytes = Vec::new();
        write(&mut bytes).map_err(|source| BundleError::Table {
            name: name.to_owned(),
            source,
        })?;
        self.add(name, bytes);
        Ok(())
    }

    /// Adds `value` as pretty-printed JSON (no final newline).
    pub fn add_json(
        &mut self,
        name: &str,
        value: &impl serde::Serialize,
    ) -> Result<(), BundleError> {
        let text = serde_json::to_string_pretty(value).map_err(|source| BundleError::Json {
            name: name.to_owned(),
            source,
        })?;
        self.add(name, text);
        Ok(())
    }

    /// Writes every file into `dir` as a whole ([`OutputDir`]): a new folder beside it is written
    /// complete, then swapped in (files of the old folder the bundle does not write are kept).
    /// On error the old folder is untouched. Returns the paths in bundle order.
    pub fn write_to(&self, dir: &Path) -> Result<Vec<PathBuf>, BundleError> {
        let out = OutputDir::create(dir).map_err(BundleError::Folder)?;
        self.write_files(out.path(), dir)?;
        out.commit().map_err(BundleError::Folder)?;
        Ok(self.paths_in(dir))
    }

    /// Writes every file into `dir`, a folder that is not in place yet and goes in as a whole
    /// later (a staged [`OutputDir`]'s folder, or a subfolder of one), creating it if missing.
    /// [`Self::write_to`] would stage a second copy inside the first. Returns the paths written.
    pub fn write_into(&self, dir: &Path) -> Result<Vec<PathBuf>, BundleError> {
        std::fs::create_dir_all(dir).map_err(|source| BundleError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        self.write_files(dir, dir)?;
        Ok(self.paths_in(dir))
    }

    /// Writes the files into `dir`; errors name each file under `shown`, where it will be.
    fn write_files(&self, dir: &Path, shown: &Path) -> Result<(), BundleError> {
        for f in &self.files {
            std::fs::write(dir.join(&f.name), &f.bytes).map_err(|source| BundleError::Io {
                path: shown.join(&f.name),
                source,
            })?;
        }
        Ok(())
    }

    fn paths_in(&self, dir: &Path) -> Vec<PathBuf> {
        self.files.iter().map(|f| dir.join(&f.name)).collect()
    }
}

/// The tables of a cross-validation report: `results.md`, `results.json`, `results.csv` (mean ±
/// std per method) and `folds.csv` (every fold's metrics).
pub fn cv_report_bundle(
    report: &CvReport,
    folds: &[FoldResult],
) -> Result<ReportBundle, BundleError> {
    let mut bundle = ReportBundle::default();
    bundle.add("results.md", report.to_markdown());
    bundle.add_json("results.json", &report.to_json())?;
    bundle.add_csv("results.csv", |w| report.write_csv(w))?;
    bundle.add_csv("folds.csv", |w| write_folds_csv(folds, w))?;
    Ok(bundle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_every_file_in_order_or_none() {
        let dir = std::env::temp_dir().join(format!("riskscore-bundle-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut bundle = ReportBundle::default();
        bundle.add("a.md", "alpha");
        bundle
            .add_csv("b.csv", |w| {
                csv::Writer::from_writer(w).write_record(["x", "y"])
            })
            .unwrap();
        let written = bundle.write_to(&dir).unwrap();
        assert_eq!(written, vec![dir.join("a.md"), dir.join("b.csv")]);
        assert_eq!(std::fs::read_to_string(dir.join("a.md")).unwrap(), "alpha");
        assert_eq!(std::fs::read_to_string(dir.join("b.csv")).unwrap(), "x,y\n");

        // A file that cannot be created leaves the others untouched and no temporary file behind.
        let mut failing = ReportBundle::default();
        failing.add("a.md", "changed");
        failing.add("missing/c.csv", "nope");
        assert!(matches!(
            failing.write_to(&dir),
            Err(BundleError::Io { .. })
        ));
        assert_eq!(std::fs::read_to_string(dir.join("a.md")).unwrap(), "alpha");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            2,
            "a temporary file was left"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn write_into_writes_in_place_without_a_second_staging() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("staged/sub");
        let mut bundle = ReportBundle::default();
        bundle.add("a.md", "alpha");
        bundle.add("b.md", "beta");
        let written = bundle.write_into(&dir).unwrap();
        assert_eq!(written, vec![dir.join("a.md"), dir.join("b.md")]);
        assert_eq!(std::fs::read_to_string(dir.join("b.md")).unwrap(), "beta");
        let names: Vec<_> = std::fs::read_dir(d.path().join("staged"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["sub"], "a temporary folder beside it");
        let mut failing = ReportBundle::default();
        failing.add("missing/c.csv", "nope");
        let e = failing.write_into(&dir).unwrap_err();
        assert!(e.to_string().contains("missing/c.csv"), "{e}");
    }
}
