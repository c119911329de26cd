//! The report's figures (SVG, plotters): Fig. 3, 5/6 (written by stage 2), 7, the trade and the
//! extremes. Logarithmic axes plot `log₁₀` of the value and say so on the axis.

use std::path::Path;

use anyhow::Context;
use plotters::prelude::*;

use super::Report;
use super::extremes::ExtremePoint;
use super::rapier::{RapierComparison, RapierPoint};

/// A named polyline.
struct Series {
    name: String,
    points: Vec<(f64, f64)>,
}

/// Writes every figure; returns their file names (Fig. 5/6 of stage 2 included).
pub fn write_all(out: &Path, r: &Report) -> anyhow::Result<Vec<String>> {
    let mut names = Vec::new();
    // Figures drawn without `add` (their names join `names` after it).
    let mut extra: Vec<String> = Vec::new();
    let mut add =
        |name: String, title: &str, x: &str, y: &str, series: Vec<Series>, marks: Vec<(f64, f64)>| {
            lines(&out.join(&name), title, x, y, &series, &marks)
                .with_context(|| format!("figure {name}"))?;
            names.push(name);
            anyhow::Ok(())
        };
    // Fig. 3: tight rows per step, auto.
    let tight: Vec<Series> = r
        .scenes
        .iter()
        .filter_map(|s| {
            let v = s.variants.iter().find(|v| v.variant == "auto")?;
            let pts = v
                .steps
                .iter()
                .enumerate()
                .map(|(k, p)| (k as f64 + 1.0, 100.0 * p.tight as f64 / p.rows.max(1) as f64))
                .collect();
            Some(Series { name: s.scene.clone(), points: pts })
        })
        .collect();
    add(
        "fig3_tight.svg".into(),
        "Tight rows per step (cf. paper Fig. 3), auto",
        "step",
        "tight rows, % of rows",
        tight,
        vec![],
    )?;
    // Fig. 7: solve time per step per variant, one figure per scene.
    for s in &r.scenes {
        let series = s
            .variants
            .iter()
            .map(|v| Series {
                name: v.variant.clone(),
                points: v
                    .steps
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| p.solve_us > 0.0)
                    .map(|(k, p)| (k as f64 + 1.0, (p.solve_us * 1e-3).log10()))
                    .collect(),
            })
            .collect();
        add(
            format!("fig7_solve_time_{}.svg", s.scene),
            &format!("{}: solve time per step (cf. paper Fig. 7)", s.scene),
            "step",
            "log10(solve time per step, ms)",
            series,
            vec![],
        )?;
    }
    // The trade, one figure per scene.
    for i in &r.islands {
        let series = i
            .trade
            .iter()
            .map(|c| Series {
                name: c.method.clone(),
                points: c
                    .points
                    .iter()
                    .filter(|p| p.time_us > 0.0 && p.residual_rel > 0.0)
                    .map(|p| (p.time_us.log10(), p.residual_rel.log10()))
                    .collect(),
            })
            .collect();
        add(
            format!("trade_{}.svg", i.scene),
            &format!("{}: residual against time on {} islands", i.scene, i.islands),
            "log10(time per solve, µs)",
            "log10(relative residual)",
            series,
            vec![],
        )?;
    }
    // The extremes: one figure, a panel per sweep.
    let name = "extremes.svg";
    extremes_figure(&out.join(name), r).with_context(|| format!("figure {name}"))?;
    extra.push(name.to_string());
    // Fig. 4: speed-up over size, one line per tight percentage.
    for (name, title, sizes) in [
        ("fig4_dense.svg", "Fig. 4, dense SPD: deletions over refactor of A_FF", &r.fig4.dense),
        (
            "fig4_envelope.svg",
            "Fig. 4, contact-like on the envelope: deletions over envelope refactor",
            &r.fig4.envelope,
        ),
    ] {
        let series = r
            .fig4
            .tight_pct
            .iter()
            .enumerate()
            .map(|(k, t)| Series {
                name: format!("{t:.0} % tight"),
                points: sizes
                    .iter()
                    .filter_map(|s| s.points.get(k).map(|p| (s.m as f64, p.speedup)))
                    .collect(),
            })
            .collect();
        add(name.into(), title, "rows m", "speed-up (refactor time / deletion time)", series, vec![])?;
    }
    // Equal time: payload displacement, auto and PGS at auto's time.
    let h = 1.0 / 60.0;
    let series = r
        .equal_time
        .iter()
        .flat_map(|e| {
            [&e.auto, &e.pgs_equal].map(|x| Series {
                name: format!("{}: {}", e.scene, x.method),
                // log10, floored at 0.1 mm and clipped at 1 km: a diverged run stays on the chart
                // without flattening the others.
                points: x
                    .payload_series
                    .iter()
                    .enumerate()
                    .map(|(k, d)| {
                        ((k + 1) as f64 * h, if d.is_finite() { d.max(1e-4).log10().min(3.0) } else { 3.0 })
                    })
                    .collect(),
            })
        })
        .collect();
    add(
        "equal_time_payload.svg".into(),
        "Payload displacement from its start: auto and PGS at equal solve time (3: diverged)",
        "time (s)",
        "log10(displacement, m)",
        series,
        vec![],
    )?;
    if let Some(c) = &r.rapier {
        let name = "rapier_mass_ratio.svg";
        rapier_figure(&out.join(name), c).with_context(|| format!("figure {name}"))?;
        names.push(name.to_string());
    }
    names.append(&mut extra);
    for i in &r.islands {
        if let Some(f) = &i.sparsity_figure {
            names.push(f.clone());
        }
    }
    Ok(names)
}

/// The two extremes sweeps, one panel each: joint error over the swept value per method, red
/// crosses where a run was unstable.
fn extremes_figure(path: &Path, r: &Report) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1000, 1100)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let areas = root.split_evenly((2, 1));
    for (area, (title, x, pts)) in areas.iter().zip([
        (
            "winch: joint error over compliance (x: unstable)",
            "log10(compliance)",
            &r.extremes.winch_compliance,
        ),
        (
            "crane: joint error over the load's mass ratio (x: unstable)",
            "log10(mass ratio)",
            &r.extremes.crane_mass_ratio,
        ),
    ]) {
        let (series, marks) = extreme_series(pts);
        panel(area, title, 22, (x, "log10(joint error, m)"), &series, &marks, 0.0)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}

fn extreme_series(pts: &[ExtremePoint]) -> (Vec<Series>, Vec<(f64, f64)>) {
    let mut series: Vec<Series> = Vec::new();
    let mut marks = Vec::new();
    for p in pts {
        let y = p.max_joint_error_m.max(1e-16).log10();
        let pt = (p.x.log10(), if y.is_finite() { y } else { 2.0 });
        if !p.stable {
            marks.push(pt);
        }
        match series.iter_mut().find(|s| s.name == p.variant) {
            Some(s) => s.points.push(pt),
            None => series.push(Series { name: p.variant.clone(), points: vec![pt] }),
        }
    }
    (series, marks)
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plot: {e}")
}

/// A line chart of `series`, with red crosses at `marks`.
fn lines(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    marks: &[(f64, f64)],
) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    panel(&root, title, 22, (x_desc, y_desc), series, marks, 0.0)?;
    root.present().map_err(plot_err)?;
    Ok(())
}

/// A line chart of `series` with red crosses at `marks`, drawn on `area`; the x axis runs on by
/// `legend_room` of its range at the right, where the legend goes.
fn panel(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    title: &str,
    title_size: u32,
    (x_desc, y_desc): (&str, &str),
    series: &[Series],
    marks: &[(f64, f64)],
    legend_room: f64,
) -> anyhow::Result<()> {
    let all = series
        .iter()
        .flat_map(|s| s.points.iter())
        .chain(marks)
        .filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in all {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let pad = |a: f64, b: f64| if b - a > 0.0 { 0.05 * (b - a) } else { 0.5 };
    let (px, py) = (pad(x0, x1), pad(y0, y1));
    x1 += legend_room * (x1 - x0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", title_size))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0 - px)..(x1 + px), (y0 - py)..(y1 + py))
        .map_err(plot_err)?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).draw().map_err(plot_err)?;
    for (k, s) in series.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let pts: Vec<(f64, f64)> =
            s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(plot_err)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        if pts.len() <= 40 {
            chart
                .draw_series(PointSeries::of_element(pts, 3, color.filled(), &|c, s, st| {
                    Circle::new(c, s, st)
                }))
                .map_err(plot_err)?;
        }
    }
    chart.draw_series(marks.iter().map(|&p| Cross::new(p, 8, RED.stroke_width(3)))).map_err(plot_err)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// A value of a run of the rapier comparison (`None`: not plotted).
type Metric = fn(&RapierPoint) -> Option<f64>;

/// The rapier comparison in one figure: four panels over `log₁₀` of the mass ratio — joint drift
/// (the jointed rigs), penetration (the stack), `|ΔE|` at the end and time per step (every rig) —
/// one line per engine × rig, red crosses where a run broke.
fn rapier_figure(path: &Path, c: &RapierComparison) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1400, 1000)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let areas = root.split_evenly((2, 2));
    let metric: [(&str, &str, Metric); 4] = [
        ("joint drift (chain, arm)", "log10(max joint drift, m)", |p| p.max_drift_m),
        ("penetration (stack)", "log10(max penetration, m)", |p| p.max_penetration_m),
        ("energy change at the end", "log10(|ΔE| / Σ m g l)", |p| Some(p.energy_change_rel.abs())),
        ("time per step", "log10(mean step time, µs)", |p| Some(p.mean_step_us)),
    ];
    for (area, (title, y, f)) in areas.iter().zip(metric) {
        let mut series: Vec<Series> = Vec::new();
        let mut marks = Vec::new();
        for p in &c.points {
            let Some(v) = f(p) else { continue };
            let ly = v.max(1e-16).log10();
            let pt = (p.ratio.log10(), if ly.is_finite() { ly } else { 2.0 });
            if p.broken.is_some() {
                marks.push(pt);
            }
            let name = format!("{} {}", p.engine, p.rig);
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push(pt),
                None => series.push(Series { name, points: vec![pt] }),
            }
        }
        let title = format!("rapier vs pivotsim: {title} (x: broken)");
        panel(area, &title, 18, ("log10(mass ratio)", y), &series, &marks, 0.45)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}
