//! A problem judged against the ULFEM reference instead of its exact solution
//! (`problem.reference = "ulfem"`, SPEC §6.3).
//!
//! [`UlfemReference`] wraps a [`Problem`]: set-up, boundary and body force are the wrapped
//! problem's; the "exact" fields are those of an [`Ulfem`] solution with
//! `problem.reference_dofs` nodes, advanced lazily to the time asked for (times must not
//! decrease, as in a run) and read at the particles' material positions `X_p`. The
//! reference velocity is time-stepped like the particle velocities, so it is compared at
//! the same time `t` (not `t - dt/2`).

use super::ulfem::{Ulfem, UlfemSetup};
use super::{Field, PlotAxis, Problem};
use crate::error::Result;
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::{Boundary, Material};
use std::sync::Mutex;

/// A problem with the ULFEM reference as its exact solution.
pub struct UlfemReference {
    inner: Box<dyn Problem>,
    reference: Mutex<Ulfem>,
}

impl UlfemReference {
    /// Wrap `inner` with a reference of `nodes` nodes for `material` and time step `dt`.
    pub fn new(
        inner: Box<dyn Problem>,
        nodes: usize,
        density: f64,
        material: Material,
        dt: f64,
    ) -> Result<Self> {
        let setup = UlfemSetup {
            length: inner.length(),
            nodes,
            density,
            material,
            boundary: inner.boundary(),
            dt,
        };
        let reference = Ulfem::new(setup, &|x| inner.initial_velocity(x))?;
        Ok(Self {
            inner,
            reference: Mutex::new(reference),
        })
    }

    /// The reference advanced to `t` (`None` if it failed, e.g. became non-finite).
    fn advanced(&self, t: f64) -> Option<std::sync::MutexGuard<'_, Ulfem>> {
        let mut reference = self.reference.lock().ok()?;
        reference
            .advance_to(t, &|time| self.inner.body_acceleration(time))
            .ok()?;
        Some(reference)
    }
}

impl Problem for UlfemReference {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn length(&self) -> f64 {
        self.inner.length()
    }
    fn initial_particles(&self, grid: &Grid, per_cell: usize, density: f64) -> Particles {
        self.inner.initial_particles(grid, per_cell, density)
    }
    fn initial_velocity(&self, x0: f64) -> f64 {
        self.inner.initial_velocity(x0)
    }
    fn boundary(&self) -> Boundary {
        self.inner.boundary()
    }
    fn body_acceleration(&self, t: f64) -> f64 {
        self.inner.body_acceleration(t)
    }
    fn exact_fields(&self) -> &'static [Field] {
        &Field::ALL
    }
    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64> {
        self.advanced(t).map(|r| r.value(field, x0))
    }
    fn exact_profile(&self, field: Field, x0: &[f64], t: f64) -> Vec<f64> {
        match self.advanced(t) {
            Some(r) => r.values(field, x0),
            None => vec![f64::NAN; x0.len()],
        }
    }
    fn velocity_is_time_stepped(&self) -> bool {
        true
    }
    fn solution_peak_times(&self, _end: f64) -> Vec<f64> {
        // The reference is stepped to the output time only.
        Vec::new()
    }
    fn reference_label(&self) -> &'static str {
        "ULFEM"
    }
    fn plot_axis(&self) -> PlotAxis {
        self.inner.plot_axis()
    }
}
