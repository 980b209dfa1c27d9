//! Convergence studies: one scenario over several cell counts (same particles per cell),
//! errors per field and observed orders `log(e_k-1 / e_k) / log(h_k-1 / h_k)`; writes
//! `study.csv` and `convergence.svg`, and each run's outputs into `cells_<N>/`.

use crate::app::{run, RunOptions};
use crate::config::{KeySource, Scenario};
use crate::error::{Error, Result};
use crate::numerics::norms::observed_order;
use crate::output::plot::{loglog_plot_ticked, Axes, Series, Style};
use crate::output::write_atomic;
use crate::problems::Field;
use std::fmt::Write as _;
use std::path::Path;

/// Errors of one resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyRow {
    pub cells: usize,
    pub h: f64,
    pub n_particles: usize,
    /// `(field, rms, rel_l2, observed rms order vs the previous row)`.
    pub fields: Vec<(Field, f64, f64, f64)>,
    /// The run's warnings (its `summary.json`'s `warnings`).
    pub warnings: Vec<String>,
}

/// Warnings about the study itself: a `grid.cells` given with `--set`, which `--cells`
/// replaces (one given in the file is the scenario's own resolution and replaced silently).
/// Each run's `summary.json` repeats them.
pub fn study_warnings(scenario: &Scenario) -> Vec<String> {
    match scenario.given_keys.source("grid.cells") {
        Some(KeySource::Set) => vec![format!(
            "grid.cells = {} given with --set is ignored: study --cells sets the cell counts",
            scenario.given_keys.value("grid.cells").unwrap_or("(given)")
        )],
        _ => Vec::new(),
    }
}

/// Run the study; returns one row per cell count (in the given order). If a run fails,
/// `study.csv` holds the rows of the runs before it (the failed run's own directory has its
/// partial output) and its error is returned.
pub fn study(
    scenario: &Scenario,
    name: &str,
    cells: &[usize],
    options: &RunOptions,
    progress: &mut (dyn FnMut(usize, usize, usize) + Send),
) -> Result<Vec<StudyRow>> {
    if cells.is_empty() {
        return Err(Error::invalid(
            "--cells",
            "(empty)",
            "give at least one cell count",
        ));
    }
    let mut rows: Vec<StudyRow> = Vec::new();
    for &n in cells {
        let mut resolved = scenario.clone();
        resolved.grid.cells = n.into();
        let mut run_options = RunOptions {
            out_dir: options.out_dir.join(format!("cells_{n}")),
            ..options.clone()
        };
        run_options.warnings.extend(study_warnings(scenario));
        let summary = match run(&resolved, name, &run_options, &mut |step, total| {
            progress(n, step, total)
        }) {
            Ok(summary) => summary,
            Err(failure) => {
                // Keep the table of the runs that completed (partial output), then fail.
                if !rows.is_empty() {
                    write_study_csv(&options.out_dir.join("study.csv"), &rows)?;
                }
                return Err(failure);
            }
        };
        let warnings = summary.warnings;
        let errors = summary.errors.unwrap_or_default();
        let h = if resolved.problem.dim > 1 {
            crate::problems::tensor::cell_size_x(&resolved)?
        } else {
            crate::problems::build(&resolved)?.length() / n as f64
        };
        let mut fields = Vec::new();
        for field in Field::TWO_PHASE {
            if let (Some(&e_rms), Some(&e_l2)) = (
                errors.rms.get(field.name()),
                errors.rel_l2.get(field.name()),
            ) {
                let order = rows
                    .last()
                    .and_then(|prev| {
                        prev.fields
                            .iter()
                            .find(|f| f.0 == field)
                            .map(|f| observed_order(f.1, prev.h, e_rms, h))
                    })
                    .unwrap_or(f64::NAN);
                fields.push((field, e_rms, e_l2, order));
            }
        }
        rows.push(StudyRow {
            cells: n,
            h,
            n_particles: summary.n_particles,
            fields,
            warnings,
        });
    }
    write_study_csv(&options.out_dir.join("study.csv"), &rows)?;
    if scenario.output.plots {
        convergence_plot(&options.out_dir.join("convergence.svg"), name, &rows)?;
    }
    Ok(rows)
}

/// The study as a text table: errors and observed orders per field.
pub fn format_table(rows: &[StudyRow]) -> String {
    let mut out = String::new();
    let Some(first) = rows.first() else {
        return out;
    };
    let _ = write!(out, "{:>6} {:>10}", "cells", "h");
    for (field, ..) in &first.fields {
        let _ = write!(
            out,
            " {:>14} {:>6}",
            format!("rms {}", short(*field)),
            "order"
        );
    }
    out.push('\n');
    for row in rows {
        let _ = write!(out, "{:>6} {:>10.4e}", row.cells, row.h);
        for &(_, e_rms, _, order) in &row.fields {
            let order = if order.is_nan() {
                "-".to_string()
            } else {
                format!("{order:.2}")
            };
            let _ = write!(out, " {e_rms:>14.4e} {order:>6}");
        }
        out.push('\n');
    }
    out
}

fn short(field: Field) -> &'static str {
    match field {
        Field::Displacement => "u",
        Field::Velocity => "v",
        Field::Stress => "sigma",
        Field::LiquidVelocity => "v_w",
        Field::PorePressure => "p",
        Field::EffectiveStress => "sigma'",
    }
}

fn write_study_csv(path: &Path, rows: &[StudyRow]) -> Result<()> {
    let mut out = String::from("cells,h,n_particles");
    if let Some(first) = rows.first() {
        for (field, ..) in &first.fields {
            let f = field.name();
            let _ = write!(out, ",rms_{f},rel_l2_{f},order_{f}");
        }
    }
    out.push('\n');
    for row in rows {
        let _ = write!(out, "{},{:e},{}", row.cells, row.h, row.n_particles);
        for &(_, e_rms, e_l2, order) in &row.fields {
            let order = if order.is_nan() {
                String::new()
            } else {
                format!("{order:.6}")
            };
            let _ = write!(out, ",{e_rms:e},{e_l2:e},{order}");
        }
        out.push('\n');
    }
    write_atomic(path, out.as_bytes())
}

fn convergence_plot(path: &Path, name: &str, rows: &[StudyRow]) -> Result<()> {
    let Some(first) = rows.first() else {
        return Ok(());
    };
    let h: Vec<f64> = rows.iter().map(|r| r.h).collect();
    let data: Vec<(String, Vec<f64>)> = first
        .fields
        .iter()
        .enumerate()
        .map(|(k, (field, ..))| {
            (
                format!("RMS {}", field.name()),
                rows.iter()
                    .map(|r| r.fields.get(k).map_or(f64::NAN, |f| f.1))
                    .collect(),
            )
        })
        .collect();
    let mut series: Vec<Series> = data
        .iter()
        .map(|(label, y)| Series {
            label,
            x: (&h).into(),
            y: y.into(),
            style: Style::LinePoints,
        })
        .collect();
    let guides = slope_guides(&h, &data);
    series.extend(guides.iter().map(|(label, x, y)| Series {
        label,
        x: x.into(),
        y: y.into(),
        style: Style::Guide,
    }));
    let title = format!("{name}: convergence");
    loglog_plot_ticked(
        path,
        &Axes {
            title: &title,
            x_label: "cell size h [m]",
            y_label: "RMS error",
        },
        &series,
        &h,
    )
}

/// Slope guides `e = C h^s`, `s = 1, 2, 3`, over the range of `h`: they start at the
/// coarsest `h`, half a decade below the smallest error there, and are labelled at the
/// finest `h`. None with fewer than two cell sizes or no positive error.
fn slope_guides(h: &[f64], data: &[(String, Vec<f64>)]) -> Vec<(String, Vec<f64>, Vec<f64>)> {
    let positive = |v: &f64| v.is_finite() && *v > 0.0;
    let h_max = h.iter().copied().filter(positive).fold(f64::NAN, f64::max);
    let h_min = h.iter().copied().filter(positive).fold(f64::NAN, f64::min);
    let Some(coarsest) = h.iter().position(|&v| v == h_max) else {
        return Vec::new();
    };
    let anchor = data
        .iter()
        .filter_map(|(_, e)| e.get(coarsest).copied().filter(positive))
        .fold(f64::NAN, f64::min);
    if h_min.is_nan() || h_min >= h_max || !positive(&anchor) {
        return Vec::new();
    }
    let start = anchor / 10f64.sqrt();
    (1..=3)
        .map(|s| {
            let end = start * (h_min / h_max).powi(s);
            (format!("slope {s}"), vec![h_max, h_min], vec![start, end])
        })
        .collect()
}
