//! Profile the MPM step with pprof and write a flamegraph.
//!
//! ```text
//! cargo run --release --example profile_step -- --particles 1000000 --steps 200
//! cargo run --release --example profile_step -- --particles 120000 --steps 2000 --out /tmp/fg.svg
//! ```
//!
//! Runs `--steps` steps of the vibrating bar (`scenarios/vibrating_bar.toml`: linear basis,
//! lumped mass, MUSL, 12 particles per cell, `dt = 1e-7`) with about `--particles`
//! particles on the global rayon pool (`RAYON_NUM_THREADS` picks the thread count), sampled
//! at 1000 Hz. Writes the flamegraph SVG to `--out` (default `perf/flamegraph_step.svg` in
//! the crate) and prints the frames with the most self samples and the `tlsmpm` functions
//! with the most inclusive samples. See `perf/README.md`.

#[cfg(unix)]
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = match profile::Options::parse(&args) {
        Ok(Some(options)) => options,
        Ok(None) => {
            println!("{}", profile::USAGE);
            return;
        }
        Err(message) => {
            eprintln!("error: {message}\n\n{}", profile::USAGE);
            std::process::exit(2);
        }
    };
    if let Err(message) = profile::run(&options) {
        eprintln!("error: {message}");
        std::process::exit(1);
    }
}

#[cfg(not(unix))]
fn main() {
    eprintln!("error: profile_step needs pprof, which is only available on unix");
    std::process::exit(1);
}

#[cfg(unix)]
mod profile {
    use std::collections::HashMap;
    use std::path::PathBuf;
    use std::time::Instant;
    use tlsmpm::app::build::build_simulation;

    const SCENARIO: &str = include_str!("../scenarios/vibrating_bar.toml");
    const PER_CELL: usize = 12;
    const TOP: usize = 12;

    pub const USAGE: &str = "\
usage: profile_step [--particles N] [--steps S] [--out FILE]

  --particles N   particles, rounded down to a multiple of 12 (default 1000000, at least 12)
  --steps S       time steps to profile (default 200, at least 1)
  --out FILE      flamegraph SVG to write (default perf/flamegraph_step.svg in the crate)
  -h, --help      this message";

    pub struct Options {
        pub particles: usize,
        pub steps: usize,
        pub out: PathBuf,
    }

    impl Options {
        /// `Ok(None)` for `--help`; `Err` with a message for bad arguments.
        pub fn parse(args: &[String]) -> Result<Option<Self>, String> {
            let mut options = Options {
                particles: 1_000_000,
                steps: 200,
                out: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("perf/flamegraph_step.svg"),
            };
            let mut it = args.iter();
            while let Some(arg) = it.next() {
                let (flag, inline) = match arg.split_once('=') {
                    Some((flag, value)) if flag.starts_with("--") => {
                        (flag, Some(value.to_string()))
                    }
                    _ => (arg.as_str(), None),
                };
                if matches!(flag, "-h" | "--help") {
                    return Ok(None);
                }
                if !matches!(flag, "--particles" | "--steps" | "--out") {
                    return Err(format!("unknown argument `{arg}`"));
                }
                let value = match inline {
                    Some(value) => value,
                    None => it
                        .next()
                        .cloned()
                        .ok_or_else(|| format!("`{flag}` needs a value"))?,
                };
                match flag {
                    "--particles" => {
                        options.particles = count(flag, &value)?;
                        if options.particles < PER_CELL {
                            return Err(format!(
                                "`--particles {value}`: need at least {PER_CELL} (one cell)"
                            ));
                        }
                    }
                    "--steps" => options.steps = count(flag, &value)?,
                    _ => {
                        if value.is_empty() {
                            return Err("`--out` needs a non-empty path".to_string());
                        }
                        options.out = PathBuf::from(value);
                    }
                }
            }
            Ok(Some(options))
        }
    }

    /// A positive integer; accepts `1000000`, `1_000_000` and `1e6`.
    fn count(flag: &str, value: &str) -> Result<usize, String> {
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

    /// Strip the `::h0123456789abcdef` hash of a demangled Rust symbol.
    fn short(name: &str) -> &str {
        match name.rsplit_once("::h") {
            Some((head, hash))
                if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) =>
            {
                head
            }
            _ => name,
        }
    }

    pub fn run(options: &Options) -> Result<(), String> {
        let cells = options.particles / PER_CELL;
        let overrides = [
            format!("grid.cells={cells}"),
            format!("particles.per_cell={PER_CELL}"),
            "time.dt=1.0e-7".to_string(),
        ];
        let scenario = tlsmpm::config::from_str(SCENARIO, "vibrating_bar.toml", &overrides)
            .map_err(|e| e.to_string())?;
        let (problem, mut sim) = build_simulation(&scenario, false).map_err(|e| e.to_string())?;
        let particles = sim.particles.len();
        let threads = rayon::current_num_threads();
        println!(
            "profiling {} steps, {particles} particles on {cells} cells, {threads} rayon threads",
            options.steps
        );

        let guard = pprof::ProfilerGuardBuilder::default()
            .frequency(1000)
            .blocklist(&["libc", "libgcc", "pthread", "vdso"])
            .build()
            .map_err(|e| format!("starting the profiler: {e}"))?;
        let start = Instant::now();
        let dt = sim.stepper.dt();
        let mut crossings = 0;
        for step in 1..=options.steps {
            let time = step as f64 * dt;
            let report = sim
                .stepper
                .step(
                    &mut sim.particles,
                    problem.body_acceleration(time),
                    step,
                    time,
                )
                .map_err(|e| e.to_string())?;
            crossings += report.crossings;
        }
        let elapsed = start.elapsed().as_secs_f64();
        let report = guard
            .report()
            .build()
            .map_err(|e| format!("building the profile report: {e}"))?;
        println!(
            "{:.3} s, {:.3} ms/step, {:.3e} particle-steps/s, {crossings} grid crossings",
            elapsed,
            1e3 * elapsed / options.steps as f64,
            (particles * options.steps) as f64 / elapsed
        );

        if let Some(dir) = options.out.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
        }
        let file = std::fs::File::create(&options.out)
            .map_err(|e| format!("creating {}: {e}", options.out.display()))?;
        report
            .flamegraph(std::io::BufWriter::new(file))
            .map_err(|e| format!("writing {}: {e}", options.out.display()))?;
        println!("wrote {}", options.out.display());

        // Self samples per leaf frame (innermost inlined function), and inclusive samples
        // per tlsmpm function (counted once per stack).
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
        Ok(())
    }
}
