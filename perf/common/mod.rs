//! Shared by the pprof examples (`perf/profile_step.rs`, `perf/profile_mass_solve.rs`):
//! argument parsing, the profiler set-up, the flamegraph SVG and the sample tables.
//!
//! Included from each example with `#[path = "common/mod.rs"] mod common;` (unix only:
//! pprof needs it).

use std::collections::HashMap;
use std::path::Path;

/// Rows printed per sample table.
pub const TOP: usize = 12;

/// Walk `args` in order: `-h`/`--help` stops with `Ok(false)`; every other argument must be
/// one of `flags`, with its value either inline (`--flag=value`) or as the next argument,
/// and is handed to `apply(flag, value)` (whose error stops the walk). `Ok(true)` when every
/// argument was applied.
pub fn parse_flags(
    args: &[String],
    flags: &[&str],
    mut apply: impl FnMut(&str, String) -> Result<(), String>,
) -> Result<bool, String> {
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        let (flag, inline) = match arg.split_once('=') {
            Some((flag, value)) if flag.starts_with("--") => (flag, Some(value.to_string())),
            _ => (arg.as_str(), None),
        };
        if matches!(flag, "-h" | "--help") {
            return Ok(false);
        }
        if !flags.contains(&flag) {
            return Err(format!("unknown argument `{arg}`"));
        }
        let value = match inline {
            Some(value) => value,
            None => it
                .next()
                .cloned()
                .ok_or_else(|| format!("`{flag}` needs a value"))?,
        };
        apply(flag, value)?;
    }
    Ok(true)
}

/// A positive integer; accepts `1000000`, `1_000_000` and `1e6`.
pub fn count(flag: &str, value: &str) -> Result<usize, String> {
    let bad = || format!("`{flag} {value}`: expected a positive integer");
    let cleaned = value.replace('_', "");
    let n = match cleaned.parse::<usize>() {
        Ok(n) => n,
        Err(_) => {
            let x: f64 = cleaned.parse().map_err(|_| bad())?;
            if !(x.is_finite() && x >= 1.0 && x.fract() == 0.0 && x <= 1e15) {
                return Err(bad());
            }
            x as usize
        }
    };
    if n == 0 {
        return Err(bad());
    }
    Ok(n)
}

/// The value of `--out`: a non-empty path.
pub fn out_path(value: String) -> Result<std::path::PathBuf, String> {
    if value.is_empty() {
        return Err("`--out` needs a non-empty path".to_string());
    }
    Ok(std::path::PathBuf::from(value))
}

/// Strip the `::h0123456789abcdef` hash of a demangled Rust symbol.
pub fn short(name: &str) -> &str {
    match name.rsplit_once("::h") {
        Some((head, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => {
            head
        }
        _ => name,
    }
}

/// Start sampling all threads at 1000 Hz, skipping frames in the C runtime.
pub fn start_profiler() -> Result<pprof::ProfilerGuard<'static>, String> {
    pprof::ProfilerGuardBuilder::default()
        .frequency(1000)
        .blocklist(&["libc", "libgcc", "pthread", "vdso"])
        .build()
        .map_err(|e| format!("starting the profiler: {e}"))
}

/// The samples so far, symbolised.
pub fn build_report(guard: &pprof::ProfilerGuard<'_>) -> Result<pprof::Report, String> {
    guard
        .report()
        .build()
        .map_err(|e| format!("building the profile report: {e}"))
}

/// Write the flamegraph SVG of `report` to `out` (creating its folder) and say so.
pub fn write_flamegraph(report: &pprof::Report, out: &Path) -> Result<(), String> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    }
    let file =
        std::fs::File::create(out).map_err(|e| format!("creating {}: {e}", out.display()))?;
    report
        .flamegraph(std::io::BufWriter::new(file))
        .map_err(|e| format!("writing {}: {e}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}

/// Print the [`TOP`] frames with the most self samples (leaf frame = innermost inlined
/// function) and the [`TOP`] `tlsmpm` functions with the most inclusive samples (counted
/// once per stack).
pub fn print_tables(report: &pprof::Report) {
    let mut total = 0isize;
    let mut leaf: HashMap<String, isize> = HashMap::new();
    let mut inclusive: HashMap<String, isize> = HashMap::new();
    for (frames, &count) in &report.data {
        total += count;
        let names: Vec<String> = frames
            .frames
            .iter()
            .flatten()
            .map(|s| short(&s.name()).to_string())
            .collect();
        if let Some(first) = names.first() {
            *leaf.entry(first.clone()).or_default() += count;
        }
        let mut seen: Vec<&String> = names
            .iter()
            .filter(|n| n.starts_with("tlsmpm::") || n.starts_with("<tlsmpm::"))
            .collect();
        seen.sort();
        seen.dedup();
        for name in seen {
            *inclusive.entry(name.clone()).or_default() += count;
        }
    }
    let print = |title: &str, map: HashMap<String, isize>| {
        let mut rows: Vec<(String, isize)> = map.into_iter().collect();
        rows.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        println!("\n{title} ({total} samples)");
        for (name, count) in rows.into_iter().take(TOP) {
            let pct = 100.0 * count as f64 / total.max(1) as f64;
            println!("{pct:6.1}%  {count:7}  {name}");
        }
    };
    print("self samples, by leaf frame", leaf);
    print("inclusive samples, tlsmpm functions", inclusive);
}

/// The shared `main` of the profiling examples: parse the arguments (`--help` prints
/// `usage`; a bad argument prints the message and `usage`, exit 2), then run (a failure
/// prints its message, exit 1).
pub fn main<O>(
    usage: &str,
    parse: fn(&[String]) -> Result<Option<O>, String>,
    run: fn(&O) -> Result<(), String>,
) {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = match parse(&args) {
        Ok(Some(options)) => options,
        Ok(None) => {
            println!("{usage}");
            return;
        }
        Err(message) => {
            eprintln!("error: {message}\n\n{usage}");
            std::process::exit(2);
        }
    };
    if let Err(message) = run(&options) {
        eprintln!("error: {message}");
        std::process::exit(1);
    }
}
