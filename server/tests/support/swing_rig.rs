//! The swinging-load rig of issue 12: the built-in `hanging_chain`'s 20 capsule links (0.5 kg,
//! 0.1 m, ball joints) from a hook at 2.5 m, with a ball load joined at its centre to the last
//! link's end, released from rest along a straight line at `angle` from the vertical.
//! `RIG_PROJECTION=n` in the environment sets the position projection iterations (a measurement
//! knob for the ignored sweeps; default 0).

#![allow(dead_code)]

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, GeometricStiffness, JointBuilder, World, WorldSettings, capsule_inertia, sphere_inertia,
};
use pivotsim_server::solver::{SolverOptions, Variant};

pub const LINKS: usize = 20;
pub const ELL: f64 = 0.1;
pub const M_LINK: f64 = 0.5;
pub const HOOK: f64 = 2.5;
pub const G: f64 = 9.81;

/// What a run of the rig measured.
#[derive(Debug, Clone)]
pub struct RigRun {
    pub steps: usize,
    pub max_joint_error: f64,
    pub max_speed: f64,
    /// Largest `(E − E₀) / |E_swing|` over the run, `E_swing` the initial energy above the rest
    /// position (the potential energy released by the swing).
    pub max_energy_gain: f64,
    /// Energy left at the end, over the initial swing energy.
    pub final_energy: f64,
    /// Mean swing period (s) from the load's upward zero crossings of x, if two or more.
    pub period: Option<f64>,
    /// Whether every step succeeded.
    pub finite: bool,
    /// Mean wall time per step (µs).
    pub step_us: f64,
    /// Largest tension in the hook joint (N).
    pub max_tension: f64,
}

pub fn world(load: f64, angle_deg: f64, gs: GeometricStiffness, variant: Variant) -> World {
    let settings = WorldSettings {
        geometric_stiffness: gs,
        solver: SolverOptions { variant, ..Default::default() },
        projection_iterations: std::env::var("RIG_PROJECTION").ok().and_then(|s| s.parse().ok()).unwrap_or(0),
        ..Default::default()
    };
    let mut w = World::new(settings).unwrap();
    let a = angle_deg.to_radians();
    let d = Vector3::new(a.sin(), 0.0, -a.cos());
    let top = Vector3::new(0.0, 0.0, HOOK);
    let q = nalgebra::UnitQuaternion::rotation_between(&Vector3::z(), &d).unwrap_or_else(|| {
        nalgebra::UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    let inertia = capsule_inertia(M_LINK, 0.01, 0.04);
    let mut prev = None;
    for i in 0..LINKS {
        let b = w
            .add_body(
                BodyBuilder::dynamic(&format!("link{i}"), M_LINK, inertia)
                    .position(top + d * ((i as f64 + 0.5) * ELL))
                    .orientation(q),
            )
            .unwrap();
        w.add_joint(JointBuilder::ball(&format!("joint{i}"), b, prev, top + d * (i as f64 * ELL))).unwrap();
        prev = Some(b);
    }
    let end = top + d * (LINKS as f64 * ELL);
    let l = w.add_body(BodyBuilder::dynamic("load", load, sphere_inertia(load, 0.1)).position(end)).unwrap();
    w.add_joint(JointBuilder::ball("pin", l, prev, end)).unwrap();
    w
}

/// Period of the rigid compound pendulum (chain as a uniform rod, load a point at its end) at
/// amplitude `amp` (rad), with the series of the complete elliptic integral to `θ⁴`.
pub fn compound_period(load: f64, amp: f64) -> f64 {
    let (mc, l) = (LINKS as f64 * M_LINK, LINKS as f64 * ELL);
    let i = load * l * l + mc * l * l / 3.0;
    let mgd = G * (load * l + mc * l / 2.0);
    let t0 = 2.0 * std::f64::consts::PI * (i / mgd).sqrt();
    t0 * (1.0 + amp * amp / 16.0 + 11.0 * amp.powi(4) / 3072.0)
}

pub fn energy(w: &World) -> f64 {
    w.kinetic_energy() + w.potential_energy()
}

pub fn run(load: f64, angle_deg: f64, gs: GeometricStiffness, variant: Variant, seconds: f64) -> RigRun {
    let mut w = world(load, angle_deg, gs, variant);
    let h = w.settings().timestep;
    let e0 = energy(&w);
    // Energy at rest (straight down) for the swing energy scale.
    let rest = {
        let mc = LINKS as f64 * M_LINK;
        let l = LINKS as f64 * ELL;
        -G * (-(HOOK - l) * load - (HOOK - l / 2.0) * mc)
    };
    let swing = (e0 - rest).abs().max(1e-9);
    let load_id = w.body_id("load").unwrap();
    let hook = w.joint_id("joint0").unwrap();
    let n = (seconds / h).round() as usize;
    let mut r = RigRun {
        steps: 0,
        max_joint_error: 0.0,
        max_speed: 0.0,
        max_energy_gain: f64::NEG_INFINITY,
        final_energy: 1.0,
        period: None,
        finite: true,
        step_us: 0.0,
        max_tension: 0.0,
    };
    let mut crossings = Vec::new();
    let mut x_prev = w.body(load_id).unwrap().position().x;
    let t = std::time::Instant::now();
    for _ in 0..n {
        if w.step().is_err() {
            r.finite = false;
            break;
        }
        r.steps += 1;
        r.max_joint_error = r.max_joint_error.max(w.max_joint_error());
        for b in w.bodies() {
            r.max_speed = r.max_speed.max(b.linvel().norm());
        }
        let e = energy(&w);
        r.max_energy_gain = r.max_energy_gain.max((e - e0) / swing);
        r.final_energy = (e - rest) / swing;
        if let Some(re) = w.joint_reaction(hook) {
            r.max_tension = r.max_tension.max(re.force.norm());
        }
        let x = w.body(load_id).unwrap().position().x;
        if x_prev < 0.0 && x >= 0.0 {
            crossings.push(w.time() - h + h * (-x_prev) / (x - x_prev));
        }
        x_prev = x;
    }
    r.step_us = t.elapsed().as_secs_f64() * 1e6 / r.steps.max(1) as f64;
    if crossings.len() >= 2 {
        r.period = Some((crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64);
    }
    r
}
