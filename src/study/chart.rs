//! Pictures of the study: error against time per scene (log–log, PNG and SVG) and side-by-side
//! crops of each scene's hardest region, like the paper's Figures 4–8.

use super::report::{budgets_in_order, distinct, metric_title, spread};
use super::{Results, Showcase};
use crate::error::{Error, Result};
use crate::film::{srgb8, write_png_rgb8};
use crate::metrics::{Metric, ldr};
use crate::output::write_atomic;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// The charts' font, committed with its licence (`assets/fonts/`): PNG text needs glyphs, and
/// the machine's fonts are not part of the build.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");

const CHART_SIZE: (u32, u32) = (720, 480);

/// Make the committed font the one plotters draws "sans-serif" with; call before drawing PNGs.
pub fn register_font() -> Result<()> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| Error::new("the committed chart font cannot be read"))
}

fn draw_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> Error {
    Error::new(format!("cannot draw chart: {e}"))
}

/// One line per method: mean `metric` over seeds against the budget, whiskers from the
/// smallest to the largest seed.
fn draw_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    res: &Results,
    scene: &str,
    metric: Metric,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let rows: Vec<_> = res.records.iter().filter(|r| r.scene == scene).collect();
    let methods = distinct(rows.iter().map(|r| r.method.clone()));
    let budgets = budgets_in_order(rows.iter().copied());
    let values: Vec<f64> = rows
        .iter()
        .map(|r| r.scores.get(metric))
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() {
        (lo / 1.5, hi * 1.5)
    } else {
        (1e-3, 1.0)
    };
    let (b0, b1) = budgets
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    let (b0, b1) = (b0 / 1.3, b1 * 1.3);
    let title = format!("{scene}: {} against time", metric_title(metric));
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((b0..b1).log_scale(), (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("time budget (s)")
        .y_desc(metric.name())
        .draw()?;
    for (i, m) in methods.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64, f64, f64)> = budgets
            .iter()
            .filter_map(|&b| {
                spread(&res.records, scene, m, b, metric)
                    .filter(|s| s.min > 0.0)
                    .map(|s| (b, s.min, s.mean, s.max))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.2)),
                color.stroke_width(2),
            ))?
            .label(m.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart.draw_series(
            pts.iter()
                .map(|p| ErrorBar::new_vertical(p.0, p.1, p.2, p.3, color.filled(), 6)),
        )?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()
}

/// `<dir>/<scene>-<metric>.png` and `.svg` for every scene of the study.
pub fn write_charts(res: &Results, dir: &Path, metric: Metric) -> Result<Vec<String>> {
    let mut written = Vec::new();
    for scene in distinct(res.records.iter().map(|r| r.scene.as_str())) {
        let stem = format!("{scene}-{}", metric.name());
        let (w, h) = CHART_SIZE;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            draw_chart(&root, res, scene, metric).map_err(draw_err)?;
        }
        write_png_rgb8(
            &dir.join(format!("{stem}.png")),
            w as usize,
            h as usize,
            buf,
        )?;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
            draw_chart(&root, res, scene, metric).map_err(draw_err)?;
        }
        let svg_path = dir.join(format!("{stem}.svg"));
        write_atomic(&svg_path, |tmp| {
            std::fs::write(tmp, &svg).map_err(|e| Error::in_file(&svg_path, e.to_string()))
        })?;
        written.push(stem);
    }
    Ok(written)
}

/// The top-left corner of the `win`×`win` window where `image` is furthest from `reference`
/// (squared LDR error): where the method fails, the crops look.
pub fn hardest_window(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    width: usize,
    height: usize,
    win: usize,
) -> (usize, usize) {
    // Summed-area table of the per-pixel error.
    let mut sat = vec![0.0f64; (width + 1) * (height + 1)];
    for y in 0..height {
        let mut row = 0.0;
        for x in 0..width {
            let i = y * width + x;
            row += (0..3)
                .map(|c| (ldr(image[i][c]) - ldr(reference[i][c])).powi(2))
                .sum::<f64>();
            sat[(y + 1) * (width + 1) + x + 1] = sat[y * (width + 1) + x + 1] + row;
        }
    }
    let at = |x: usize, y: usize| sat[y * (width + 1) + x];
    let mut best = (0, 0, f64::NEG_INFINITY);
    for y in 0..=height.saturating_sub(win) {
        for x in 0..=width.saturating_sub(win) {
            let s = at(x + win, y + win) - at(x, y + win) - at(x + win, y) + at(x, y);
            if s > best.2 {
                best = (x, y, s);
            }
        }
    }
    (best.0, best.1)
}

/// A strip of crops: the reference, then every method's image at the largest budget, each the
/// same window around the paper OMC method's worst region, scaled up by whole pixels and labelled.
/// Returns the window (x, y, size).
pub fn write_crops(show: &Showcase, omc: &str, path: &Path) -> Result<(usize, usize, usize)> {
    let (w, h) = (show.width, show.height);
    let win = (w.min(h) / 4).max(8);
    let probe = show
        .images
        .iter()
        .find(|(m, _)| m == omc)
        .or(show.images.first())
        .ok_or_else(|| Error::in_file(path, "no images to crop"))?;
    let (x0, y0) = hardest_window(&probe.1, &show.reference, w, h, win);
    let scale = (192 / win).max(1);
    let panel = win * scale;
    let (gap, label_h) = (6usize, 22usize);
    let panels: Vec<(&str, &[[f32; 3]])> =
        std::iter::once(("reference", show.reference.as_slice()))
            .chain(
                show.images
                    .iter()
                    .map(|(m, img)| (m.as_str(), img.as_slice())),
            )
            .collect();
    let out_w = panels.len() * panel + (panels.len() + 1) * gap;
    let out_h = panel + label_h + 2 * gap;
    let mut buf = vec![255u8; out_w * out_h * 3];
    for (k, (_, img)) in panels.iter().enumerate() {
        let left = gap + k * (panel + gap);
        for py in 0..panel {
            for px in 0..panel {
                let src = img[(y0 + py / scale) * w + x0 + px / scale];
                let o = ((label_h + gap + py) * out_w + left + px) * 3;
                buf[o..o + 3].copy_from_slice(&src.map(srgb8));
            }
        }
    }
    {
        let root =
            BitMapBackend::with_buffer(&mut buf, (out_w as u32, out_h as u32)).into_drawing_area();
        for (k, (name, _)) in panels.iter().enumerate() {
            let left = (gap + k * (panel + gap)) as i32;
            root.draw(&Text::new(
                name.to_string(),
                (left, 3),
                ("sans-serif", 16).into_font().color(&BLACK),
            ))
            .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    write_png_rgb8(path, out_w, out_h, buf)?;
    Ok((x0, y0, win))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardest_window_finds_the_wrong_block() {
        let (w, h) = (32, 24);
        let reference = vec![[0.2f32; 3]; w * h];
        let mut image = reference.clone();
        for y in 10..14 {
            for x in 20..24 {
                image[y * w + x] = [0.9; 3];
            }
        }
        assert_eq!(hardest_window(&image, &reference, w, h, 4), (20, 10));
    }
}
