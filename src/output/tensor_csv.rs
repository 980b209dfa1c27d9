//! `particles.csv` of 2D / 3D runs with the stable columns of DESIGN §7:
//! `x0,y0[,z0],x,y[,z],u_x,u_y[,u_z],v_x,v_y[,v_z],stress_xx,stress_yy,stress_zz,stress_xy[,stress_xz,stress_yz],volume,density,mass`,
//! then the `_exact` columns of `u_*`, `v_*`, `stress_*` that are known. One particle per
//! line in original (id) order; numbers in Rust's shortest round-trip `{:e}` form ([`push_lower_exp`]). Rows
//! are formatted in parallel chunks and streamed in order ([`write_rows`]) through a
//! buffered writer into a temporary file that is renamed into place ([`write_atomic_with`]).

use super::atomic::write_atomic_with;
use super::exp_format::push_lower_exp;
use super::rows::{id_order, write_rows};
use crate::error::Result;
use crate::particles::tensor::{written_stress_components, STRESS_COMPONENTS};
use crate::particles::TensorParticles;
use crate::problems::Field;
use std::path::Path;

const AXES: [&str; 3] = ["x", "y", "z"];

/// Exact values of one field at every particle (storage order): components `[c][p]`
/// (`D` for `u`, `v`; six stress components in storage order for `stress`).
pub struct TensorExactColumn<'a> {
    pub field: Field,
    pub values: &'a [Vec<f64>],
}

/// The header line (without newline).
pub fn header(dim: usize, exact: &[TensorExactColumn]) -> String {
    let mut columns: Vec<String> = Vec::new();
    columns.extend(AXES[..dim].iter().map(|a| format!("{a}0")));
    columns.extend(AXES[..dim].iter().map(|a| a.to_string()));
    columns.extend(AXES[..dim].iter().map(|a| format!("u_{a}")));
    columns.extend(AXES[..dim].iter().map(|a| format!("v_{a}")));
    let stress = written_stress_components(dim);
    columns.extend(
        stress
            .iter()
            .map(|&c| format!("stress_{}", STRESS_COMPONENTS[c])),
    );
    columns.extend(["volume", "density", "mass"].map(String::from));
    for column in exact {
        match column.field {
            Field::Stress => columns.extend(
                stress
                    .iter()
                    .map(|&c| format!("stress_{}_exact", STRESS_COMPONENTS[c])),
            ),
            field => columns.extend(
                AXES[..dim]
                    .iter()
                    .map(|a| format!("{}_{a}_exact", field.column())),
            ),
        }
    }
    columns.join(",")
}

/// Write `particles.csv` (or a snapshot) of `particles`.
pub fn write_tensor_particles<const D: usize>(
    path: &Path,
    particles: &TensorParticles<D>,
    exact: &[TensorExactColumn],
) -> Result<()> {
    let p = particles;
    let order = id_order(&p.id);
    let stress = written_stress_components(D);
    write_atomic_with(path, |writer| {
        writer.write_all(header(D, exact).as_bytes())?;
        writer.write_all(b"\n")?;
        write_rows(writer, &order, |k, out| {
            let mut first = true;
            let mut put = |out: &mut Vec<u8>, value: f64| {
                if !first {
                    out.push(b',');
                }
                first = false;
                push_lower_exp(out, value);
            };
            for field in [&p.x0, &p.x, &p.u, &p.v] {
                for component in field {
                    put(out, component[k]);
                }
            }
            for &c in stress {
                put(out, p.stress[c][k]);
            }
            put(out, p.volume[k]);
            put(out, p.density(k));
            put(out, p.mass[k]);
            for column in exact {
                match column.field {
                    Field::Stress => {
                        for &c in stress {
                            put(out, column.values[c][k]);
                        }
                    }
                    _ => {
                        for component in &column.values[..D] {
                            put(out, component[k]);
                        }
                    }
                }
            }
            out.push(b'\n');
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_follow_the_stable_names() {
        assert_eq!(
            header(2, &[]),
            "x0,y0,x,y,u_x,u_y,v_x,v_y,stress_xx,stress_yy,stress_zz,stress_xy,volume,density,mass"
        );
        let values = vec![Vec::new(); 6];
        let exact = [
            TensorExactColumn {
                field: Field::Displacement,
                values: &values,
            },
            TensorExactColumn {
                field: Field::Stress,
                values: &values,
            },
        ];
        let h = header(3, &exact);
        assert!(h.starts_with("x0,y0,z0,x,y,z,u_x,u_y,u_z,v_x,v_y,v_z,stress_xx,stress_yy,stress_zz,stress_xy,stress_xz,stress_yz,volume,density,mass,u_x_exact,u_y_exact,u_z_exact,stress_xx_exact"), "{h}");
        assert!(h.ends_with("stress_yz_exact"));
    }

    #[test]
    fn rows_come_back_in_id_order_with_every_bit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("particles.csv");
        let x0 = [vec![0.25, 0.75], vec![0.1, 1.0 / 3.0]];
        let mut p = TensorParticles::<2>::at_rest(x0, vec![0.5, 0.5], 2.0, |_| 0);
        p.id = vec![1, 0];
        p.stress[3][0] = -1e-300;
        write_tensor_particles(&path, &p, &[]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let rows: Vec<&str> = text.lines().collect();
        assert_eq!(rows.len(), 3);
        let second: Vec<f64> = rows[2].split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(second.len(), 15);
        assert_eq!(second[0], 0.25);
        assert_eq!(second[1], 0.1);
        assert_eq!(second[11], -1e-300);
        let first: Vec<f64> = rows[1].split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(first[1].to_bits(), (1.0f64 / 3.0).to_bits());
        assert!(!dir.path().join("particles.csv.tmp").exists());
    }
}
