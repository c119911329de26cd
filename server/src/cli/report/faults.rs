//! Stage 8, the fault matrix (`pivotsim_server::fault_matrix`, issue 30): every shipped scene ×
//! every fault its actuators, joints and cables accept, at t = 8 s and 14 s, 10 s past the fault —
//! as shipped, with one position projection per step, and with the loads ×10 and ×100 (full mode;
//! quick mode runs the shipped scenes, tiny mode the pendulum). One row per scene and variant:
//! how many cells stayed stable (watchdog quiet, every unbroken joint within 1 mm beyond its elastic
//! deflection), the worst joint error and drift, the largest energy excess over start + inputs, and
//! in how many cells the joint-error guard and the substeps acted. Every cell is in `report.json`.

use indicatif::ProgressBar;
use pivotsim_server::fault_matrix::{Cell, LOADS, MatrixVariant, SCENES, scene_cells};
use serde::Serialize;

use super::Plan;

/// One scene in one variant.
#[derive(Debug, Clone, Serialize)]
pub struct FaultRow {
    pub scene: String,
    pub variant: String,
    /// Cells run, and how many were stable.
    pub cells: usize,
    pub stable: usize,
    /// Worst joint error (m) and drift beyond elastic deflection (m), with the cell of the latter.
    pub worst_error_m: f64,
    pub worst_drift_m: f64,
    pub worst_drift_cell: String,
    /// Largest energy excess over start + inputs (J), and its cell.
    pub worst_excess_j: f64,
    pub worst_excess_cell: String,
    /// Cells in which the joint-error guard projected, and cells with steps re-run as substeps.
    pub guarded_cells: usize,
    pub substepped_cells: usize,
}

/// Stage 8's result.
#[derive(Debug, Clone, Serialize)]
pub struct Faults {
    pub rows: Vec<FaultRow>,
    pub cells: Vec<Cell>,
}

/// The (scene, variant) runs of a mode.
pub fn runs(mode: &str) -> Vec<(&'static str, MatrixVariant)> {
    match mode {
        "tiny" => vec![("pendulum", MatrixVariant::Shipped)],
        "quick" => SCENES.iter().map(|&s| (s, MatrixVariant::Shipped)).collect(),
        _ => {
            let mut v: Vec<_> = SCENES.iter().map(|&s| (s, MatrixVariant::Shipped)).collect();
            v.extend(SCENES.iter().map(|&s| (s, MatrixVariant::Projection(1))));
            for k in [10.0, 100.0] {
                v.extend(LOADS.iter().map(|&(s, body)| (s, MatrixVariant::Load(body, k))));
            }
            v
        }
    }
}

fn cell_name(c: &Cell) -> String {
    format!("{} `{}` at {} s", c.kind, c.target, c.at)
}

/// Runs the matrix of the plan's mode.
pub fn run(plan: &Plan, pb: &ProgressBar) -> anyhow::Result<Faults> {
    let mut out = Faults { rows: Vec::new(), cells: Vec::new() };
    for (name, variant) in runs(plan.mode) {
        pb.set_message(format!("faults: {name}, {}", variant.label()));
        let cells = scene_cells(name, variant, |c| {
            pb.set_message(format!("faults: {name}, {}, {}", c.variant, cell_name(c)))
        })
        .map_err(anyhow::Error::msg)?;
        let worst = |f: fn(&Cell) -> f64| {
            cells
                .iter()
                .max_by(|a, b| f(a).total_cmp(&f(b)))
                .map(|c| (f(c), cell_name(c)))
                .unwrap_or((0.0, String::new()))
        };
        let (worst_drift_m, worst_drift_cell) = worst(|c| c.joint_drift);
        let (worst_excess_j, worst_excess_cell) = worst(|c| c.energy_excess);
        out.rows.push(FaultRow {
            scene: name.to_string(),
            variant: variant.label(),
            cells: cells.len(),
            stable: cells.iter().filter(|c| c.stable).count(),
            worst_error_m: cells.iter().map(|c| c.joint_error).fold(0.0, f64::max),
            worst_drift_m,
            worst_drift_cell,
            worst_excess_j,
            worst_excess_cell,
            guarded_cells: cells.iter().filter(|c| c.guarded > 0).count(),
            substepped_cells: cells.iter().filter(|c| c.substepped > 0).count(),
        });
        out.cells.extend(cells);
        pb.inc(1);
    }
    Ok(out)
}
