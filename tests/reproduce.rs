//! `tlsmpm reproduce` on the binary: `--quick` on two cases writes `report.md` with one row
//! per published number of those cases, each with a verdict, and a reason for every row
//! that is not `matched`; `--list` names every case; an unknown case id is an input error
//! (exit 2); an existing output directory is kept unless `--force`.

use std::process::Command;
use tlsmpm::app::reproduce::{select, Verdict};

struct Outcome {
    code: i32,
    stdout: String,
    stderr: String,
}

fn tlsmpm(args: &[&str]) -> Outcome {
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("start tlsmpm");
    Outcome {
        code: output.status.code().expect("exit code"),
        stdout: String::from_utf8_lossy(&output.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
    }
}

/// The cells of the table row whose first cell is `quantity`.
fn row<'a>(report: &'a str, quantity: &str) -> Option<Vec<&'a str>> {
    report.lines().find_map(|line| {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        (cells.len() > 2 && cells[1] == quantity).then_some(cells)
    })
}

#[test]
fn quick_reproduction_reports_every_published_number_with_a_verdict() {
    let ids = ["function_reconstruction", "small_bar_conservation"];
    let dir = tempfile::tempdir().expect("temporary directory");
    let out = dir.path().join("reproduce");
    let out_arg = out.to_str().expect("utf-8 path");
    let o = tlsmpm(&["reproduce", "--quick", "--out", out_arg, ids[0], ids[1]]);
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    let report = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    let cases = select(&ids.map(String::from)).expect("known cases");
    let mut rows = 0;
    for case in &cases {
        assert!(report.contains(&format!("## {}", case.id)), "{}", case.id);
        for number in case.numbers.iter().filter(|n| n.quick) {
            let cells = row(&report, &number.quantity)
                .unwrap_or_else(|| panic!("no row for {} in\n{report}", number.quantity));
            // | quantity | published | ours | versus | tolerance | verdict | reason |
            let verdict = cells[6];
            assert!(
                ["matched", "better", "differs"].contains(&verdict),
                "{}: verdict {verdict}",
                number.quantity
            );
            let ours: f64 = cells[3].parse().expect("our number");
            assert_eq!(number.verdict(ours).name(), verdict, "{}", number.quantity);
            if verdict != Verdict::Matched.name() {
                assert!(
                    cells[7].len() > 20 && !cells[7].starts_with("no reason recorded"),
                    "{}: {verdict} without a reason",
                    number.quantity
                );
            }
            rows += 1;
        }
    }
    assert_eq!(
        rows, 16,
        "4 reconstruction numbers and the 12 of the conservation table"
    );
    // The summary counts every row.
    let total = row(&report, "**all**").expect("summary total");
    assert_eq!(total[3], "16");
    // The TLS reconstruction integral is at round-off and matched.
    let integral = row(&report, "TLS integral rel. error").expect("row");
    assert_eq!(integral[6], "matched");
    assert!(integral[3].parse::<f64>().expect("number") < 1e-13);
    assert!(
        o.stdout.contains("16 published numbers compared"),
        "{}",
        o.stdout
    );

    // A second run into the same directory is refused without --force.
    let again = tlsmpm(&["reproduce", "--quick", "--quiet", "--out", out_arg, ids[0]]);
    assert_eq!(again.code, 2, "stderr: {}", again.stderr);
    let forced = tlsmpm(&[
        "reproduce",
        "--quick",
        "--quiet",
        "--force",
        "--out",
        out_arg,
        ids[0],
    ]);
    assert_eq!(forced.code, 0, "stderr: {}", forced.stderr);
    let replaced = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(!replaced.contains("## small_bar_conservation"));
}

#[test]
fn list_names_every_case_and_unknown_ids_are_input_errors() {
    let o = tlsmpm(&["reproduce", "--list"]);
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    let all = select(&[]).expect("all cases");
    assert!(all.len() >= 10);
    for case in &all {
        assert!(o.stdout.contains(case.id), "{} not listed", case.id);
    }
    let bad = tlsmpm(&["reproduce", "--quick", "no_such_case"]);
    assert_eq!(bad.code, 2);
    assert!(bad.stderr.contains("no_such_case") && bad.stderr.contains("mms_bar"));
}
