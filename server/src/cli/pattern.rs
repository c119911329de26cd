//! `pattern`: sparsity-pattern plots (paper Fig. 5 and 6): `A` in its input order, `A` after the
//! (reverse) Cuthill–McKee reordering, and the factor `L₀` with its stored envelope (skyline).

use std::path::Path;

use anyhow::anyhow;
use plotters::prelude::*;

use pivotsim_server::solver::envelope::Envelope;
use pivotsim_server::solver::ordering::{self, OrderingWorkspace};
use pivotsim_server::solver::{OrderingKind, SymCsr, io};

/// What a pattern plot shows, in numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PatternInfo {
    /// Matrix size.
    pub m: usize,
    /// Stored non-zeros of `A` (both triangles).
    pub nnz: usize,
    /// Bandwidth of `A` in input order.
    pub bandwidth_before: usize,
    /// Bandwidth after reordering.
    pub bandwidth_after: usize,
    /// Envelope below the diagonal in input order.
    pub envelope_before: usize,
    /// Envelope below the diagonal after reordering.
    pub envelope_after: usize,
    /// Stored entries of the envelope factor (diagonal included).
    pub factor_entries: usize,
    /// Non-zeros of `L₀` (diagonal included): the fill the envelope has to hold.
    pub factor_nonzeros: usize,
}

/// Writes a three-panel SVG: `A` (input order), `P A Pᵀ` and `L₀` on its envelope.
pub fn sparsity_svg(path: &Path, a: &SymCsr, kind: OrderingKind) -> anyhow::Result<PatternInfo> {
    let m = a.n();
    let mut ws = OrderingWorkspace::new();
    let (mut perm, mut inv) = (Vec::new(), Vec::new());
    ws.order(a, kind, &mut perm, &mut inv);
    let mut ap = SymCsr::default();
    ap.permuted_from(a, &perm, &inv);
    let mut env = Envelope::new();
    env.build(&ap);
    let mut l = vec![0.0; env.len()];
    env.factor_from(&ap, &vec![false; m], &mut l, 0, ap.max_diag());
    let factor_nonzeros = l.iter().filter(|x| **x != 0.0).count();
    let info = PatternInfo {
        m,
        nnz: a.nnz(),
        bandwidth_before: ordering::bandwidth(a),
        bandwidth_after: ordering::bandwidth(&ap),
        envelope_before: ordering::envelope(a),
        envelope_after: ordering::envelope(&ap),
        factor_entries: env.len(),
        factor_nonzeros,
    };

    let root = SVGBackend::new(path, (1500, 540)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let panels = root.split_evenly((1, 3));
    let title_a =
        format!("A, input order (bandwidth {}, envelope {})", info.bandwidth_before, info.envelope_before);
    let title_p = format!(
        "A after {} (bandwidth {}, envelope {})",
        kind.name().to_uppercase(),
        info.bandwidth_after,
        info.envelope_after
    );
    let title_l =
        format!("L0 on its envelope ({} stored, {} non-zero)", info.factor_entries, info.factor_nonzeros);
    draw_matrix(&panels[0], &title_a, m, |draw| {
        for i in 0..m {
            for &j in a.row(i).0 {
                draw(i, j, &BLUE)?;
            }
        }
        Ok(())
    })?;
    draw_matrix(&panels[1], &title_p, m, |draw| {
        for i in 0..m {
            for &j in ap.row(i).0 {
                draw(i, j, &BLUE)?;
            }
        }
        Ok(())
    })?;
    let sky = env.skyline().to_vec();
    draw_matrix(&panels[2], &title_l, m, |draw| {
        let shade = RGBColor(220, 220, 220);
        for (j, &s) in sky.iter().enumerate() {
            for p in j..=s {
                let v = env.get(&l, p, j);
                draw(p, j, if v != 0.0 { &RED } else { &shade })?;
            }
        }
        Ok(())
    })?;
    root.present().map_err(plot_err)?;
    Ok(info)
}

type DrawCell<'a> = dyn FnMut(usize, usize, &RGBColor) -> anyhow::Result<()> + 'a;

/// Cells per side of a panel at most: a larger matrix is drawn in blocks of `⌈m / CELLS⌉²` entries
/// (a block shows the strongest colour of its entries), which keeps an SVG of a 400-row island
/// under a few hundred kB instead of megabytes.
const CELLS: usize = 100;

fn draw_matrix(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    title: &str,
    m: usize,
    body: impl FnOnce(&mut DrawCell<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let n = m.max(1) as f64;
    let block = m.div_ceil(CELLS).max(1);
    let g = m.div_ceil(block).max(1);
    // The strongest colour seen per block, by rank: 0 none, then shade < blue < red.
    let mut grid: Vec<(u8, RGBColor)> = vec![(0, WHITE); g * g];
    let rank = |c: &RGBColor| {
        if *c == RED {
            3
        } else if *c == BLUE {
            2
        } else {
            1
        }
    };
    let mut mark = |i: usize, j: usize, color: &RGBColor| -> anyhow::Result<()> {
        let cell = &mut grid[(i / block) * g + j / block];
        let r = rank(color);
        if r > cell.0 {
            *cell = (r, *color);
        }
        Ok(())
    };
    body(&mut mark)?;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(25)
        .y_label_area_size(35)
        .build_cartesian_2d(0.0..n, n..0.0)
        .map_err(plot_err)?;
    chart.configure_mesh().disable_mesh().draw().map_err(plot_err)?;
    let b = block as f64;
    chart
        .draw_series(grid.iter().enumerate().filter(|(_, c)| c.0 > 0).map(|(k, c)| {
            let (y, x) = ((k / g) as f64 * b, (k % g) as f64 * b);
            Rectangle::new([(x, y), ((x + b).min(n), (y + b).min(n))], c.1.filled())
        }))
        .map_err(plot_err)?;
    Ok(())
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plot: {e}")
}

/// Runs `pattern`: plots `file`'s matrix into `out` and prints the numbers.
pub fn pattern(file: &Path, out: &Path, ordering: OrderingKind) -> anyhow::Result<()> {
    let p = io::read_mlcp_file(file)?;
    let info = sparsity_svg(out, p.a(), ordering)?;
    println!(
        "{}: m={} nnz={} bandwidth {}→{} envelope {}→{} factor {} stored / {} non-zero → {}",
        file.display(),
        info.m,
        info.nnz,
        info.bandwidth_before,
        info.bandwidth_after,
        info.envelope_before,
        info.envelope_after,
        info.factor_entries,
        info.factor_nonzeros,
        out.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_plot_of_a_shuffled_path() {
        // A path graph 0-1-…-29 in scrambled order: RCM must bring the bandwidth back to 1.
        let n = 30;
        let order: Vec<usize> = (0..n).map(|i| (i * 7) % n).collect();
        let mut t = Vec::new();
        for i in 0..n {
            t.push((order[i], order[i], 4.0));
            if i + 1 < n {
                t.push((order[i], order[i + 1], -1.0));
                t.push((order[i + 1], order[i], -1.0));
            }
        }
        let a = SymCsr::from_triplets(n, &t).unwrap();
        let path = std::env::temp_dir().join(format!("pivotsim-pattern-{}.svg", std::process::id()));
        let info = sparsity_svg(&path, &a, OrderingKind::ReverseCuthillMcKee).unwrap();
        assert_eq!(info.bandwidth_after, 1);
        assert!(info.bandwidth_before > 1);
        assert_eq!(info.factor_entries, 2 * n - 1);
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("RCM"));
        std::fs::remove_file(&path).ok();
    }
}
