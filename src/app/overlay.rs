//! `tlsmpm overlay`: one particle field of several finished runs in one figure, or (with
//! `--axis h`) one error column of several finished studies in one log-log figure.
//!
//! Reads `RUN_DIR/particles.csv` of each run, takes one column (any name in the header, e.g.
//! `pore_pressure`, `stress`, `u`) against the initial position `x0` or the current position
//! `x`, sorted along that axis, and draws one point series per run with
//! [`profile_plot`]; optionally the first run's `<COLUMN>_exact` column as a line. Series are
//! labelled by the given labels, else by the run directory's name followed by the `basis /
//! reconstruction` of its `summary.json` when that file is there.
//!
//! With `--axis h` each directory is a `tlsmpm study` output: the column (e.g.
//! `rms_displacement`) of its `study.csv` is drawn against the cell size `h` on log-log
//! axes, one line per study — the comparison plot of several methods' convergence.
//!
//! With `--axis time` a column of each run's `history.csv` (e.g. `kinetic_energy`) is drawn
//! against the time, one line per run; `total_energy` is the sum of `kinetic_energy` and
//! `strain_energy` — the energy plot of long runs.
//!
//! Bad input (a missing file, a column not in the header, an unparsable number, more labels
//! than runs) is an input error naming the path, line or column; nothing panics.

use crate::error::{Error, Result};
use crate::output::plot::{loglog_plot, profile_plot, Axes, Series, Style};
use std::path::{Path, PathBuf};

/// The horizontal axis of the overlay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Initial position `x0` (column `x0`).
    Initial,
    /// Current position `x` (column `x`).
    Current,
    /// Cell size `h` of a study (`study.csv`, log-log axes).
    MeshSize,
    /// Time (`history.csv`, one line per run).
    Time,
}

impl Axis {
    /// `x0` or `x`.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "x0" => Some(Axis::Initial),
            "x" => Some(Axis::Current),
            "h" => Some(Axis::MeshSize),
            "time" => Some(Axis::Time),
            _ => None,
        }
    }

    /// The column name and the axis label.
    fn names(self) -> (&'static str, &'static str) {
        match self {
            Axis::Initial => ("x0", "initial position X [m]"),
            Axis::Current => ("x", "x [m]"),
            Axis::MeshSize => ("h", "cell size h [m]"),
            Axis::Time => ("time", "time t [s]"),
        }
    }

    /// The file read from each directory.
    fn file(self) -> &'static str {
        match self {
            Axis::MeshSize => "study.csv",
            Axis::Time => "history.csv",
            _ => "particles.csv",
        }
    }
}

/// What to overlay and where to write it.
#[derive(Clone, Debug)]
pub struct OverlayOptions {
    /// Run directories, each holding a `particles.csv`.
    pub runs: Vec<PathBuf>,
    /// Column to plot.
    pub field: String,
    /// Horizontal axis.
    pub axis: Axis,
    /// Series labels in run order; runs without one get a default label.
    pub labels: Vec<String>,
    /// Also draw `<field>_exact` of the first run as a line.
    pub exact: bool,
    /// Output SVG [default: `overlay_<field>.svg` in the current directory].
    pub out: Option<PathBuf>,
}

/// A parsed `particles.csv`: its path, header and one vector per column.
#[derive(Debug)]
pub struct Table {
    pub path: PathBuf,
    pub header: Vec<String>,
    pub columns: Vec<Vec<f64>>,
}

impl Table {
    /// Read a CSV file of numbers with a header row (blank lines are skipped).
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::ReadInput {
            path: path.to_path_buf(),
            source,
        })?;
        let bad = |line: usize, message: String| Error::ReadInput {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("line {line}: {message}"),
            ),
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, first)) = lines.next() else {
            return Err(bad(1, "empty file, expected a header row".into()));
        };
        let header: Vec<String> = first.split(',').map(|s| s.trim().to_string()).collect();
        let mut columns = vec![Vec::new(); header.len()];
        for (index, line) in lines {
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != header.len() {
                let n = fields.len();
                let m = header.len();
                return Err(bad(index + 1, format!("{n} fields, the header has {m}")));
            }
            for ((name, field), column) in header.iter().zip(&fields).zip(&mut columns) {
                // An empty cell (the first row's order in study.csv) is a missing value.
                let field = field.trim();
                if field.is_empty() {
                    column.push(f64::NAN);
                    continue;
                }
                let value = field.parse::<f64>().map_err(|_| {
                    bad(
                        index + 1,
                        format!("column `{name}`: `{field}` is not a number"),
                    )
                })?;
                column.push(value);
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            columns,
        })
    }

    /// With `kinetic_energy` and `strain_energy` columns (a `history.csv`), also their sum
    /// `total_energy`.
    pub fn with_total_energy(mut self) -> Self {
        if self.get("total_energy").is_some() {
            return self;
        }
        if let (Some(kinetic), Some(stored)) =
            (self.get("kinetic_energy"), self.get("strain_energy"))
        {
            let total = kinetic.iter().zip(stored).map(|(k, s)| k + s).collect();
            self.header.push("total_energy".into());
            self.columns.push(total);
        }
        self
    }

    /// The column called `name`, or `None`.
    pub fn get(&self, name: &str) -> Option<&[f64]> {
        let k = self.header.iter().position(|h| h == name)?;
        self.columns.get(k).map(Vec::as_slice)
    }

    /// The column called `name`; else an invalid `key` listing the available columns.
    pub fn column(&self, key: &str, name: &str) -> Result<&[f64]> {
        self.get(name).ok_or_else(|| {
            let path = self.path.display();
            let available = self.header.join(", ");
            Error::invalid(
                key,
                name,
                format!("no such column in {path} (available: {available})"),
            )
        })
    }
}

/// `(x, y)` sorted by `x` (ties keep file order).
fn sorted(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut pairs: Vec<(f64, f64)> = x.iter().copied().zip(y.iter().copied()).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    pairs.into_iter().unzip()
}

/// The directory's name, with ` (basis / reconstruction)` from its `summary.json` if readable.
fn default_label(run: &Path) -> String {
    let name = run
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_else(|| run.display().to_string());
    let summary = std::fs::read_to_string(run.join("summary.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).ok());
    let field = |key: &str| {
        let value = summary.as_ref()?.get(key)?.as_str()?;
        Some(value.to_string())
    };
    match (field("basis"), field("reconstruction")) {
        (Some(basis), Some(reconstruction)) => format!("{name} ({basis} / {reconstruction})"),
        _ => name,
    }
}

/// Draw the overlay; returns the path of the SVG written.
pub fn overlay(options: &OverlayOptions) -> Result<PathBuf> {
    if options.runs.is_empty() {
        return Err(Error::invalid("RUN_DIR", "(none)", "give at least one run"));
    }
    if options.labels.len() > options.runs.len() {
        let (l, r) = (options.labels.len(), options.runs.len());
        return Err(Error::invalid(
            "--label",
            options.labels[r..].join(", "),
            format!("{l} labels for {r} runs"),
        ));
    }
    let field = options.field.as_str();
    let (axis, axis_label) = options.axis.names();
    let mut data = Vec::with_capacity(options.runs.len());
    let mut exact = None;
    for (k, run) in options.runs.iter().enumerate() {
        let table = Table::read(&run.join(options.axis.file()))?.with_total_energy();
        let label = match options.labels.get(k) {
            Some(label) => label.clone(),
            None => default_label(run),
        };
        let (x, y) = sorted(
            table.column("--axis", axis)?,
            table.column("--field", field)?,
        );
        if options.exact && k == 0 {
            let name = format!("{field}_exact");
            exact = Some(sorted(
                table.column("--axis", axis)?,
                table.column("--exact", &name)?,
            ));
        }
        data.push((label, x, y));
    }
    // The exact solution first (thin, drawn under the runs), then the runs in order.
    let mut series: Vec<Series> = Vec::new();
    if let Some((x, y)) = &exact {
        series.push(Series {
            label: "exact",
            x: x.into(),
            y: y.into(),
            style: Style::Reference,
        });
    }
    series.extend(data.iter().map(|(label, x, y)| Series {
        label,
        x: x.into(),
        y: y.into(),
        style: match options.axis {
            Axis::MeshSize => Style::LinePoints,
            Axis::Time => Style::Line,
            _ => Style::Points,
        },
    }));
    let path = options
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("overlay_{field}.svg")));
    let title = format!("{field} of {} runs", options.runs.len());
    let axes = Axes {
        title: &title,
        x_label: axis_label,
        y_label: field,
    };
    match options.axis {
        Axis::MeshSize => loglog_plot(&path, &axes, &series)?,
        _ => profile_plot(&path, &axes, &series)?,
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, text: &str) -> PathBuf {
        let path = dir.join("particles.csv");
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn parses_columns_of_a_small_csv() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "x0,x,stress\n2e-1,2.1e-1,-1e0\n1e-1,1e-1,3.5e2\n\n",
        );
        let table = Table::read(&path).unwrap();
        assert_eq!(table.header, ["x0", "x", "stress"]);
        assert_eq!(table.get("stress").unwrap(), [-1.0, 350.0]);
        let (x, y) = sorted(table.get("x0").unwrap(), table.get("stress").unwrap());
        assert_eq!((x, y), (vec![0.1, 0.2], vec![350.0, -1.0]));
    }

    #[test]
    fn study_mode_reads_study_csv_with_empty_orders_on_log_axes() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("study.csv"),
            "cells,h,rms_stress,order_stress\n8,1.25e-1,1e3,\n16,6.25e-2,2.5e2,2e0\n",
        )
        .unwrap();
        let table = Table::read(&dir.path().join("study.csv")).unwrap();
        let orders = table.get("order_stress").unwrap();
        assert!(orders[0].is_nan() && orders[1] == 2.0);
        let out = dir.path().join("o.svg");
        let options = OverlayOptions {
            runs: vec![dir.path().to_path_buf()],
            field: "rms_stress".into(),
            axis: Axis::parse("h").unwrap(),
            labels: vec!["tls".into()],
            exact: false,
            out: Some(out.clone()),
        };
        assert_eq!(overlay(&options).unwrap(), out);
        assert!(std::fs::read_to_string(&out).unwrap().contains("tls"));
    }

    #[test]
    fn time_mode_reads_history_csv_with_a_total_energy_column() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        std::fs::create_dir_all(&run).unwrap();
        let history = run.join("history.csv");
        std::fs::write(
            &history,
            "step,time,kinetic_energy,strain_energy\n1,0.1,3.0,1.0\n2,0.2,2.5,1.25\n",
        )
        .unwrap();
        let table = Table::read(&history).unwrap().with_total_energy();
        assert_eq!(table.get("total_energy"), Some(&[4.0, 3.75][..]));
        let out = dir.path().join("energy.svg");
        let options = OverlayOptions {
            runs: vec![run],
            field: "total_energy".into(),
            axis: Axis::parse("time").unwrap(),
            labels: vec![],
            exact: false,
            out: Some(out.clone()),
        };
        assert_eq!(overlay(&options).unwrap(), out);
        assert!(std::fs::read_to_string(&out).unwrap().contains("<svg"));
    }

    #[test]
    fn missing_column_lists_the_available_ones() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), "x0,x,stress\n1e0,1e0,0e0\n");
        let table = Table::read(&path).unwrap();
        let err = table.column("--field", "nope").unwrap_err();
        let message = err.to_string();
        assert!(err.is_input_error());
        assert!(
            message.contains("nope") && message.contains("x0, x, stress"),
            "{message}"
        );
    }

    #[test]
    fn bad_number_names_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), "x0,stress\n1e0,2e0\n2e0,abc\n");
        let err = Table::read(&path).unwrap_err();
        let message = err.to_string();
        assert!(err.is_input_error());
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(
            message.contains("line 3") && message.contains("abc"),
            "{message}"
        );
    }

    #[test]
    fn too_many_labels_and_missing_run_are_input_errors() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "x0,x,stress\n1e0,1e0,0e0\n");
        let mut options = OverlayOptions {
            runs: vec![dir.path().to_path_buf()],
            field: "stress".into(),
            axis: Axis::Initial,
            labels: vec!["a".into(), "b".into()],
            exact: false,
            out: Some(dir.path().join("o.svg")),
        };
        assert!(overlay(&options)
            .unwrap_err()
            .to_string()
            .contains("--label"));
        options.labels.clear();
        options.exact = true;
        let message = overlay(&options).unwrap_err().to_string();
        assert!(message.contains("stress_exact"), "{message}");
        options.exact = false;
        assert_eq!(overlay(&options).unwrap(), dir.path().join("o.svg"));
        options.runs.push(dir.path().join("missing"));
        let err = overlay(&options).unwrap_err();
        assert!(err.is_input_error() && err.to_string().contains("missing"));
    }
}
