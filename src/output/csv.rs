//! CSV writers with the stable column names of DESIGN §4. Numbers are written in Rust's
//! shortest round-trip `{:e}` form (by [`push_lower_exp`], byte for byte), so a file read
//! back gives the same `f64` bits; particle rows are streamed in parallel chunks
//! ([`write_rows`]) through a buffered writer, never held whole in memory.

use super::atomic::write_atomic_with;
use super::exp_format::push_lower_exp;
use super::rows::{id_order, write_rows};
use super::write_atomic;
use crate::error::Result;
use crate::particles::Particles;
use crate::physics::HistoryRow;
use crate::problems::Field;
use std::fmt::Write as _;
use std::path::Path;

/// Exact values of one field at every particle (in particle storage order).
pub struct ExactColumn<'a> {
    pub field: Field,
    pub values: &'a [f64],
}

/// `particles.csv` / `snapshot_NNNN.csv`: `x0,x,u,v,stress,volume,density,mass`; for
/// two-phase particles `v` is the solid velocity, `stress` the total stress
/// `sigma' + p`, `density` and `mass` the solid ones, followed by
/// `v_w,pore_pressure,effective_stress`; then `<field>_exact` for each exact column; one
/// line per particle in original order.
pub fn write_particles(path: &Path, particles: &Particles, exact: &[ExactColumn]) -> Result<()> {
    let mut header = String::from("x0,x,u,v,stress,volume,density,mass");
    if particles.liquid.is_some() {
        header.push_str(",v_w,pore_pressure,effective_stress");
    }
    for column in exact {
        let _ = write!(header, ",{}_exact", column.field.column());
    }
    header.push('\n');
    let p = particles;
    let order = id_order(&p.id);
    write_atomic_with(path, |writer| {
        writer.write_all(header.as_bytes())?;
        write_rows(writer, &order, |k, out| {
            let pressure = p.liquid.as_ref().map_or(0.0, |l| l.pore_pressure[k]);
            let total_stress = p.stress[k] + pressure;
            let columns = [
                p.x0[k],
                p.x[k],
                p.u[k],
                p.v[k],
                total_stress,
                p.volume[k],
                p.density[k],
                p.mass[k],
            ];
            for (i, &value) in columns.iter().enumerate() {
                if i > 0 {
                    out.push(b',');
                }
                push_lower_exp(out, value);
            }
            if let Some(l) = &p.liquid {
                for value in [l.velocity[k], l.pore_pressure[k], p.stress[k]] {
                    out.push(b',');
                    push_lower_exp(out, value);
                }
            }
            for column in exact {
                out.push(b',');
                push_lower_exp(out, column.values[k]);
            }
            out.push(b'\n');
        })
    })
}

/// `history.csv`: `step,time,mass_rel_error,momentum_rel_error,kinetic_energy,
/// strain_energy,grid_crossings` (momentum error empty on steps with all particles at rest);
/// two-phase runs add `liquid_mass_rel_error,liquid_momentum_rel_error`.
pub fn write_history(path: &Path, history: &[HistoryRow]) -> Result<()> {
    let two_phase = history.iter().any(|r| r.liquid_mass_rel_error.is_some());
    let mut out = String::from(
        "step,time,mass_rel_error,momentum_rel_error,kinetic_energy,strain_energy,grid_crossings",
    );
    if two_phase {
        out.push_str(",liquid_mass_rel_error,liquid_momentum_rel_error");
    }
    out.push('\n');
    let optional = |e: Option<f64>| e.map_or(String::new(), |e| format!("{e:e}"));
    for row in history {
        let _ = write!(
            out,
            "{},{:e},{:e},{},{:e},{:e},{}",
            row.step,
            row.time,
            row.mass_rel_error,
            optional(row.momentum_rel_error),
            row.kinetic_energy,
            row.strain_energy,
            row.grid_crossings
        );
        if two_phase {
            let _ = write!(
                out,
                ",{},{}",
                optional(row.liquid_mass_rel_error),
                optional(row.liquid_momentum_rel_error)
            );
        }
        out.push('\n');
    }
    write_atomic(path, out.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    #[test]
    fn particles_round_trip_in_original_order() {
        let grid = Grid::new(1.0, 2);
        let mut p = Particles::at_subcell_centres(&grid, 2, 3.0);
        p.v = vec![0.1, -0.2, 1.0 / 3.0, 1e-300];
        // Storage order differs from the original order.
        let order = [1, 0, 3, 2];
        p.permute(&order, &mut Vec::new());
        let exact = vec![0.5; 4];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("particles.csv");
        write_particles(
            &path,
            &p,
            &[ExactColumn {
                field: Field::Stress,
                values: &exact,
            }],
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "x0,x,u,v,stress,volume,density,mass,stress_exact"
        );
        let v: Vec<f64> = lines
            .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
            .collect();
        assert_eq!(v, vec![0.1, -0.2, 1.0 / 3.0, 1e-300]);
    }
}
