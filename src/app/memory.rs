//! The memory a run will need, estimated from its particle count before anything is
//! allocated, against the memory the machine has free: a run that cannot fit is refused
//! with the estimate (exit code 2) instead of aborting on a failed allocation.
//!
//! The estimate is `bytes_per_particle(D) * n_particles`, with the peak resident sizes
//! measured on 1e6-particle runs (`docs/outputs.md`), rounded up: the particle arrays, the
//! bins and the sorting buffers, the grid and the reconstruction's cell fits, and the
//! output rows.

use crate::config::Scenario;
use crate::error::{Error, Result};

/// Peak bytes per particle of a run in `dim` dimensions: the peak resident size of
/// 1e6-particle runs divided by the particle count, the largest over lumped MPM and
/// TLS with the consistent mass, plus about a quarter (measured: 1D 367, 2D 763 / 928,
/// 3D 1080 / 1625 bytes).
pub fn bytes_per_particle(dim: usize) -> u64 {
    match dim {
        1 => 500,
        2 => 1200,
        _ => 2000,
    }
}

/// Memory available to this process in bytes: `TLSMPM_AVAILABLE_MEMORY` if set (a batch
/// job's own limit), else `MemAvailable` of `/proc/meminfo`, lowered to the cgroup limit
/// when one is set; `None` where neither is known.
pub fn available_memory() -> Option<u64> {
    if let Ok(text) = std::env::var("TLSMPM_AVAILABLE_MEMORY") {
        return text.trim().parse().ok();
    }
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let available_kib: u64 = meminfo
        .lines()
        .find_map(|line| line.strip_prefix("MemAvailable:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let mut available = available_kib.saturating_mul(1024);
    let cgroup = |name: &str| -> Option<u64> {
        std::fs::read_to_string(format!("/sys/fs/cgroup/{name}"))
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    if let (Some(limit), Some(used)) = (cgroup("memory.max"), cgroup("memory.current")) {
        available = available.min(limit.saturating_sub(used));
    }
    Some(available)
}

/// `Err` naming the particle keys when the estimate exceeds `available` bytes.
///
/// ```
/// use tlsmpm::app::memory::check_fits;
/// assert!(check_fits(1_000_000, 1, Some(64 << 30)).is_ok());
/// let err = check_fits(190_000_000, 2, Some(24 << 30)).unwrap_err();
/// assert_eq!(err.exit_code(), 2);
/// assert!(err.to_string().contains("GiB"));
/// ```
pub fn check_fits(particles: usize, dim: usize, available: Option<u64>) -> Result<()> {
    let Some(available) = available else {
        return Ok(());
    };
    let needed = (particles as u64).saturating_mul(bytes_per_particle(dim));
    if needed <= available {
        return Ok(());
    }
    let gib = |bytes: u64| bytes as f64 / f64::from(1 << 30);
    Err(Error::invalid(
        "grid.cells x particles.per_cell",
        particles,
        format!(
            "{particles} particles need about {:.1} GiB of memory in {dim}D, but only {:.1} GiB \
             is available; use fewer cells or particles per cell (grid.cells, \
             particles.per_cell)",
            gib(needed),
            gib(available)
        ),
    ))
}

/// [`check_fits`] for a validated scenario on this machine.
pub fn check_scenario_fits(scenario: &Scenario) -> Result<()> {
    match scenario.particle_count() {
        Some(n) => check_fits(n, scenario.problem.dim, available_memory()),
        None => Ok(()),
    }
}
