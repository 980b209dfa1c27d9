//! Tests of the scatter plots.

use super::*;

fn axes() -> ScatterAxes<'static> {
    ScatterAxes {
        title: "Stress at t = 0.5 s",
        x_label: "x [m]",
        y_label: "y [m]",
        colour_label: "σxx [Pa]",
    }
}

/// Deterministic uniform numbers in `[0, 1)` (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The `<rect` elements of the marks group.
fn marks(svg: &str) -> usize {
    let start = svg.find(r#"<g id="marks""#).expect("marks group");
    let end = start + svg[start..].find("</g>").expect("end of marks");
    svg[start..end].matches("<rect").count()
}

fn assert_valid(svg: &str, what: &str) {
    assert!(svg.starts_with("<svg"), "{what}");
    assert!(svg.trim_end().ends_with("</svg>"), "{what}");
    assert!(!svg.contains("NaN") && !svg.contains("inf"), "{what}");
}

fn no_tmp_left(dir: &Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file left: {name}");
    }
}

#[test]
fn hundred_particles_one_mark_each() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scatter.svg");
    let (mut x, mut y, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..10 {
        for j in 0..10 {
            x.push(0.1 * f64::from(i) + 0.05);
            y.push(0.05 * f64::from(j) + 0.025);
            v.push(f64::from(i * j));
        }
    }
    scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert_valid(&svg, "100");
    assert_eq!(marks(&svg), 100);
    assert!(svg.matches("<rect").count() <= 100 + 4);
    for text in [
        "Stress at t = 0.5 s",
        "x [m]",
        "y [m]",
        "σxx [Pa]",
        "100 particles",
    ] {
        assert!(svg.contains(text), "{text}");
    }
    // Extreme colours present: v = 0 and v = 81 are the ends of the scale.
    assert!(svg.contains(&hex(VIRIDIS[0])));
    assert!(svg.contains(&hex(VIRIDIS[9])));
    assert!(!svg.contains("binned"));
    no_tmp_left(dir.path());
}

#[test]
fn million_particles_are_binned_into_a_small_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("million.svg");
    let n = 1_000_000;
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let x: Vec<f64> = (0..n).map(|_| 2.0 * rng.next()).collect();
    let y: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let v: Vec<f64> = x.iter().zip(&y).map(|(x, y)| (3.0 * x).sin() * y).collect();
    scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    let size = svg.len();
    eprintln!("1e6 particles: {size} bytes, {} marks", marks(&svg));
    assert_valid(&svg, "1e6");
    assert!(size < 1_000_000, "{size} bytes");
    let m = marks(&svg);
    assert!(m <= MAX_MARKS, "{m} marks");
    assert!(m >= MAX_MARKS / 2, "{m} marks");
    assert!(svg.contains("1000000 particles binned to a "), "caption");
    assert!(svg.contains("mean per bin"));
    no_tmp_left(dir.path());
}

#[test]
fn viridis_is_monotone_with_the_right_ends() {
    assert_eq!(viridis(0.0), (68, 1, 84));
    assert_eq!(viridis(1.0), (253, 231, 37));
    assert_eq!(viridis(-3.0), viridis(0.0));
    assert_eq!(viridis(7.0), viridis(1.0));
    assert_eq!(viridis(f64::NAN), viridis(0.0));
    // The sum r + g + b strictly increases from the low to the high end; after
    // rounding to 8 bits it may dip by a rounding step at most.
    let exact_sum = |t: f64| viridis_exact(t).iter().sum::<f64>();
    let sum = |c: Rgb| u32::from(c.0) + u32::from(c.1) + u32::from(c.2);
    for i in 1..=1000 {
        let (t0, t1) = (f64::from(i - 1) / 1000.0, f64::from(i) / 1000.0);
        assert!(exact_sum(t1) > exact_sum(t0), "{t1}");
        assert!(sum(viridis(t1)) + 2 >= sum(viridis(t0)), "{t1}");
    }
    for i in 1..=20 {
        let (t0, t1) = (f64::from(i - 1) / 20.0, f64::from(i) / 20.0);
        assert!(sum(viridis(t1)) > sum(viridis(t0)), "{t1}");
    }
    // Strictly increasing between the anchors.
    for i in 1..VIRIDIS.len() {
        assert!(sum(VIRIDIS[i]) > sum(VIRIDIS[i - 1]));
    }
    let scale = ColourScale::new(-2.0, 6.0).unwrap();
    assert_eq!(scale.colour(-2.0), VIRIDIS[0]);
    assert_eq!(scale.colour(6.0), VIRIDIS[9]);
    assert_eq!(scale.colour(2.0), viridis(0.5));
    assert_eq!(scale.colour(100.0), VIRIDIS[9]);
}

#[test]
fn binned_mean_is_exact_for_a_tiny_case() {
    // Two particles in cell (0, 0) with values 1 and 3, one in cell (1, 1) with 5.
    let x = [0.1, 0.2, 0.9, f64::NAN];
    let y = [0.1, 0.3, 0.8, 0.5];
    let v = [1.0, 3.0, 5.0, 100.0];
    let raster = bin_mean(&x, &y, &v, (0.0, 1.0), (0.0, 1.0), 2, 2);
    assert_eq!(raster.count, vec![2, 0, 0, 1]);
    assert_eq!(raster.cell_mean(0, 0), Some(2.0));
    assert_eq!(raster.cell_mean(1, 0), None);
    assert_eq!(raster.cell_mean(0, 1), None);
    assert_eq!(raster.cell_mean(1, 1), Some(5.0));
    assert_eq!(raster.cell_mean(2, 0), None);
    let scale = ColourScale::new(1.0, 3.0).unwrap();
    assert_eq!(scale.colour(2.0), viridis(0.5));
    // Huge values do not overflow the mean.
    let raster = bin_mean(
        &[0.0, 0.0],
        &[0.0, 0.0],
        &[f64::MAX, f64::MAX],
        (0.0, 0.0),
        (0.0, 0.0),
        1,
        1,
    );
    assert_eq!(raster.cell_mean(0, 0), Some(f64::MAX));
}

#[test]
fn binned_plot_colours_cells_by_their_mean() {
    // MAX_MARKS + 2 particles: most with value 0 at a corner, two with 1 and 3 in the
    // opposite corner, one with 4 in the middle (the scale is 0..4, mean 2 → centre).
    let mut x = vec![0.0; MAX_MARKS - 1];
    let mut y = vec![0.0; MAX_MARKS - 1];
    let mut v = vec![0.0; MAX_MARKS - 1];
    x.extend([1.0, 1.0, 0.5]);
    y.extend([1.0, 1.0, 0.5]);
    v.extend([1.0, 3.0, 4.0]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("binned.svg");
    scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert_valid(&svg, "binned");
    assert_eq!(marks(&svg), 3);
    let colour = hex(ColourScale::new(0.0, 4.0).unwrap().colour(2.0));
    assert_eq!(colour, hex(viridis(0.5)));
    assert!(svg.contains(&format!(r#"fill="{colour}""#)), "{colour}");
    assert!(svg.contains(&format!("{} particles binned to a ", MAX_MARKS + 2)));
}

#[test]
fn raster_matches_the_aspect_and_stays_within_the_limit() {
    for (w, h) in [
        (600.0, 300.0),
        (300.0, 600.0),
        (500.0, 500.0),
        (600.0, 90.0),
        (3.0, 500.0),
    ] {
        let (nx, ny) = raster_shape(w, h, MAX_MARKS, MIN_CELL_PX);
        assert!(nx * ny <= MAX_MARKS, "{w} {h}: {nx} {ny}");
        let (cw, ch) = (w / nx as f64, h / ny as f64);
        assert!(cw >= MIN_CELL_PX - 1e-9 || nx == 1, "{w} {h}");
        assert!((cw / ch - 1.0).abs() < 0.3 || nx == 1, "{w} {h}: {cw} {ch}");
    }
    assert_eq!(raster_shape(600.0, 300.0, MAX_MARKS, MIN_CELL_PX), (91, 45));
    assert_eq!(raster_shape(500.0, 500.0, MAX_MARKS, MIN_CELL_PX), (64, 64));
    assert_eq!(raster_shape(0.0, 0.0, MAX_MARKS, MIN_CELL_PX), (1, 1));
    assert_eq!(raster_shape(600.0, 0.0, MAX_MARKS, MIN_CELL_PX), (300, 1));
    assert_eq!(raster_shape(0.0, 50.0, MAX_MARKS, MIN_CELL_PX), (1, 25));
    assert_eq!(
        raster_shape(f64::NAN, 50.0, MAX_MARKS, MIN_CELL_PX),
        (1, 25)
    );
}

#[test]
fn axes_have_equal_scale() {
    let ((x0, x1), (y0, y1)) = axis_ranges(Some(((0.0, 2.0), (0.0, 1.0)))).unwrap();
    assert!(x0 < 0.0 && x1 > 2.0 && y0 < 0.0 && y1 > 1.0);
    // Equal padding on all sides.
    assert!(((x1 - 2.0) - (y1 - 1.0)).abs() < 1e-12);
    let (pw, ph) = plot_size(x1 - x0, y1 - y0);
    assert!((pw / ph - (x1 - x0) / (y1 - y0)).abs() < 1e-12);
    assert!(pw <= MAX_PLOT_W + 1e-9 && ph <= MAX_PLOT_H + 1e-9);
    // A thin strip keeps a readable height.
    let (_, (y0, y1)) = axis_ranges(Some(((0.0, 1.0), (0.0, 1e-4)))).unwrap();
    assert!(y1 - y0 >= MIN_EXTENT);
    // Identical points, zero, huge.
    assert!(axis_ranges(Some(((3.0, 3.0), (3.0, 3.0)))).is_some());
    assert!(axis_ranges(Some(((0.0, 0.0), (0.0, 0.0)))).is_some());
    assert!(axis_ranges(Some(((-1e308, 1e308), (0.0, 0.0)))).is_none());
}

#[test]
fn colour_bar_has_at_least_five_distinct_ticks() {
    for (lo, hi) in [
        (0.0, 1.0),
        (0.13, 0.87),
        (-3.3e6, 1.2e5),
        (1e-7, 3e-7),
        (999.999, 1000.001),
        (-1.0, -0.9999999),
        (5.0, 5.0),
        (0.0, 0.0),
        (1e-300, 2e-300),
    ] {
        let scale = ColourScale::new(lo, hi).unwrap();
        let ticks = nice_ticks(scale.lo, scale.hi, BAR_TICKS);
        assert!(ticks.values.len() >= BAR_TICKS, "{lo} {hi}: {ticks:?}");
        let mut labels = ticks.labels.clone();
        labels.dedup();
        assert_eq!(labels.len(), ticks.labels.len(), "{lo} {hi}: {ticks:?}");
        for v in &ticks.values {
            assert!((scale.lo..=scale.hi).contains(v), "{lo} {hi}: {ticks:?}");
        }
    }
    let t = nice_ticks(0.0, 1.0, 5);
    assert_eq!(t.labels, ["0.00", "0.25", "0.50", "0.75", "1.00"]);
    let t = nice_ticks(0.0, 1.0, 6);
    assert_eq!(t.labels, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
    let t = nice_ticks(0.0, 1e6, 5);
    assert_eq!(t.labels, ["0", "2.5e5", "5e5", "7.5e5", "1e6"]);
    let t = nice_ticks(0.0, 10.0, 3);
    assert_eq!(t.labels, ["0", "5", "10"]);
    let t = nice_ticks(-0.5, 0.5, 4);
    assert_eq!(t.labels, ["-0.50", "-0.25", "0.00", "0.25", "0.50"]);
    assert!(ColourScale::new(-1e308, 1e308).is_none());
}

#[test]
fn degenerate_inputs_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let nan = vec![f64::NAN; 5];
    let same = vec![2.0; 5];
    let ramp: Vec<f64> = (0..5).map(f64::from).collect();
    let mixed = vec![1.0, f64::INFINITY, f64::NAN, -2.0, 0.5];
    let huge = vec![-1e308, 1e308, 0.0, 1.0, 2.0];
    let tiny = vec![1e-320, 2e-320, 0.0, 3e-320, 0.0];
    let long_line: Vec<f64> = (0..5000).map(|i| f64::from(i) * 1e-3).collect();
    let long_same = vec![7.0; 5000];
    let empty: Vec<f64> = Vec::new();
    type Case<'a> = (&'a str, &'a [f64], &'a [f64], &'a [f64]);
    let cases: Vec<Case> = vec![
        ("empty", &empty, &empty, &empty),
        ("all nan values", &ramp, &ramp, &nan),
        ("all nan positions", &nan, &nan, &ramp),
        ("identical points", &same, &same, &ramp),
        ("identical points and values", &same, &same, &same),
        ("single point", &ramp[..1], &ramp[..1], &ramp[..1]),
        ("vertical line", &same, &ramp, &ramp),
        ("some non-finite", &ramp, &ramp, &mixed),
        ("huge values", &ramp, &ramp, &huge),
        ("huge positions", &huge, &ramp, &ramp),
        ("subnormal", &tiny, &tiny, &tiny),
        ("binned horizontal line", &long_line, &long_same, &long_line),
        ("binned identical", &long_same, &long_same, &long_line),
        ("binned constant", &long_line, &long_line, &long_same),
    ];
    let blank = ScatterAxes {
        title: "",
        x_label: "",
        y_label: "",
        colour_label: "",
    };
    let weird = ScatterAxes {
        title: "a <b> & \"c\"\nd",
        x_label: "x\u{7}",
        y_label: "",
        colour_label: "'v'",
    };
    let all_axes = [axes(), blank, weird];
    for (i, (name, x, y, v)) in cases.iter().enumerate() {
        for (j, labels) in all_axes.iter().enumerate() {
            let path = dir.path().join(format!("case{i}_{j}.svg"));
            match scatter_plot(&path, labels, x, y, v) {
                Ok(()) => {
                    let svg = std::fs::read_to_string(&path).unwrap();
                    assert_valid(&svg, name);
                    assert!(marks(&svg) <= MAX_MARKS, "{name}");
                }
                Err(Error::WriteOutput { path: p, reason }) => {
                    assert_eq!(p, path, "{name}");
                    assert!(name.starts_with("huge"), "{name}: {reason}");
                }
                Err(e) => panic!("{name}: unexpected error {e}"),
            }
        }
    }
    let svg = std::fs::read_to_string(dir.path().join("case7_0.svg")).unwrap();
    assert!(svg.contains("3 particles; 2 skipped (non-finite)"), "{svg}");
    let svg = std::fs::read_to_string(dir.path().join("case2_0.svg")).unwrap();
    assert!(svg.contains("no particles to draw; 5 skipped"));
    let svg = std::fs::read_to_string(dir.path().join("case2_2.svg")).unwrap();
    assert!(svg.contains("a &lt;b&gt; &amp; &quot;c&quot; d"));
    let svg = std::fs::read_to_string(dir.path().join("case11_0.svg")).unwrap();
    assert!(svg.contains("binned to a "));
    no_tmp_left(dir.path());
}

#[test]
fn mismatched_lengths_are_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.svg");
    let err = scatter_plot(&path, &axes(), &[1.0, 2.0], &[1.0], &[1.0, 2.0]).unwrap_err();
    assert!(matches!(err, Error::InvalidValue { .. }), "{err}");
    assert!(err.to_string().contains("same length"), "{err}");
    let err = scatter_plot(&path, &axes(), &[1.0], &[1.0], &[]).unwrap_err();
    assert!(matches!(err, Error::InvalidValue { .. }), "{err}");
    assert!(!path.exists());
}

#[test]
fn unwritable_path_is_a_clean_error() {
    let path = Path::new("/nonexistent-dir/scatter.svg");
    let err = scatter_plot(path, &axes(), &[1.0], &[1.0], &[1.0]).unwrap_err();
    assert!(matches!(err, Error::WriteOutput { .. }));
    assert!(err.to_string().contains("/nonexistent-dir/scatter.svg"));
}
