//! `report.md` of `tlsmpm reproduce`: the summary table (numbers compared and verdicts per
//! case), then per case every published number with ours, the ratio or difference, the
//! tolerance, the verdict and its reason, the observed orders of the case's studies, and
//! links to the plots and run directories.

use super::case::{Case, Measure, Plot, Rule, RunValue, SolverTable, Verdict};
use super::measure::Lab;
use super::{Counts, ReproduceReport, Row};
use crate::app::overlay::{overlay, Axis, OverlayOptions};
use crate::error::Result;
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// The report's name in the output directory.
pub const REPORT: &str = "report.md";

/// A value as the report shows it: counts as integers, orders with two decimals, the rest
/// with four significant digits.
fn show(value: f64, measure: &Measure, rule: Rule) -> String {
    if !value.is_finite() {
        return format!("{value}");
    }
    match (measure, rule) {
        (Measure::Solver(SolverTable::CgIterations | SolverTable::VCycles, ..), _)
        | (Measure::Run(_, RunValue::GridCrossings), _) => format!("{value:.0}"),
        (Measure::Order(..), _) | (_, Rule::Order(_)) => format!("{value:.2}"),
        _ => significant(value, 4),
    }
}

/// `value` to `digits` significant digits: plain between 1e-2 and 1e5, else scientific.
///
/// ```text
/// significant(52.0706, 4) == "52.07", significant(2.827e-16, 4) == "2.827e-16"
/// ```
fn significant(value: f64, digits: usize) -> String {
    let magnitude = value.abs();
    if magnitude == 0.0 || !(1e-2..1e5).contains(&magnitude) {
        return format!("{value:.*e}", digits - 1);
    }
    let integer_digits = magnitude.log10().floor() as i64 + 1;
    let decimals = (digits as i64 - integer_digits).max(0) as usize;
    format!("{value:.decimals$}")
}

/// `ours / published`, or `ours - published` for orders; empty when the paper states no
/// single number.
fn comparison(row: &Row, ours: f64) -> String {
    let p = &row.published;
    if !p.stated.is_empty() {
        return String::new();
    }
    match (&p.measure, p.rule) {
        (Measure::Order(..), _) | (_, Rule::Order(_)) => format!("{:+.2}", ours - p.value),
        _ => format!("x {:.3}", ours / p.value),
    }
}

/// A relative link from the directory `from` to `to` (both made absolute); the path of
/// `to` itself when they share no root.
fn link(from: &Path, to: &Path) -> String {
    let absolute = |p: &Path| -> PathBuf {
        let p = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir().unwrap_or_default().join(p)
        };
        // Lexical clean-up of `.` and `..`.
        let mut clean = PathBuf::new();
        for c in p.components() {
            match c {
                Component::CurDir => {}
                Component::ParentDir => {
                    clean.pop();
                }
                other => clean.push(other),
            }
        }
        clean
    };
    let (from, to) = (absolute(from), absolute(to));
    let (a, b): (Vec<_>, Vec<_>) = (from.components().collect(), to.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return to.display().to_string();
    }
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(
        b[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}

/// The repository's `docs/` link of a number, as seen from the output directory.
fn doc_link(out_dir: &Path, doc: &str) -> String {
    let (file, anchor) = doc.split_once('#').unwrap_or((doc, ""));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = root.join(file);
    let mut text = if target.exists() {
        link(out_dir, &target)
    } else {
        file.to_string()
    };
    if !anchor.is_empty() {
        text.push('#');
        text.push_str(anchor);
    }
    text
}

/// Draw the case's plots from its finished runs and studies (skipping what failed).
pub fn plots(case: &Case, lab: &Lab) -> Result<()> {
    for plot in &case.plots {
        let (runs, labels, field, axis, exact, file) = match plot {
            Plot::Runs {
                file,
                field,
                runs,
                exact,
            } => {
                let found: Vec<(String, PathBuf)> = runs
                    .iter()
                    .filter_map(|(label, spec)| {
                        lab.run_dir(spec)
                            .map(|d| (label.to_string(), d.to_path_buf()))
                    })
                    .collect();
                let (labels, dirs) = found.into_iter().unzip();
                (
                    dirs,
                    labels,
                    field.to_string(),
                    Axis::Initial,
                    *exact,
                    *file,
                )
            }
            Plot::Studies { file, field } => {
                let studies = case
                    .numbers
                    .iter()
                    .filter_map(|n| match &n.measure {
                        Measure::Order(spec, ..) => Some(*spec),
                        _ => None,
                    })
                    .chain(case.context.iter().copied());
                let mut labels: Vec<String> = Vec::new();
                let mut dirs: Vec<PathBuf> = Vec::new();
                for spec in studies {
                    if let Some(dir) = lab.study_dir(&spec) {
                        if !dirs.iter().any(|d| d == dir) {
                            labels.push(spec.label.to_string());
                            dirs.push(dir.to_path_buf());
                        }
                    }
                }
                (
                    dirs,
                    labels,
                    format!("rms_{field}"),
                    Axis::MeshSize,
                    false,
                    *file,
                )
            }
        };
        if runs.is_empty() {
            continue;
        }
        overlay(&OverlayOptions {
            runs,
            field,
            axis,
            labels,
            exact,
            out: Some(lab.out_dir.join(file)),
        })?;
    }
    Ok(())
}

fn counts_cells(c: Counts) -> String {
    format!(
        "{} | {} | {} | {} | {}",
        c.compared, c.matched, c.better, c.differs, c.failed
    )
}

/// Write `report.md` of the cases done so far.
pub fn write(out_dir: &Path, report: &ReproduceReport, lab: &Lab) -> Result<()> {
    let mut md = String::new();
    let total = report.counts();
    let mode = if report.quick {
        "`--quick` (smaller sizes, the numbers marked quick)"
    } else {
        "full"
    };
    let _ = writeln!(md, "# tlsmpm reproduce: the published numbers\n");
    let _ = writeln!(
        md,
        "Mode: {mode}; {} threads; wall time {:.0} s. {} published numbers compared: \
         **{} matched, {} better, {} differs**{}.\n",
        report.threads,
        report.seconds,
        total.compared,
        total.matched,
        total.better,
        total.differs,
        if total.failed > 0 {
            format!(", {} could not be computed (a run failed)", total.failed)
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        md,
        "`matched`: within the tolerance of the row; `better`: ours is more accurate and \
         the reason is known; `differs`: outside the tolerance, with the reason. The \
         `reason` column links to the page that explains it.\n"
    );
    let _ = writeln!(md, "## Summary\n");
    let _ = writeln!(
        md,
        "| case | source | compared | matched | better | differs | failed | seconds |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|");
    for outcome in &report.cases {
        let _ = writeln!(
            md,
            "| [{id}](#{id}) | {} | {} | {:.1} |",
            outcome.case.source,
            counts_cells(outcome.counts()),
            outcome.seconds,
            id = outcome.case.id,
        );
    }
    let _ = writeln!(
        md,
        "| **all** | | {} | {:.1} |\n",
        counts_cells(total),
        report.seconds
    );
    for outcome in &report.cases {
        write_case(&mut md, out_dir, outcome, lab);
    }
    write_atomic(&out_dir.join(REPORT), md.as_bytes())
}

fn write_case(md: &mut String, out_dir: &Path, outcome: &super::CaseOutcome, lab: &Lab) {
    let case = &outcome.case;
    let _ = writeln!(md, "## {}\n", case.id);
    let _ = writeln!(md, "{} — {}.\n", case.title, case.source);
    let _ = writeln!(
        md,
        "| quantity | published | tlsmpm | ours vs published | tolerance | verdict | reason |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---|---|---|");
    for row in &outcome.rows {
        let p = &row.published;
        let published = if p.stated.is_empty() {
            show(p.value, &p.measure, p.rule)
        } else {
            p.stated.to_string()
        };
        let doc = doc_link(out_dir, p.doc);
        let (ours, versus, verdict, reason) = match &row.ours {
            Ok(v) => {
                let verdict = p.verdict(*v);
                let reason = match (verdict, p.reason.is_empty()) {
                    (Verdict::Matched, _) => String::new(),
                    (_, true) => format!("no reason recorded ([the measurements]({doc}))"),
                    (_, false) => format!("{} ([more]({doc}))", p.reason),
                };
                (
                    show(*v, &p.measure, p.rule),
                    comparison(row, *v),
                    verdict.name().to_string(),
                    reason,
                )
            }
            Err(e) => (
                "—".to_string(),
                String::new(),
                "failed".to_string(),
                e.replace('|', "/"),
            ),
        };
        let _ = writeln!(
            md,
            "| {} | {published} | {ours} | {versus} | {} | {verdict} | {reason} |",
            p.quantity,
            p.rule.describe()
        );
    }
    md.push('\n');
    orders_table(md, out_dir, case, lab);
    let files: Vec<String> = case
        .plots
        .iter()
        .map(|plot| match plot {
            Plot::Runs { file, .. } | Plot::Studies { file, .. } => *file,
        })
        .filter(|file| lab.out_dir.join(file).exists())
        .map(|file| format!("[{file}]({file})"))
        .collect();
    if !files.is_empty() {
        let _ = writeln!(md, "Plots: {}.\n", files.join(", "));
    }
}

/// Observed orders of every study of the case, pair by pair (coarse to fine).
fn orders_table(md: &mut String, out_dir: &Path, case: &Case, lab: &Lab) {
    let mut studies: Vec<super::StudySpec> = Vec::new();
    for n in &case.numbers {
        if let Measure::Order(spec, ..) = &n.measure {
            if !studies.contains(spec) {
                studies.push(*spec);
            }
        }
    }
    studies.extend(case.context.iter().copied());
    if studies.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "Observed RMS orders, grid pair by grid pair (coarse to fine), and the finest RMS \
         error:\n"
    );
    let _ = writeln!(md, "| study | cells | field orders | finest RMS |");
    let _ = writeln!(md, "|---|---|---|---|");
    for spec in studies {
        let Some(rows) = lab.study_rows(&spec) else {
            let _ = writeln!(md, "| {} | | failed | |", spec.label);
            continue;
        };
        let cells: Vec<String> = rows.iter().map(|r| r.cells.to_string()).collect();
        let mut orders = Vec::new();
        let mut finest = Vec::new();
        if let Some(first) = rows.first() {
            for (k, (field, ..)) in first.fields.iter().enumerate() {
                let pairs: Vec<String> = rows
                    .iter()
                    .skip(1)
                    .map(|r| {
                        r.fields
                            .get(k)
                            .map_or("-".to_string(), |f| format!("{:.2}", f.3))
                    })
                    .collect();
                orders.push(format!("{}: {}", field.name(), pairs.join(" / ")));
                if let Some(last) = rows.last().and_then(|r| r.fields.get(k)) {
                    finest.push(format!("{} {:.2e}", field.name(), last.1));
                }
            }
        }
        let dir = lab
            .study_dir(&spec)
            .map(|d| link(out_dir, d))
            .unwrap_or_default();
        let _ = writeln!(
            md,
            "| [{}]({dir}) | {} | {} | {} |",
            spec.label,
            cells.join(", "),
            orders.join("; "),
            finest.join(", ")
        );
    }
    md.push('\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_keep_four_significant_digits() {
        assert_eq!(significant(52.0706, 4), "52.07");
        assert_eq!(significant(32877.55, 4), "32878");
        assert_eq!(significant(1.7, 4), "1.700");
        assert_eq!(significant(2.827e-16, 4), "2.827e-16");
        assert_eq!(significant(0.0123456, 4), "0.01235");
    }

    #[test]
    fn links_climb_out_of_the_output_directory() {
        assert_eq!(
            link(Path::new("/a/out/reproduce"), Path::new("/a/docs/x.md")),
            "../../docs/x.md"
        );
        assert_eq!(
            link(Path::new("/a/out"), Path::new("/a/out/f.svg")),
            "f.svg"
        );
    }
}
