//! End-to-end tests: real PNG and SVG files written into a temporary directory.

use std::path::{Path, PathBuf};

use decoy_plots::{Aspect, Plot, PlotError, Series, write_plot, write_stacked};

/// A fresh directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("decoy-plots-test-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn series(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        label: label.into(),
        x,
        y,
    }
}

fn sine_plot(title: &str, n: u32) -> Plot {
    let t: Vec<f64> = (0..n).map(|i| f64::from(i) * 0.01).collect();
    Plot {
        title: title.into(),
        x_label: "time [s]".into(),
        y_label: "tension [N]".into(),
        series: vec![
            series(
                "tow point",
                t.clone(),
                t.iter().map(|t| 1000.0 + 100.0 * t.sin()).collect(),
            ),
            series(
                "decoy",
                t.clone(),
                t.iter().map(|t| 400.0 + 50.0 * t.cos()).collect(),
            ),
        ],
        aspect: Aspect::Free,
        invert_y: false,
    }
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

fn assert_written(paths: &[PathBuf; 2], stem: &Path) {
    assert_eq!(paths[0], stem.with_extension("png"));
    assert_eq!(paths[1], stem.with_extension("svg"));
    for p in paths {
        let len = std::fs::metadata(p).unwrap().len();
        assert!(len > 1000, "{} has only {len} bytes", p.display());
    }
}

#[test]
fn writes_png_and_svg_with_title() {
    let dir = TempDir::new("basic");
    let stem = dir.path("tension");
    let paths = write_plot(&sine_plot("Cable tension during a turn", 2000), &stem).unwrap();
    assert_written(&paths, &stem);
    assert_eq!(png_size(&paths[0]), (1200, 800));
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains("Cable tension during a turn"));
    // Axis descriptions and legend labels are text too.
    for text in ["time [s]", "tension [N]", "tow point", "decoy"] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
}

#[test]
fn title_is_escaped_in_svg() {
    let dir = TempDir::new("escape");
    let paths = write_plot(&sine_plot("T & <D>", 10), &dir.path("escaped")).unwrap();
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(svg.contains("T &amp; &lt;D&gt;"));
}

#[test]
fn nan_only_plot_is_empty() {
    let dir = TempDir::new("empty");
    let plot = Plot {
        title: "all NaN".into(),
        series: vec![
            series("a", vec![f64::NAN; 5], vec![1.0; 5]),
            series("b", vec![1.0, 2.0], vec![f64::INFINITY, f64::NEG_INFINITY]),
            series("c", vec![], vec![]),
        ],
        ..Plot::default()
    };
    let stem = dir.path("nan");
    match write_plot(&plot, &stem) {
        Err(PlotError::Empty { title }) => assert_eq!(title, "all NaN"),
        other => panic!("expected Empty, got {other:?}"),
    }
    assert!(!stem.with_extension("png").exists() && !stem.with_extension("svg").exists());

    let no_series = Plot {
        title: "nothing".into(),
        ..Plot::default()
    };
    assert!(matches!(
        write_plot(&no_series, &stem),
        Err(PlotError::Empty { title }) if title == "nothing"
    ));
    assert!(matches!(
        write_stacked(&[sine_plot("fine", 10), plot], &stem),
        Err(PlotError::Empty { title }) if title == "all NaN"
    ));
    assert!(matches!(
        write_stacked(&[], &stem),
        Err(PlotError::Empty { .. })
    ));
}

#[test]
fn some_non_finite_points_are_skipped() {
    let dir = TempDir::new("gaps");
    let plot = Plot {
        title: "gaps".into(),
        series: vec![series(
            "s",
            vec![0.0, 1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0],
            vec![1.0, f64::INFINITY, 3.0, 4.0, 5.0, f64::NEG_INFINITY, 7.0],
        )],
        ..Plot::default()
    };
    let stem = dir.path("gaps");
    assert_written(&write_plot(&plot, &stem).unwrap(), &stem);
}

#[test]
fn single_point_and_constant_series_draw() {
    let dir = TempDir::new("degenerate");
    let plot = Plot {
        title: "degenerate".into(),
        series: vec![
            series("point", vec![3.0], vec![-7.5]),
            series("flat", vec![0.0, 1.0, 2.0], vec![-7.5; 3]),
        ],
        ..Plot::default()
    };
    let stem = dir.path("degenerate");
    assert_written(&write_plot(&plot, &stem).unwrap(), &stem);
    let zero = Plot {
        title: "zero".into(),
        series: vec![series("z", vec![0.0], vec![0.0])],
        aspect: Aspect::Equal,
        ..Plot::default()
    };
    assert_written(&write_plot(&zero, &stem).unwrap(), &stem);
}

#[test]
fn mismatched_lengths_are_a_draw_error() {
    let dir = TempDir::new("mismatch");
    let plot = Plot {
        title: "bad".into(),
        series: vec![series("s", vec![0.0, 1.0], vec![0.0])],
        ..Plot::default()
    };
    let err = write_plot(&plot, &dir.path("bad")).unwrap_err();
    assert!(matches!(err, PlotError::Draw(_)), "{err:?}");
    assert!(
        err.to_string().contains("2 x values but 1 y values"),
        "{err}"
    );
}

#[test]
fn equal_aspect_cable_shape_with_inverted_y() {
    let dir = TempDir::new("equal");
    let x: Vec<f64> = (0..=300).map(f64::from).collect();
    let plot = Plot {
        title: "Cable shape".into(),
        x_label: "behind tow point [m]".into(),
        y_label: "depth [m]".into(),
        series: vec![series(
            "cable",
            x.clone(),
            x.iter().map(|x| 30.0 * (x / 300.0).powi(2)).collect(),
        )],
        aspect: Aspect::Equal,
        invert_y: true,
    };
    let stem = dir.path("cable");
    let paths = write_plot(&plot, &stem).unwrap();
    assert_written(&paths, &stem);
    assert_eq!(png_size(&paths[0]), (1200, 800));
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(svg.contains("Cable shape"));
}

#[test]
fn output_is_deterministic() {
    let dir = TempDir::new("determinism");
    let mut plot = sine_plot("Determinism", 5000);
    plot.series[1].y[17] = f64::NAN;
    let a = write_plot(&plot, &dir.path("a")).unwrap();
    let b = write_plot(&plot, &dir.path("b")).unwrap();
    for (a, b) in a.iter().zip(&b) {
        let (a_bytes, b_bytes) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
        assert!(
            a_bytes == b_bytes,
            "{} differs from {}",
            a.display(),
            b.display()
        );
    }
    let stacked = [sine_plot("one", 100), sine_plot("two", 300)];
    let a = write_stacked(&stacked, &dir.path("sa")).unwrap();
    let b = write_stacked(&stacked, &dir.path("sb")).unwrap();
    assert_eq!(std::fs::read(&a[1]).unwrap(), std::fs::read(&b[1]).unwrap());
    assert_eq!(std::fs::read(&a[0]).unwrap(), std::fs::read(&b[0]).unwrap());
}

#[test]
fn large_series_are_decimated_but_keep_spikes() {
    let dir = TempDir::new("large");
    let n = 100_000;
    let x: Vec<f64> = (0..n).map(|i| f64::from(i) * 1e-3).collect();
    let mut y: Vec<f64> = x.iter().map(|t| (3.0 * t).sin()).collect();
    y[54_321] = 25.0; // a one-sample spike sets the y range and must be drawn
    let plot = Plot {
        title: "100k points".into(),
        series: vec![series("signal", x, y)],
        ..Plot::default()
    };
    let started = std::time::Instant::now();
    let paths = write_plot(&plot, &dir.path("large")).unwrap();
    eprintln!("100k points: {:?}", started.elapsed());
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    let drawn: usize = svg
        .split("<polyline")
        .skip(1)
        .map(|p| {
            let points = p
                .split("points=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap();
            points.split_whitespace().count()
        })
        .sum();
    assert!((100..=5000).contains(&drawn), "{drawn} points drawn");
    // The spike's top is at the top of the data: some drawn vertex is near the top of the
    // plotting area (the highest vertex in SVG pixel coordinates).
    let top = svg
        .split("points=\"")
        .skip(1)
        .flat_map(|p| p.split('"').next().unwrap().split_whitespace())
        .filter_map(|xy| xy.split(',').nth(1)?.parse::<i32>().ok())
        .min()
        .unwrap();
    assert!(top < 120, "highest drawn vertex at y = {top} px");
}

#[test]
fn stacked_figure_with_shared_x_label() {
    let dir = TempDir::new("stacked");
    let plots = [
        sine_plot("Tension", 500),
        sine_plot("Depth", 500),
        sine_plot("Altitude", 500),
    ];
    let stem = dir.path("stacked");
    let paths = write_stacked(&plots, &stem).unwrap();
    assert_written(&paths, &stem);
    assert_eq!(png_size(&paths[0]), (1200, 960));
    let svg = std::fs::read_to_string(&paths[1]).unwrap();
    for title in ["Tension", "Depth", "Altitude"] {
        assert!(svg.contains(title), "SVG lacks {title}");
    }
    // The shared x label is drawn once, under the bottom panel.
    assert_eq!(svg.matches("time [s]").count(), 1);
    let two = write_stacked(&plots[..2], &dir.path("two")).unwrap();
    assert_eq!(png_size(&two[0]), (1200, 800));
}

#[test]
fn stem_keeps_dots_and_parent_is_created() {
    let dir = TempDir::new("stem");
    let stem = dir.path("nested/deeper/run.v2");
    let [png, svg] = write_plot(&sine_plot("stem", 10), &stem).unwrap();
    assert_eq!(png, dir.path("nested/deeper/run.v2.png"));
    assert_eq!(svg, dir.path("nested/deeper/run.v2.svg"));
    assert!(png.is_file() && svg.is_file());
}

#[test]
fn unwritable_path_is_an_io_error() {
    let dir = TempDir::new("io");
    let file = dir.path("a-file");
    std::fs::write(&file, b"not a directory").unwrap();
    let err = write_plot(&sine_plot("io", 10), &file.join("plot")).unwrap_err();
    match &err {
        PlotError::Io { path, .. } => assert_eq!(path, &file),
        other => panic!("expected Io, got {other:?}"),
    }
    assert!(err.to_string().contains("a-file"), "{err}");
}
