//! Result files (DESIGN §4): `summary.json`, `particles.csv`, `history.csv`,
//! `snapshot_NNNN.csv`, `study.csv` and SVG plots, each written atomically.

pub mod atomic;
pub mod csv;
pub mod exp_format;
pub mod legend;
pub mod plot;
pub mod pvtu;
pub mod rows;
pub mod run_dir;
pub mod scatter;
pub mod series;
pub mod summary;
pub mod tensor_csv;
pub mod thinning;
pub mod vtu;

pub use atomic::write_atomic;
pub use summary::Summary;
