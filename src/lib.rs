//! # tlsmpm
//!
//! Material point methods — standard MPM, dual-domain MPM and B-spline MPM in 1D, and a
//! dimension-generic 2D / 3D core, also over MPI ranks — with conservative
//! Taylor-least-squares (TLS) reconstruction and fast consistent-mass solves. The method
//! pages are in the repository's `docs/` (`docs/capabilities.md` lists everything); the
//! command line, scenario keys and output files are in `docs/cli.md` and `docs/outputs.md`.
//!
//! Layers, each calling only downwards:
//!
//! | module | what |
//! |---|---|
//! | [`numerics`] | deterministic reductions, error norms |
//! | [`linalg`] | sparse matrices, the [`linalg::LinearSolver`] trait, CG |
//! | [`grid`] | the background grid, the [`grid::Basis`] trait and its bases |
//! | [`particles`] | the SoA particle store and per-cell bins |
//! | [`mapping`] | particle → grid transfers behind [`mapping::Mapping`] |
//! | [`physics`] | constitutive laws, boundary conditions, the MUSL/USL step, time loop, the distributed step |
//! | [`problems`] | benchmarks with exact solutions |
//! | [`output`] | CSV, JSON and SVG writers |
//! | [`app`] | scenario → simulation dispatch, runs, studies |

pub mod app;
pub mod config;
pub mod error;
pub mod grid;
pub mod linalg;
pub mod mapping;
pub mod numerics;
pub mod output;
pub mod particles;
pub mod physics;
pub mod problems;

pub use error::{Error, Result};
