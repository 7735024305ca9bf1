//! The report's plot: image error against GPU time, one line per scene through its presets
//! (cheapest first), each point labelled with its preset. Drawn by plotters into an RGB buffer
//! and written as PNG with the `image` crate; text uses the Ubuntu font egui embeds, so no
//! system fonts are needed.

use std::path::Path;
use std::sync::Once;

use anyhow::{Result, anyhow};
use plotters::prelude::*;

/// One scene's points: (preset name, GPU ms, error).
pub struct Line<'a> {
    pub scene: &'a str,
    pub points: Vec<(&'a str, f64, f64)>,
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is egui's own and known good; a failure would only lose the labels.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

pub fn draw(path: &Path, title: &str, y_label: &str, lines: &[Line]) -> Result<()> {
    register_font();
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let all = || lines.iter().flat_map(|l| l.points.iter()).filter(|p| p.1.is_finite() && p.2.is_finite());
    let x_max = all().map(|p| p.1).fold(0.0f64, f64::max).max(1e-3) * 1.15;
    let y_max = all().map(|p| p.2).fold(0.0f64, f64::max).max(1e-3) * 1.15;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| anyhow!("drawing the plot: {e}");
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..x_max, 0.0..y_max)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("GPU time per frame, ms (median)")
            .y_desc(y_label)
            .axis_desc_style(("sans-serif", 16))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        for (i, line) in lines.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let pts: Vec<(f64, f64)> =
                line.points.iter().filter(|p| p.1.is_finite() && p.2.is_finite()).map(|p| (p.1, p.2)).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(err)?
                .label(line.scene)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3)));
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, colour.filled()))).map_err(err)?;
            chart
                .draw_series(
                    line.points
                        .iter()
                        .filter(|p| p.1.is_finite() && p.2.is_finite())
                        .map(|p| Text::new(p.0.to_string(), (p.1, p.2), ("sans-serif", 12).into_font().color(&colour))),
                )
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(penumbra_engine::output::save_image(path, &buf, (w, h), image::ExtendedColorType::Rgb8)?)
}
