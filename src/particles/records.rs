//! Particles packed as flat `f64` records, to move them between the ranks of a
//! distributed run (`docs/distributed.md`).
//!
//! A record is `[id, cell, x0.., x.., u.., v.., stress(6), F(D x D), V, V0, m]`: every
//! field of [`TensorParticles`] in its storage order. Ids and cells travel as `f64`, exact
//! below `2^53`.

use super::TensorParticles;
use crate::error::{Error, Result};

/// Largest id or cell index a record carries exactly.
const EXACT_INTEGER: usize = 1 << 53;

impl<const D: usize> TensorParticles<D> {
    /// Values per record: `2 + 4 D + 6 + D^2 + 3`.
    ///
    /// ```
    /// use tlsmpm::particles::TensorParticles;
    /// assert_eq!(TensorParticles::<2>::record_len(), 23);
    /// assert_eq!(TensorParticles::<3>::record_len(), 32);
    /// ```
    pub const fn record_len() -> usize {
        2 + 4 * D + 6 + D * D + 3
    }

    /// Every particle as a record, in order (the particles stay).
    pub fn records(&self) -> Vec<f64> {
        let fields = self.fields();
        let mut out = Vec::with_capacity(self.len() * Self::record_len());
        for k in 0..self.len() {
            out.extend_from_slice(&[self.id[k] as f64, self.cell[k] as f64]);
            out.extend(fields.iter().map(|f| f[k]));
        }
        out
    }

    /// Move every particle `k` with `destination(k) = Some(d)` into `outboxes[d]` as a
    /// record; the others stay, in their order.
    pub fn take_records(
        &mut self,
        destination: impl Fn(usize) -> Option<usize>,
        outboxes: &mut [Vec<f64>],
    ) {
        let n = self.len();
        let leaving: Vec<(usize, usize)> = (0..n)
            .filter_map(|k| destination(k).map(|d| (k, d)))
            .collect();
        if leaving.is_empty() {
            return;
        }
        let headers: Vec<[f64; 2]> = leaving
            .iter()
            .map(|&(k, _)| [self.id[k] as f64, self.cell[k] as f64])
            .collect();
        let fields = self.fields_mut();
        for (&(k, d), header) in leaving.iter().zip(&headers) {
            let out = &mut outboxes[d];
            out.extend_from_slice(header);
            out.extend(fields.iter().map(|f| f[k]));
        }
        let mut keep = vec![true; n];
        for &(k, _) in &leaving {
            keep[k] = false;
        }
        self.retain_flagged(&keep);
    }

    /// Append the particles of `records` (whole records, as [`Self::take_records`]
    /// writes them).
    pub fn append_records(&mut self, records: &[f64]) -> Result<()> {
        let len = Self::record_len();
        if !records.len().is_multiple_of(len) {
            return Err(Error::invalid(
                "particle records",
                records.len(),
                format!("not a multiple of the record length {len}"),
            ));
        }
        for record in records.chunks_exact(len) {
            let (id, cell) = (record[0], record[1]);
            for value in [id, cell] {
                if !(value >= 0.0 && value < EXACT_INTEGER as f64 && value.fract() == 0.0) {
                    return Err(Error::invalid(
                        "particle records",
                        value,
                        "not an id or cell",
                    ));
                }
            }
            self.id.push(id as usize);
            self.cell.push(cell as usize);
            for (field, &value) in self.fields_mut().into_iter().zip(&record[2..]) {
                field.push(value);
            }
        }
        Ok(())
    }

    /// Keep particle `k` where `keep[k]`, in order.
    fn retain_flagged(&mut self, keep: &[bool]) {
        let mut flags = keep.iter();
        self.id.retain(|_| *flags.next().unwrap_or(&true));
        let mut flags = keep.iter();
        self.cell.retain(|_| *flags.next().unwrap_or(&true));
        for field in self.fields_mut() {
            let mut flags = keep.iter();
            field.retain(|_| *flags.next().unwrap_or(&true));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_move_every_field_and_keep_the_rest_in_order() {
        let x0 = [vec![0.1, 0.6, 0.2, 0.9], vec![0.5, 0.1, 0.8, 0.3]];
        let mut p = TensorParticles::<2>::at_rest(x0, vec![1.0, 2.0, 3.0, 4.0], 2.0, |x| {
            usize::from(x[0] > 0.5)
        });
        p.stress[2] = vec![5.0, 6.0, 7.0, 8.0];
        p.deformation_gradient[0][1] = vec![0.1, 0.2, 0.3, 0.4];
        let original = p.clone();
        let mut boxes = vec![Vec::new(), Vec::new()];
        p.take_records(|k| (k % 2 == 1).then_some(k / 2), &mut boxes);
        assert_eq!(p.id, vec![0, 2]);
        assert_eq!(p.mass, vec![2.0, 6.0]);
        assert_eq!(boxes[0].len(), TensorParticles::<2>::record_len());
        assert_eq!(boxes[1].len(), TensorParticles::<2>::record_len());
        let whole = original.records();
        assert_eq!(whole.len(), 4 * TensorParticles::<2>::record_len());
        assert_eq!(
            &whole[TensorParticles::<2>::record_len()..][..boxes[0].len()],
            &boxes[0][..]
        );
        p.append_records(&boxes[1]).unwrap();
        p.append_records(&boxes[0]).unwrap();
        assert_eq!(p.id, vec![0, 2, 3, 1]);
        let order = [0, 2, 3, 1];
        assert_eq!(p.cell, order.map(|k| original.cell[k]).to_vec());
        assert_eq!(p.stress[2], order.map(|k| original.stress[2][k]).to_vec());
        assert_eq!(
            p.deformation_gradient[0][1],
            order
                .map(|k| original.deformation_gradient[0][1][k])
                .to_vec()
        );
        assert_eq!(p.x[1], order.map(|k| original.x[1][k]).to_vec());
        assert_eq!(p.volume0, order.map(|k| original.volume0[k]).to_vec());
        // A torn record or a non-integer id is refused.
        assert!(p.append_records(&boxes[0][1..]).is_err());
        let mut bad = boxes[0].clone();
        bad[0] = 1.5;
        assert!(p.append_records(&bad).is_err());
    }
}
