//! The published 2D solver tables of SPEC §5.1 (unit square, unit density, boundary DOFs
//! eliminated), for printing next to ours.

/// `(order p, 1/h, condition number)`.
pub const CONDITION_NUMBERS: [(usize, usize, f64); 20] = [
    (1, 8, 7.38),
    (1, 16, 8.55),
    (1, 32, 8.89),
    (1, 64, 8.97),
    (2, 8, 52.1),
    (2, 16, 55.1),
    (2, 32, 56.0),
    (2, 64, 56.2),
    (3, 8, 440.0),
    (3, 16, 424.0),
    (3, 32, 420.0),
    (3, 64, 422.0),
    (4, 8, 3.77e3),
    (4, 16, 3.36e3),
    (4, 32, 3.29e3),
    (4, 64, 3.30e3),
    (5, 8, 3.30e4),
    (5, 16, 2.61e4),
    (5, 32, 2.52e4),
    (5, 64, 2.52e4),
];

/// `(order p, 1/h, CG iterations to 1e-8)`.
pub const CG_ITERATIONS: [(usize, usize, usize); 20] = [
    (1, 16, 18),
    (1, 32, 18),
    (1, 64, 18),
    (1, 128, 17),
    (2, 16, 34),
    (2, 32, 46),
    (2, 64, 46),
    (2, 128, 44),
    (3, 16, 68),
    (3, 32, 93),
    (3, 64, 95),
    (3, 128, 91),
    (4, 16, 93),
    (4, 32, 178),
    (4, 64, 196),
    (4, 128, 187),
    (5, 16, 156),
    (5, 32, 242),
    (5, 64, 252),
    (5, 128, 227),
];

/// `(order p, 1/h, p-multigrid V(8,8)-cycles to 1e-8)`.
pub const VCYCLES: [(usize, usize, usize); 20] = [
    (1, 8, 1),
    (1, 16, 1),
    (1, 32, 1),
    (1, 64, 1),
    (2, 8, 4),
    (2, 16, 4),
    (2, 32, 4),
    (2, 64, 3),
    (3, 8, 15),
    (3, 16, 12),
    (3, 32, 10),
    (3, 64, 9),
    (4, 8, 22),
    (4, 16, 17),
    (4, 32, 13),
    (4, 64, 11),
    (5, 8, 58),
    (5, 16, 38),
    (5, 32, 27),
    (5, 64, 20),
];

/// The published condition number at `(order, cells)`, if any.
pub fn condition_number(order: usize, cells: usize) -> Option<f64> {
    CONDITION_NUMBERS
        .iter()
        .find(|&&(p, n, _)| p == order && n == cells)
        .map(|&(_, _, k)| k)
}

/// The published iteration count of `solver` (`cg` or `pmg`) at `(order, cells)`, if any.
pub fn iterations(solver: &str, order: usize, cells: usize) -> Option<usize> {
    let table: &[(usize, usize, usize)] = match solver {
        "cg" => &CG_ITERATIONS,
        "pmg" => &VCYCLES,
        _ => return None,
    };
    table
        .iter()
        .find(|&&(p, n, _)| p == order && n == cells)
        .map(|&(_, _, k)| k)
}
