//! The VTU frames of a 2D / 3D run: `particles_NNNN.vtu` and `particles.pvd` in one
//! process; in a distributed run every rank writes its own particles as the piece
//! `particles_NNNN_RRRR.vtu` (`RRRR` the rank) into rank 0's output directory, rank 0
//! writes `particles_NNNN.pvtu` naming the pieces, and `particles.pvd` lists the `.pvtu`
//! files, so ParaView opens each time as one data set (`docs/distributed.md`). The ranks
//! must share a file system, as MPI codes' parallel output does.

use crate::error::{Error, Result};
use crate::output::pvtu::write_pvtu;
use crate::output::vtu::{write_pvd, write_vtu, PointArray};
use crate::particles::tensor::stress_index;
use crate::particles::TensorParticles;
use crate::physics::distributed::RankExchange;
use std::path::{Path, PathBuf};

/// The point-data arrays of a particle frame and their components in `D` dimensions, in
/// file order.
fn arrays<const D: usize>() -> [(&'static str, usize); 6] {
    [
        ("displacement", D),
        ("velocity", D),
        ("stress", 6),
        ("volume", 1),
        ("density", 1),
        ("mass", 1),
    ]
}

/// Write the particles `p` as one `.vtu` (points, and the arrays of [`arrays`]).
pub(crate) fn write_vtu_of<const D: usize>(path: &Path, p: &TensorParticles<D>) -> Result<()> {
    let coordinates: Vec<&[f64]> = p.x.iter().map(|c| c.as_slice()).collect();
    fn vector<const D: usize>(field: &[Vec<f64>; D]) -> Vec<&[f64]> {
        field.iter().map(|c| c.as_slice()).collect()
    }
    // Stress in ParaView's symmetric-tensor order: XX, YY, ZZ, XY, YZ, XZ.
    let stress: Vec<&[f64]> = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)]
        .iter()
        .map(|&(a, b)| p.stress[stress_index(a, b)].as_slice())
        .collect();
    let density = p.densities();
    let [displacement, velocity, stress_name, volume, density_name, mass] = arrays::<D>();
    let arrays = [
        PointArray::new(displacement.0, vector(&p.u)),
        PointArray::new(velocity.0, vector(&p.v)),
        PointArray::new(stress_name.0, stress),
        PointArray::new(volume.0, vec![&p.volume]),
        PointArray::new(density_name.0, vec![&density]),
        PointArray::new(mass.0, vec![&p.mass]),
    ];
    write_vtu(path, &coordinates, &arrays)
}

/// The frames written so far and where they go.
pub(crate) struct VtkFrames<'a> {
    /// The output directory (rank 0's, on every rank of a distributed run).
    dir: PathBuf,
    /// The ranks of a distributed run.
    exchange: Option<&'a dyn RankExchange>,
    /// `(time, file)` of every frame, for the `.pvd`.
    series: Vec<(f64, String)>,
}

impl<'a> VtkFrames<'a> {
    /// Frames into `out`; in a distributed run (`exchange`) every rank learns rank 0's
    /// `out` (collective: every rank calls this).
    pub(crate) fn new(out: &Path, exchange: Option<&'a dyn RankExchange>) -> Result<Self> {
        let dir = match exchange {
            None => out.to_path_buf(),
            Some(exchange) => {
                let mut mine: Vec<f64> = match exchange.rank() {
                    0 => out
                        .to_str()
                        .ok_or_else(|| {
                            Error::invalid(
                                "--out",
                                out.display(),
                                "a distributed run needs a UTF-8 output path",
                            )
                        })?
                        .bytes()
                        .map(f64::from)
                        .collect(),
                    _ => Vec::new(),
                };
                // Every rank sends as many values (the exchange may need equal lengths):
                // the length first, then the bytes, zeros but on rank 0.
                let length = exchange.sum_over_ranks(&[mine.len() as f64])?;
                let length = length.first().copied().unwrap_or(0.0) as usize;
                mine.resize(length, 0.0);
                let bytes: Vec<u8> = exchange
                    .sum_over_ranks(&mine)?
                    .iter()
                    .map(|&b| b as u8)
                    .collect();
                PathBuf::from(String::from_utf8(bytes).map_err(|_| Error::Distributed {
                    reason: "rank 0 sent an output path that is not UTF-8".into(),
                })?)
            }
        };
        Ok(Self {
            dir,
            exchange,
            series: Vec::new(),
        })
    }

    /// The time of the last frame.
    pub(crate) fn last_time(&self) -> Option<f64> {
        self.series.last().map(|(t, _)| *t)
    }

    /// How many frames were written.
    pub(crate) fn len(&self) -> usize {
        self.series.len()
    }

    /// Write frame `k` of the particles `p` (this rank's, in a distributed run) at `time`.
    /// Collective in a distributed run: every rank learns whether every piece was written.
    pub(crate) fn write<const D: usize>(
        &mut self,
        k: usize,
        time: f64,
        p: &TensorParticles<D>,
    ) -> Result<()> {
        let Some(exchange) = self.exchange else {
            let file = format!("particles_{k:04}.vtu");
            write_vtu_of(&self.dir.join(&file), p)?;
            self.series.push((time, file));
            return Ok(());
        };
        let (rank, ranks) = (exchange.rank(), exchange.ranks());
        let piece = |r: usize| format!("particles_{k:04}_{r:04}.vtu");
        let written = write_vtu_of(&self.dir.join(piece(rank)), p);
        let failed = exchange.sum_over_ranks(&[f64::from(u8::from(written.is_err()))])?;
        written?;
        if failed.first().copied().unwrap_or(0.0) > 0.0 {
            return Err(Error::write(
                &self.dir,
                format!("another rank could not write its piece of frame {k}"),
            ));
        }
        let file = format!("particles_{k:04}.pvtu");
        if rank == 0 {
            let pieces: Vec<String> = (0..ranks).map(piece).collect();
            write_pvtu(&self.dir.join(&file), &arrays::<D>(), &pieces)?;
        }
        self.series.push((time, file));
        Ok(())
    }

    /// Write `particles.pvd` over the frames (rank 0 alone in a distributed run).
    pub(crate) fn finish(&self) -> Result<()> {
        if self.exchange.is_none_or(|e| e.rank() == 0) {
            write_pvd(&self.dir.join("particles.pvd"), &self.series)?;
        }
        Ok(())
    }
}
