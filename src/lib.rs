//! # tlsmpm
//!
//! Material point methods in 1D — standard MPM, dual-domain MPM and B-spline MPM — with
//! conservative Taylor-least-squares (TLS) reconstruction and fast consistent-mass solves.
//! `../shared/SPEC.md` is the mathematical contract, `../shared/DESIGN.md` the shape of the
//! code and the stable interface (CLI, scenario keys, output files).
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
//! | [`physics`] | constitutive laws, boundary conditions, the MUSL/USL step, time loop |
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
