//! The SVG plots: speed-up of deletions over refactoring (paper Fig. 4) and solve time per variant.

use std::path::Path;

use pivotsim_server::solver::Variant;

use super::kernels::Fig4;
use super::problems::ProblemResult;

pub fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

pub fn plot_fig4(path: &Path, fig: &Fig4) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let xmax = fig.sizes.iter().copied().max().unwrap_or(1) as f64 * 1.05;
    let ymax =
        fig.sweeps.iter().flatten().map(|p| p.speedup).filter(|x| x.is_finite()).fold(1.0f64, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("Speed-up of copy + deletions over refactor of A_FF (cf. paper Fig. 4)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, 0.0..ymax)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("size m of A")
        .y_desc("speed-up (refactor / downdate)")
        .draw()
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new([(0.0, 1.0), (xmax, 1.0)], BLACK.mix(0.5).stroke_width(1)))
        .map_err(plot_err)?;
    for (k, &pct) in fig.tight_pct.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let pts: Vec<(f64, f64)> = fig
            .sizes
            .iter()
            .zip(&fig.sweeps)
            .filter_map(|(&m, sw)| sw.get(k).map(|p| (m as f64, p.speedup)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(plot_err)?
            .label(format!("{pct}% tight"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        chart
            .draw_series(PointSeries::of_element(pts, 4, color.filled(), &|c, s, st| Circle::new(c, s, st)))
            .map_err(plot_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    root.present().map_err(plot_err)?;
    Ok(())
}

pub fn plot_solve_times(path: &Path, problems: &[&ProblemResult]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (1100, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let times: Vec<f64> = problems
        .iter()
        .flat_map(|p| p.variants.iter().map(|v| v.short.time_us * 1e-3))
        .filter(|x| *x > 0.0)
        .collect();
    let ymin = times.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) / 2.0;
    let ymax = times.iter().copied().fold(0.0, f64::max).max(ymin * 10.0) * 30.0;
    let n = problems.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption("Solve time per variant (35-step cap, median)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n, (ymin..ymax).log_scale())
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc("time per solve, ms (log)")
        .draw()
        .map_err(plot_err)?;
    let nv = Variant::ALL.len() as f64;
    for (k, v) in Variant::ALL.into_iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let bars: Vec<Rectangle<(f64, f64)>> = problems
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let t = p.variant(v)?.short.time_us * 1e-3;
                let x0 = i as f64 + 0.1 + 0.8 * k as f64 / nv;
                Some(Rectangle::new([(x0, ymin), (x0 + 0.8 / nv, t.max(ymin))], color.filled()))
            })
            .collect();
        chart
            .draw_series(bars)
            .map_err(plot_err)?
            .label(v.name())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    for (i, p) in problems.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, ymin));
        let style = ("sans-serif", 13).into_font().into_text_style(&root).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Center,
                plotters::style::text_anchor::VPos::Top,
            ),
        );
        root.draw(&Text::new(p.name.clone(), (px, py + 8), style.clone())).map_err(plot_err)?;
        root.draw(&Text::new(format!("m = {}", p.m), (px, py + 24), style)).map_err(plot_err)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}
