//! A 2 t load hoisted on a 20-segment, 70 kg steel cable (the paper's mobile crane, issue 12),
//! built with the scene file's `[[cable]]` element and wound in by a motorized drum (radius
//! 0.5 m, 400 kg) through the cable's fairlead and rack coupling (`dynamics/chain.rs`).
//!
//! The drum's velocity actuator ramps from rest to 0.4 rad/s over 2 s along the script's smooth
//! step (`σ(τ) = 3τ² − 2τ³`: angular acceleration `α = 0.2 · 6τ(1 − τ)` rad/s², at most
//! 0.3 rad/s²) and then holds it. Physics pinned down, against the script's kinematics and
//! Newton's second law on the load:
//! - the load rises at the drum's rate times its radius, `ż = R θ̇`, within 1 %;
//! - the tension in the cable at the load is `T = M (g + a)` within 1 %, with `a = R α` of the
//!   step (the drum reaches the rate set at the step's start within the step) while the drum
//!   accelerates and `a = 0` once it turns steadily;
//! - the drum's hinge carries the load: the rack coupling's torque is `R T`;
//! - the cable stays straight and its joints hold (mass ratio 2,000 / 3.5 = 570 on 1 m segments:
//!   `h² T ℓ / I = 19`, beyond the explicit step's bound of 4, so the geometric stiffness is what
//!   keeps it together).

use pivotsim_server::dynamics::{GeometricStiffness, steel_rope_mass_per_metre};
use pivotsim_server::scene;

const M: f64 = 2000.0;
const R: f64 = 0.5;
const G: f64 = 9.81;
/// Full drum rate (rad/s), ramp start and duration (s) of the script.
const RATE: f64 = 0.4;
const START: f64 = 0.5;
const RAMP: f64 = 2.0;

/// The drum rate the script commands at time `t` (the smooth step of `controls.rs`).
fn commanded(t: f64) -> f64 {
    let tau = ((t - START) / RAMP).clamp(0.0, 1.0);
    RATE * tau * tau * (3.0 - 2.0 * tau)
}

const SCENE: &str = r#"
[scene]
name = "hoist"
duration = 5.0

[[body]]
name = "drum"
mass = 400.0
position = [0, 0, 22]
rotation = [90, 0, 0]
[[body.shape]]
type = "cylinder"
radius = 0.5
length = 0.6

[[joint]]
name = "winch"
type = "hinge"
a = "drum"
anchor = [0, 0, 22]
axis = [0, -1, 0]

[[body]]
name = "load"
mass = 2000.0
position = [0.5, 0, 1.5]
[[body.shape]]
type = "ball"
radius = 0.5

[[cable]]
name = "rope"
start = [0.5, 0, 22]
direction = [0, 0, -1]
length = 20.0
segments = 20
diameter = 0.03
mass = 70.0
b = "load"
drum = "winch"
drum_radius = 0.5

[[actuator]]
name = "winch"
type = "velocity"
joints = ["winch"]
scale = [0.4]
max_force = 1e6

[[script]]
t = 0.5
set = { winch = 1.0 }
ramp = 2.0
"#;

struct Sample {
    t: f64,
    vz: f64,
    az: f64,
    drum_rate: f64,
    tension: f64,
}

fn run(gs: GeometricStiffness) -> (Vec<Sample>, f64) {
    let mut s = scene::load_str("hoist", SCENE).unwrap();
    let mut settings = *s.world.settings();
    settings.geometric_stiffness = gs;
    s.world.set_settings(settings).unwrap();
    let w = &s.world;
    let load = w.body_id("load").unwrap();
    let winch = w.joint_id("winch").unwrap();
    let end = w.joint_id("rope/end").unwrap();
    let h = w.settings().timestep;
    let mut out = Vec::new();
    let mut max_error: f64 = 0.0;
    let mut vz_prev = 0.0;
    for _ in 0..300 {
        s.step().unwrap();
        let w = &s.world;
        let vz = w.body(load).unwrap().linvel().z;
        out.push(Sample {
            t: w.time(),
            vz,
            az: (vz - vz_prev) / h,
            drum_rate: w.joint_speed(winch).unwrap(),
            tension: w.joint_reaction(end).unwrap().force.norm(),
        });
        vz_prev = vz;
        max_error = max_error.max(w.max_joint_error());
    }
    (out, max_error)
}

#[test]
fn the_steel_cable_weighs_what_steel_rope_weighs() {
    // A 1" (25.4 mm) 6 × 36 rope with a steel core: catalogue 1.85 lb/ft = 2.753 kg/m.
    let mu = steel_rope_mass_per_metre(0.0254);
    assert!((mu / 2.753 - 1.0).abs() <= 0.03, "{mu} kg/m");
}

#[test]
fn a_drum_hoists_two_tonnes_at_its_rate_with_the_tension_of_newtons_law() {
    let (samples, max_error) = run(GeometricStiffness::Implicit);
    let mut checked = (0, 0);
    for s in &samples {
        let accelerating = s.t > 1.0 && s.t < 2.4;
        let steady = s.t > 3.0;
        if !(accelerating || steady) {
            continue;
        }
        // The step ending at t reached the rate set at its start, t − h; the one before, t − 2h.
        let h = 1.0 / 60.0;
        let a = if accelerating { R * (commanded(s.t - h) - commanded(s.t - 2.0 * h)) / h } else { 0.0 };
        let rise = R * s.drum_rate;
        assert!(
            (s.vz - rise).abs() <= 0.01 * rise.abs(),
            "t {:.3}: load rises at {} m/s, drum pays {rise}",
            s.t,
            s.vz
        );
        let newton = M * (G + a);
        assert!(
            (s.tension - newton).abs() <= 0.01 * newton,
            "t {:.3}: tension {} N vs M (g + a) = {newton}",
            s.t,
            s.tension
        );
        assert!((s.az - a).abs() <= 0.01 * (G + a), "t {:.3}: acceleration {} vs {a}", s.t, s.az);
        if accelerating { checked.0 += 1 } else { checked.1 += 1 }
    }
    assert!(checked.0 > 60 && checked.1 > 100, "{checked:?}");
    assert!(max_error < 1e-3, "joint error {max_error} m");
    let last = samples.last().unwrap();
    println!("end: load at {:.4} m/s, tension {:.1} N, joint error {max_error:.2e} m", last.vz, last.tension);
}

/// For the note: the same hoist without the geometric stiffness.
#[test]
fn without_geometric_stiffness_for_comparison() {
    let (samples, max_error) = run(GeometricStiffness::Off);
    let worst =
        samples.iter().filter(|s| s.t > 3.0).map(|s| (s.tension - M * G).abs() / (M * G)).fold(0.0, f64::max);
    println!("geometric stiffness off: joint error {max_error:.3e} m, steady tension off by {worst:.3e}");
}
