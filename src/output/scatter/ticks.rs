//! Axis and colour-bar ticks: round values (multiples of 1, 2, 2.5 or 5 times a power of
//! ten) and their shortest labels.

use super::{CHAR_WIDTH, LABEL_SIZE};

/// Tick positions and their labels (an empty label: tick without text).
#[derive(Clone, Debug)]
pub(super) struct Ticks {
    pub(super) values: Vec<f64>,
    pub(super) labels: Vec<String>,
    /// Distance between neighbouring ticks.
    pub(super) step: f64,
}

impl Ticks {
    /// Widest label, estimated in pixels.
    pub(super) fn label_width(&self) -> f64 {
        let chars = self
            .labels
            .iter()
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(0);
        text_width(chars, LABEL_SIZE)
    }
}

/// Estimated width in pixels of `chars` characters at font size `size`.
pub(super) fn text_width(chars: usize, size: f64) -> f64 {
    chars as f64 * CHAR_WIDTH * size
}

/// `10^k`, correctly rounded.
pub(super) fn decade(k: i32) -> f64 {
    format!("1e{k}").parse().unwrap_or_else(|_| 10f64.powi(k))
}

/// Round ticks (multiples of 1, 2, 2.5 or 5 × 10^k) over `lo..hi` (finite, `lo < hi`): the
/// widest step that gives at least `min_count` ticks, or `min_count` evenly spaced values.
pub(super) fn nice_ticks(lo: f64, hi: f64, min_count: usize) -> Ticks {
    let min_count = min_count.max(2);
    let span = hi - lo;
    let top = if span > 0.0 && span.is_finite() {
        span.log10().floor() as i32 + 1
    } else {
        0
    };
    for k in (top - 40..=top).rev() {
        for m in [5.0, 2.5, 2.0, 1.0] {
            let step = m * decade(k);
            if !(step > 0.0 && step.is_finite()) {
                continue;
            }
            let i0 = (lo / step - 1e-9).ceil();
            let i1 = (hi / step + 1e-9).floor();
            if !(i0.abs() < 1e15 && i1.abs() < 1e15) {
                continue;
            }
            let count = i1 - i0 + 1.0;
            if count >= min_count as f64 && count <= 1000.0 {
                let values: Vec<f64> = (i0 as i64..=i1 as i64)
                    .map(|i| (i as f64 * step).clamp(lo, hi))
                    .collect();
                let largest = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let scientific = !(1e-3..1e5).contains(&largest);
                let labels = values
                    .iter()
                    .map(|&v| tick_label(v, step, m == 2.5, k, scientific))
                    .collect();
                return Ticks {
                    values,
                    labels,
                    step,
                };
            }
        }
    }
    let n = min_count;
    let step = span / (n - 1) as f64;
    let values: Vec<f64> = (0..n)
        .map(|i| if i + 1 == n { hi } else { lo + i as f64 * step })
        .collect();
    let labels = values.iter().map(|&v| short_number(v)).collect();
    Ticks {
        values,
        labels,
        step,
    }
}

/// Label of a tick at `v` on an axis with ticks every `step` = m × 10^`k` (`quarter`: m = 2.5).
pub(super) fn tick_label(v: f64, step: f64, quarter: bool, k: i32, scientific: bool) -> String {
    let extra = i32::from(quarter);
    let digits = ((-k).max(0) + if k <= 0 { extra } else { 0 }).clamp(0, 15) as usize;
    if v.abs() < step * 1e-6 {
        return if scientific {
            "0".into()
        } else {
            format!("{:.digits$}", 0.0)
        };
    }
    if scientific {
        let exponent = format!("{v:e}")
            .split_once('e')
            .and_then(|(_, e)| e.parse::<i32>().ok())
            .unwrap_or(0);
        let digits = (exponent - k + extra).clamp(0, 15) as usize;
        let s = format!("{v:.digits$e}");
        return match s.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
            None => s,
        };
    }
    let s = format!("{v:.digits$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        format!("{:.digits$}", 0.0)
    } else {
        s
    }
}

/// A number in at most four significant digits (scientific outside `[1e-3, 1e5)`).
pub(super) fn short_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        return match s.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
            None => s,
        };
    }
    let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.digits$}");
    trim_zeros(&s).to_string()
}

/// `"1.500"` → `"1.5"`, `"2.000"` → `"2"`; strings without a decimal point are unchanged.
pub(super) fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Ticks of an axis over `range` drawn `length` pixels long: as many as fit (2 to 8 labelled
/// values, about one per 100 px) without overlapping labels; labels are thinned if even the
/// fewest overlap.
pub(super) fn axis_ticks((lo, hi): (f64, f64), length: f64, vertical: bool) -> Ticks {
    let fits = |t: &Ticks, stride: usize| {
        let spacing = length * t.step * stride as f64 / (hi - lo);
        let need = if vertical {
            LABEL_SIZE + 4.0
        } else {
            t.label_width() + 12.0
        };
        spacing >= need
    };
    let target = ((length / 100.0).floor() as usize).clamp(2, 8);
    for min_count in (2..=target).rev() {
        let t = nice_ticks(lo, hi, min_count);
        if fits(&t, 1) {
            return t;
        }
    }
    let mut t = nice_ticks(lo, hi, 2);
    let stride = (1..t.values.len().max(1))
        .find(|&s| fits(&t, s))
        .unwrap_or(t.values.len().max(1));
    for (i, label) in t.labels.iter_mut().enumerate() {
        if i % stride != 0 {
            label.clear();
        }
    }
    t
}
