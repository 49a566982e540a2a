//! A heat map of a grid of values ([`HeatMap`], [`write_heatmap`]): one cell
//! per grid point, coloured by its value on a sequential scale, labelled with
//! the value and a mark, with contours: iso-lines at given levels drawn thin,
//! and one contour at a threshold drawn thick, each on the edges between cells
//! on either side of its value.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::{FONT, PlotError, TITLE_HEIGHT, TITLE_SIZE, draw_err, ensure_fonts, save_figure};

/// A grid of values to draw: `values[row][column]`, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatMap {
    /// Title.
    pub title: String,
    /// Lines under the title (the model, the marks, the contour).
    pub subtitle: Vec<String>,
    /// The columns' axis, e.g. `Mach`.
    pub x_label: String,
    /// The rows' axis, e.g. `altitude [m]`.
    pub y_label: String,
    /// Column labels, left to right.
    pub columns: Vec<String>,
    /// Row labels, top to bottom.
    pub rows: Vec<String>,
    /// The values, a row per row label, a value per column label (NaN: none).
    pub values: Vec<Vec<f64>>,
    /// A short mark per cell printed after its value (`E`), same shape.
    pub marks: Vec<Vec<String>>,
    /// Decimals of the printed values.
    pub decimals: usize,
    /// The contour's value: the edges between a cell at or above it and one
    /// below it are drawn thick.
    pub contour: Option<f64>,
    /// Iso-lines: for each level, the edges between a cell at or above it and
    /// one below it are drawn thin (dark red).
    pub levels: Vec<f64>,
}

const WIDTH: u32 = 1200;
const ROW_PX: u32 = 70;
const LEFT: u32 = 150;
const BOTTOM: u32 = 90;
const SUBTITLE_LINE: u32 = 26;
const LABEL_SIZE: u32 = 20;
const CELL_TEXT: u32 = 20;

/// The sequential colour scale (light to dark), by linear interpolation.
const SCALE: [(u8, u8, u8); 5] = [
    (255, 255, 204),
    (161, 218, 180),
    (65, 182, 196),
    (44, 127, 184),
    (37, 52, 148),
];

fn colour(fraction: f64) -> RGBColor {
    if !fraction.is_finite() {
        return RGBColor(230, 230, 230);
    }
    let x = fraction.clamp(0.0, 1.0) * (SCALE.len() - 1) as f64;
    let i = (x.floor() as usize).min(SCALE.len() - 2);
    let t = x - i as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * t).round() as u8;
    let (a, b) = (SCALE[i], SCALE[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

impl HeatMap {
    fn check(&self) -> Result<(), PlotError> {
        let shape_ok = self.values.len() == self.rows.len()
            && self.marks.len() == self.rows.len()
            && self.values.iter().all(|r| r.len() == self.columns.len())
            && self.marks.iter().all(|r| r.len() == self.columns.len());
        if !shape_ok {
            return Err(PlotError::Draw(format!(
                "heat map {:?}: values and marks must have a row per row label and a value per column label",
                self.title
            )));
        }
        if !self.values.iter().flatten().any(|v| v.is_finite()) {
            return Err(PlotError::Empty {
                title: self.title.clone(),
            });
        }
        Ok(())
    }

    /// The values' range (finite ones).
    fn range(&self) -> (f64, f64) {
        let finite = self.values.iter().flatten().filter(|v| v.is_finite());
        let lo = finite.clone().fold(f64::INFINITY, |a, &b| a.min(b));
        let hi = finite.fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        (lo, hi)
    }
}

/// The height of the subtitle's lines, pixels.
fn subtitle_height(map: &HeatMap) -> u32 {
    SUBTITLE_LINE * u32::try_from(map.subtitle.len()).unwrap_or(0)
}

/// Writes `<stem>.png` and `<stem>.svg` of `map` (1200 pixels wide, 70 a
/// row); returns both paths.
pub fn write_heatmap(map: &HeatMap, stem: &Path) -> Result<[PathBuf; 2], PlotError> {
    ensure_fonts()?;
    map.check()?;
    let rows = u32::try_from(map.rows.len()).unwrap_or(u32::MAX).max(1);
    let size = (
        WIDTH,
        TITLE_HEIGHT + subtitle_height(map) + rows.saturating_mul(ROW_PX) + BOTTOM,
    );
    let mut pixels = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, size).into_drawing_area();
        draw(&root, map, size)?;
        root.present().map_err(draw_err)?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw(&root, map, size)?;
        root.present().map_err(draw_err)?;
    }
    save_figure(stem, &pixels, size, &svg)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &HeatMap,
    (width, _): (u32, u32),
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let centred = |size: u32| {
        TextStyle::from((FONT, size).into_font()).pos(Pos::new(HPos::Center, VPos::Center))
    };
    let px = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
    root.draw(&Text::new(
        map.title.clone(),
        (px(width / 2), px(TITLE_HEIGHT / 2)),
        centred(TITLE_SIZE),
    ))
    .map_err(draw_err)?;
    for (i, line) in map.subtitle.iter().enumerate() {
        let y = TITLE_HEIGHT + SUBTITLE_LINE * u32::try_from(i).unwrap_or(0) + SUBTITLE_LINE / 2;
        root.draw(&Text::new(
            line.clone(),
            (px(width / 2), px(y)),
            centred(18),
        ))
        .map_err(draw_err)?;
    }

    let (n_rows, n_cols) = (map.rows.len(), map.columns.len());
    let top = TITLE_HEIGHT + subtitle_height(map) + 8;
    let grid_w = width - LEFT - 30;
    let col_w = grid_w / u32::try_from(n_cols.max(1)).unwrap_or(1);
    let (lo, hi) = map.range();
    let span = if hi > lo { hi - lo } else { 1.0 };
    let cell = |r: usize, c: usize| {
        let x0 = LEFT + col_w * u32::try_from(c).unwrap_or(0);
        let y0 = top + ROW_PX * u32::try_from(r).unwrap_or(0);
        ((px(x0), px(y0)), (px(x0 + col_w), px(y0 + ROW_PX)))
    };
    for (r, row) in map.values.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            let (a, b) = cell(r, c);
            let fraction = (v - lo) / span;
            let fill = colour(fraction);
            root.draw(&Rectangle::new([a, b], fill.filled()))
                .map_err(draw_err)?;
            root.draw(&Rectangle::new(
                [a, b],
                RGBColor(255, 255, 255).stroke_width(1),
            ))
            .map_err(draw_err)?;
            let text = if v.is_finite() {
                format!("{v:.*} {}", map.decimals, map.marks[r][c])
            } else {
                "-".to_owned()
            };
            let ink = if fraction.is_finite() && fraction > 0.55 {
                WHITE
            } else {
                BLACK
            };
            root.draw(&Text::new(
                text,
                ((a.0 + b.0) / 2, (a.1 + b.1) / 2),
                centred(CELL_TEXT).color(&ink),
            ))
            .map_err(draw_err)?;
        }
    }
    // The iso-lines (thin), then the contour (thick, over them): the edges
    // between cells on either side of each level.
    let thin = RGBColor(178, 24, 43).stroke_width(2);
    let thick = BLACK.stroke_width(5);
    let lines = map
        .levels
        .iter()
        .map(|&level| (level, thin))
        .chain(map.contour.map(|level| (level, thick)));
    for (level, style) in lines {
        let above = |r: usize, c: usize| map.values[r][c] >= level;
        for r in 0..n_rows {
            for c in 0..n_cols {
                let (a, b) = cell(r, c);
                if c + 1 < n_cols && above(r, c) != above(r, c + 1) {
                    root.draw(&PathElement::new(vec![(b.0, a.1), (b.0, b.1)], style))
                        .map_err(draw_err)?;
                }
                if r + 1 < n_rows && above(r, c) != above(r + 1, c) {
                    root.draw(&PathElement::new(vec![(a.0, b.1), (b.0, b.1)], style))
                        .map_err(draw_err)?;
                }
            }
        }
    }
    // Axis labels.
    for (r, label) in map.rows.iter().enumerate() {
        let (a, b) = cell(r, 0);
        root.draw(&Text::new(
            label.clone(),
            (a.0 - 12, (a.1 + b.1) / 2),
            TextStyle::from((FONT, LABEL_SIZE).into_font())
                .pos(Pos::new(HPos::Right, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    let bottom = px(top + ROW_PX * u32::try_from(n_rows).unwrap_or(0));
    for (c, label) in map.columns.iter().enumerate() {
        let (a, b) = cell(0, c);
        root.draw(&Text::new(
            label.clone(),
            ((a.0 + b.0) / 2, bottom + 18),
            centred(LABEL_SIZE),
        ))
        .map_err(draw_err)?;
    }
    root.draw(&Text::new(
        map.x_label.clone(),
        (px(LEFT + grid_w / 2), bottom + 55),
        centred(22),
    ))
    .map_err(draw_err)?;
    root.draw(&Text::new(
        map.y_label.clone(),
        (20, (px(top) + bottom) / 2),
        TextStyle::from((FONT, 22).into_font())
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(draw_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> HeatMap {
        HeatMap {
            title: "limit".into(),
            subtitle: vec!["rad/s".into()],
            x_label: "Mach".into(),
            y_label: "altitude [m]".into(),
            columns: vec!["0.6".into(), "0.8".into()],
            rows: vec!["9000".into(), "3000".into()],
            values: vec![vec![0.096, 0.061], vec![0.112, f64::NAN]],
            marks: vec![
                vec!["E".into(), "E".into()],
                vec!["E".into(), String::new()],
            ],
            decimals: 3,
            contour: Some(0.10),
            levels: vec![0.05, 0.15],
        }
    }

    #[test]
    fn a_heat_map_is_written_and_a_bad_shape_is_an_error() {
        let dir = std::env::temp_dir().join(format!("decoy-heatmap-{}", std::process::id()));
        let [png, svg] = write_heatmap(&map(), &dir.join("limit")).unwrap();
        assert!(png.is_file() && svg.is_file());
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.contains("0.096 E") && text.contains("0.112 E"));
        let mut bad = map();
        bad.values[1].pop();
        assert!(matches!(
            write_heatmap(&bad, &dir.join("bad")),
            Err(PlotError::Draw(_))
        ));
        let mut empty = map();
        empty.values = vec![vec![f64::NAN; 2]; 2];
        assert!(matches!(
            write_heatmap(&empty, &dir.join("empty")),
            Err(PlotError::Empty { .. })
        ));
        assert!(!dir.join("bad.png").exists());
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn the_scale_runs_light_to_dark() {
        assert_eq!(colour(0.0), RGBColor(255, 255, 204));
        assert_eq!(colour(1.0), RGBColor(37, 52, 148));
        assert_eq!(colour(f64::NAN), RGBColor(230, 230, 230));
    }
}
