//! The colour scale of the scatter plots: matplotlib's viridis map, linearly interpolated
//! between ten anchors, over the range of the drawn values.

use super::TINY;

/// An sRGB colour.
pub(crate) type Rgb = (u8, u8, u8);

/// Anchor colours of matplotlib's viridis at `i / 9`, `i = 0..=9`.
pub(super) const VIRIDIS: [Rgb; 10] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x28, 0x78),
    (0x3e, 0x49, 0x89),
    (0x31, 0x68, 0x8e),
    (0x26, 0x82, 0x8e),
    (0x1f, 0x9e, 0x89),
    (0x35, 0xb7, 0x79),
    (0x6e, 0xce, 0x58),
    (0xb5, 0xde, 0x2b),
    (0xfd, 0xe7, 0x25),
];

/// A linear colour scale over `lo..hi` through viridis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ColourScale {
    /// Value drawn in the first viridis colour.
    pub(crate) lo: f64,
    /// Value drawn in the last viridis colour.
    pub(crate) hi: f64,
    /// The drawn values were all equal (or there were none) and the scale was widened.
    pub(crate) widened: bool,
}

impl ColourScale {
    /// Scale over `min..max` of the finite values; equal ends are widened symmetrically
    /// (by 5 % of the magnitude, or ±1 about zero), `min > max` (no values) gives `0..1`;
    /// `None` if `max - min` is not representable.
    pub(crate) fn new(min: f64, max: f64) -> Option<Self> {
        if min.is_nan() || max.is_nan() || min > max {
            return Some(ColourScale {
                lo: 0.0,
                hi: 1.0,
                widened: true,
            });
        }
        let magnitude = min.abs().max(max.abs());
        let (lo, hi, widened) = if magnitude < TINY || max - min <= magnitude * 1e-9 {
            let centre = 0.5 * min + 0.5 * max;
            let half = if magnitude < TINY {
                1.0
            } else {
                0.05 * magnitude
            };
            (centre - half, centre + half, true)
        } else {
            (min, max, false)
        };
        let ok = lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && lo < hi;
        ok.then_some(ColourScale { lo, hi, widened })
    }

    /// Position of `v` on the scale, clamped to `0..=1` (0 for NaN).
    pub(crate) fn fraction(&self, v: f64) -> f64 {
        let t = (0.5 * v - 0.5 * self.lo) / (0.5 * self.hi - 0.5 * self.lo);
        if t.is_nan() {
            0.0
        } else {
            t.clamp(0.0, 1.0)
        }
    }

    /// Colour of the value `v`.
    pub(crate) fn colour(&self, v: f64) -> Rgb {
        viridis(self.fraction(v))
    }
}

/// The viridis colour at `t` in `0..=1` (clamped; NaN gives the first colour), linearly
/// interpolated between the anchors of [`VIRIDIS`].
pub(crate) fn viridis(t: f64) -> Rgb {
    let [r, g, b] = viridis_exact(t).map(|c| c.round().clamp(0.0, 255.0) as u8);
    (r, g, b)
}

/// The viridis colour at `t` before rounding to 8 bits (channels in `0.0..=255.0`).
pub(super) fn viridis_exact(t: f64) -> [f64; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = VIRIDIS.len() - 1;
    let s = t * last as f64;
    let i = (s.floor() as usize).min(last - 1);
    let f = s - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |a: u8, b: u8| f64::from(a) + f * (f64::from(b) - f64::from(a));
    [mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2)]
}

/// `#RRGGBB`.
pub(super) fn hex((r, g, b): Rgb) -> String {
    format!("#{r:02X}{g:02X}{b:02X}")
}
