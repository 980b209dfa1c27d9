//! Result files (DESIGN §4): `summary.json`, `particles.csv`, `history.csv`,
//! `snapshot_NNNN.csv`, `study.csv` and SVG plots, each written atomically.

pub mod atomic;
pub mod csv;
pub mod plot;
pub mod summary;

pub use atomic::write_atomic;
pub use summary::Summary;
