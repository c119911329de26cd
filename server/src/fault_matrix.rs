//! The fault matrix (issue 30): every shipped scene × every fault kind its actuators, joints and
//! sensors accept, injected at two moments of its scripted run — t = 8 s (the machine moving: the
//! crane's boom lifting its pipe, the forklift turning with its crate, the offshore crane's module on
//! the deck) and t = 14 s (under full load: the pipe and the module hanging, the log lifted and
//! slewed) — and run 10 s past the fault. A cell is stable when:
//!
//! - the watchdog stays quiet (`watchdog.rs`: energy never above its start plus the inputs' work by
//!   more than the scene's margin, no body above the scene's `max_speed`, no joint open by 1 cm);
//! - every joint that was not broken stays within [`JOINT_BOUND`] (1 mm) beyond its elastic
//!   deflection: a joint row of compliance `c` carrying the force `F` gives by `c F` by design
//!   (paper eq. 1; 1.5 mm for the offshore crane's 1e-10 m/N under the 15 MN of its upper works
//!   striking the deck), so a joint's drift is its error less `|c λ / h|` over its locked linear
//!   rows, and the bound is on the drift.
//!
//! The cells ([`faults_of`]): `hose_burst` and `stick_valve` on every actuator; `brake_fade` (to 0
//! at once) on every brake; `break` on the end joint of every cable (a rope parts: the hook and its
//! load fall free — their speed is bounded by the watchdog like any other body, and the parted
//! joint is no longer a joint, so its separation is not an error) and on the first joint each
//! actuator drives (a cylinder or a pin fails); `dropout` on the first sensor of each scene (the
//! world never reads a sensor, so a dropout cannot change the physics: the run must be bitwise the
//! nominal one).
//!
//! [`MatrixVariant`]s: the scenes as shipped, with `projection_iterations` set, or with their
//! load's mass and inertia scaled (same size and shape: a denser load).
//!
//! Used by `tests/fault_matrix.rs` (every cell must be stable) and by the report's `faults` stage.

use nalgebra::Vector3;
use serde::Serialize;

use crate::dynamics::{Watchdog, World, WorldSettings};
use crate::scene::{self, ActuatorKind, FaultRequest, Scene};

/// Fault moments (s).
pub const MOMENTS: [f64; 2] = [8.0, 14.0];
/// How long each run goes on after the fault (s).
pub const AFTER: f64 = 10.0;
/// Bound on an unbroken joint's drift beyond its elastic deflection (m).
pub const JOINT_BOUND: f64 = 1e-3;

/// The scenes that carry a load and the load's body. The winch has no load body: its chain is
/// what it hauls (50 links of 1 kg on its drum).
pub const LOADS: [(&str, &str); 3] = [("crane", "pipe"), ("offshore", "module"), ("forklift", "crate")];

/// The shipped scenes with actuators, cables or sensors (box_stack and hanging_chain have none).
pub const SCENES: [&str; 7] = ["pendulum", "crane", "offshore", "forklift", "forwarder", "vehicle", "winch"];

/// How a scene is run in the matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MatrixVariant {
    /// As shipped.
    Shipped,
    /// With `projection_iterations` set to this.
    Projection(usize),
    /// The load body (by name) with its mass and inertia scaled by the factor.
    Load(&'static str, f64),
}

impl MatrixVariant {
    /// A short label: `shipped`, `projection 1`, `pipe x10`.
    pub fn label(self) -> String {
        match self {
            MatrixVariant::Shipped => "shipped".into(),
            MatrixVariant::Projection(n) => format!("projection {n}"),
            MatrixVariant::Load(body, k) => format!("{body} x{k}"),
        }
    }

    /// The built-in scene `name` in this variant.
    pub fn load(self, name: &str) -> Result<Scene, String> {
        let err = |e: &dyn std::fmt::Display| format!("{name} ({}): {e}", self.label());
        match self {
            MatrixVariant::Shipped => scene::load(name).map_err(|e| err(&e)),
            MatrixVariant::Projection(n) => {
                let mut s = scene::load(name).map_err(|e| err(&e))?;
                let settings = WorldSettings { projection_iterations: n, ..*s.world.settings() };
                s.world.set_settings(settings).map_err(|e| err(&e))?;
                Ok(s)
            }
            MatrixVariant::Load(body, k) => {
                let b = scene::builtin(name).ok_or_else(|| err(&"not a built-in scene"))?;
                let text = scaled_body(b.text, body, k).map_err(|e| err(&e))?;
                scene::load_str(name, &text).map_err(|e| err(&e))
            }
        }
    }
}

/// The scene text with body `body`'s mass and inertia multiplied by `k` (its shapes unchanged).
pub fn scaled_body(text: &str, body: &str, k: f64) -> Result<String, String> {
    let mut doc: toml_edit::DocumentMut = text.parse().map_err(|e| format!("{e}"))?;
    let bodies = doc.get_mut("body").and_then(|b| b.as_array_of_tables_mut()).ok_or("no [[body]]")?;
    let b = bodies
        .iter_mut()
        .find(|b| b.get("name").and_then(|n| n.as_str()) == Some(body))
        .ok_or_else(|| format!("no body `{body}`"))?;
    let mass = b.get("mass").and_then(|m| m.as_float()).ok_or_else(|| format!("`{body}` has no mass"))?;
    b["mass"] = toml_edit::value(mass * k);
    if let Some(inertia) = b.get_mut("inertia").and_then(|i| i.as_array_mut()) {
        for v in inertia.iter_mut() {
            let x = v.as_float().ok_or_else(|| format!("`{body}`: inertia must be floats"))?;
            *v = (x * k).into();
        }
    }
    Ok(doc.to_string())
}

/// One cell's figures.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// Scene, variant label, fault kind and target, moment (s).
    pub scene: String,
    pub variant: String,
    pub kind: String,
    pub target: String,
    pub at: f64,
    /// Worst joint error after a step (m).
    pub joint_error: f64,
    /// Worst joint error beyond the joint's elastic deflection (m).
    pub joint_drift: f64,
    /// Steps in which the joint-error guard projected.
    pub guarded: u64,
    /// Steps re-run as substeps.
    pub substepped: u64,
    /// Fastest body (m/s) and the scene's bound.
    pub top_speed: f64,
    pub max_speed: f64,
    /// Largest energy excess over start + the inputs' work (J).
    pub energy_excess: f64,
    /// The watchdog's first finding, and how many steps it flagged.
    pub first: Option<String>,
    pub flagged: u64,
    /// Stable: quiet and within the joint bound.
    pub stable: bool,
    /// Final body positions (for the dropout cells' bitwise check).
    #[serde(skip)]
    pub final_positions: Vec<Vector3<f64>>,
}

fn energy(w: &World) -> f64 {
    w.kinetic_energy() + w.potential_energy()
}

/// The worst drift over the enabled joints whose error exceeds `above`: error less elastic
/// deflection (m; NaN counts as ∞; 0 when none exceeds it).
pub fn worst_drift(w: &World, above: f64) -> f64 {
    w.worst_joint_drift(above).map_or(0.0, |(_, d)| if d.is_nan() { f64::INFINITY } else { d })
}

/// The faults of scene `s`: (kind, target).
pub fn faults_of(s: &Scene) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for a in s.controls.actuators() {
        out.push(("hose_burst".to_string(), a.name().to_string()));
        out.push(("stick_valve".to_string(), a.name().to_string()));
        if a.kind() == ActuatorKind::Brake {
            out.push(("brake_fade".to_string(), a.name().to_string()));
        }
        if let Some(t) = a.targets().first()
            && let Some(j) = s.world.joint(t.joint)
        {
            let j = j.name().to_string();
            if !out.iter().any(|(k, n)| k == "break" && *n == j) {
                out.push(("break".to_string(), j));
            }
        }
    }
    for j in s.world.joints().iter().filter(|j| j.name().ends_with("/end")) {
        out.push(("break".to_string(), j.name().to_string()));
    }
    out
}

/// Runs scene `name` in `variant` under its script to `at + AFTER`, requesting `fault` (kind,
/// target) at `at` (`None`: the nominal run).
pub fn run_cell(
    name: &str,
    variant: MatrixVariant,
    fault: Option<(&str, &str)>,
    at: f64,
) -> Result<Cell, String> {
    let mut s = variant.load(name)?;
    let mut dog = Watchdog::new(&s.world, s.watchdog);
    let (e0, w0) = (energy(&s.world), s.world.input_work());
    let h = s.world.settings().timestep;
    let steps = ((at + AFTER) / h).round() as usize;
    let (kind, target) = fault.unwrap_or(("none", ""));
    let mut cell = Cell {
        scene: name.to_string(),
        variant: variant.label(),
        kind: kind.to_string(),
        target: target.to_string(),
        at,
        joint_error: 0.0,
        joint_drift: 0.0,
        guarded: 0,
        substepped: 0,
        top_speed: 0.0,
        max_speed: s.watchdog.max_speed,
        energy_excess: f64::NEG_INFINITY,
        first: None,
        flagged: 0,
        stable: false,
        final_positions: Vec::new(),
    };
    let mut pending = fault;
    for _ in 0..steps {
        if let Some((kind, target)) = pending
            && s.world.time() >= at - 1e-9
        {
            let req = FaultRequest {
                kind: kind.into(),
                target: target.into(),
                tension: None,
                to: None,
                ramp: None,
            };
            s.request_fault(&req).map_err(|e| format!("{name}: {kind} {target}: {e}"))?;
            pending = None;
        }
        s.step().map_err(|e| format!("{name} {fault:?} at {at}: t = {}: {e}", s.world.time()))?;
        let w = &s.world;
        cell.guarded += (w.last_guard_projections() > 0) as u64;
        cell.substepped += (w.last_substeps() > 1) as u64;
        let error = w.max_joint_error();
        cell.joint_error = cell.joint_error.max(error);
        cell.joint_drift =
            cell.joint_drift.max(if error > JOINT_BOUND { worst_drift(w, 0.0) } else { error });
        cell.top_speed = w.bodies().iter().map(|b| b.linvel().norm()).fold(cell.top_speed, f64::max);
        cell.energy_excess = cell.energy_excess.max(energy(w) - e0 - (w.input_work() - w0));
        if let Some(i) = dog.check(w)
            && cell.first.is_none()
        {
            cell.first = Some(i.to_string());
        }
    }
    cell.flagged = dog.count();
    cell.stable = cell.flagged == 0 && cell.joint_drift <= JOINT_BOUND;
    cell.final_positions = s.world.bodies().iter().map(|b| b.position()).collect();
    Ok(cell)
}

/// Every fault cell of scene `name` in `variant` (both moments), in the order of [`faults_of`];
/// `each` sees every cell as it finishes (progress).
pub fn scene_cells(
    name: &str,
    variant: MatrixVariant,
    mut each: impl FnMut(&Cell),
) -> Result<Vec<Cell>, String> {
    let faults = faults_of(&variant.load(name)?);
    let mut out = Vec::new();
    for (kind, target) in &faults {
        for at in MOMENTS {
            let c = run_cell(name, variant, Some((kind, target)), at)?;
            each(&c);
            out.push(c);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_load_is_heavier_and_the_same_shape() {
        let text = scene::builtin("crane").unwrap().text;
        let scaled = scaled_body(text, "pipe", 10.0).unwrap();
        let (a, b) = (scene::load_str("crane", text).unwrap(), scene::load_str("crane", &scaled).unwrap());
        let id = a.world.body_id("pipe").unwrap();
        let (ma, mb) = (a.world.body(id).unwrap().mass(), b.world.body(id).unwrap().mass());
        assert_eq!(mb, 10.0 * ma);
        assert_eq!(a.world.bodies().len(), b.world.bodies().len());
        assert!(scaled_body(text, "no-such-body", 2.0).is_err());
    }
}
