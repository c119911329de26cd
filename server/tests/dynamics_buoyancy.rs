//! Hydrostatic buoyancy and drag (`buoyancy.rs`) against Archimedes and the linear heave oscillator.
//!
//! - **Floating at the analytic draft.** A box of density `ρ_b < ρ_w` floats where the displaced
//!   water weighs as much as the box: draft `d = (ρ_b / ρ_w) H`. Checked for a 2 × 2 × 1 m box at
//!   half the water's density (dropped from 0.3 m above its waterline with a tilt that the righting
//!   moment removes) and for a 5,500 t ship hull (100 × 16 × 10 m box in sea water, draft 3.35 m), each
//!   settling under linear drag.
//! - **Sinking at the terminal speed.** A box twice as dense as water sinks; fully submerged, its
//!   speed tends to the root of `(ρ_b − ρ_w) g = c₁ u + c₂ u²` (drag per unit volume).
//! - **Riding slow waves.** With the water level `z₀ + A sin(ω t)` far below the heave resonance,
//!   a floating box heaves with the amplitude of the linear oscillator
//!   `m z̈ = −k (z − z_w) − c (ż − ż_w)`, `k = ρ_w g V / H`, `c = c₁ V d / H`:
//!   `|Z / A| = |(k + i c ω) / (k − m ω² + i c ω)|`, close to 1.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, Buoyancy, ForceElement, Water, Wave, World, WorldSettings, box_inertia,
};

const G: f64 = 9.81;

/// A box of half extents `half` and density `rho_b` at `z` (tilted by `tilt` about x), floating in
/// `water` with linear drag `c1`, quadratic `c2` on an `nx × ny` grid.
fn float(
    half: Vector3<f64>,
    rho_b: f64,
    z: f64,
    tilt: f64,
    water: Water,
    drag: (f64, f64),
    grid: (usize, usize),
) -> (World, BodyId) {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let mass = rho_b * 8.0 * half.x * half.y * half.z;
    let b = w
        .add_body(
            BodyBuilder::dynamic("hull", mass, box_inertia(mass, half))
                .position(Vector3::new(0.0, 0.0, z))
                .orientation(UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt)),
        )
        .unwrap();
    let el = Buoyancy::box_grid(b, half, grid.0, grid.1, water).with_drag(drag.0, drag.1);
    w.add_force("sea", ForceElement::Buoyancy(el)).unwrap();
    (w, b)
}

#[test]
fn floating_boxes_settle_at_the_analytic_draft() {
    // (name, half extents, body density, water density, linear drag, grid, seconds)
    let cases = [
        ("box", Vector3::new(1.0, 1.0, 0.5), 500.0, 1000.0, 2000.0, (4, 4), 40.0),
        ("5,500 t ship", Vector3::new(50.0, 8.0, 5.0), 5.5e6 / 16_000.0, 1025.0, 1050.0, (10, 4), 60.0),
    ];
    for (name, half, rho_b, rho_w, c1, grid, seconds) in cases {
        let height = 2.0 * half.z;
        let draft = rho_b / rho_w * height;
        // Released with the waterline 0.3 m too high, tilted 0.05 rad.
        let z0 = -half.z + draft + 0.3;
        let (mut w, b) = float(half, rho_b, z0, 0.05, Water::still(0.0, rho_w), (c1, 0.0), grid);
        let h = w.settings().timestep;
        for _ in 0..(seconds / h) as usize {
            w.step().unwrap();
        }
        let body = w.body(b).unwrap();
        let measured = 0.0 - (body.position().z - half.z);
        let tilt = body.orientation().angle();
        let ForceElement::Buoyancy(el) = &w.forces()[0] else { unreachable!() };
        let displaced = el.submerged_volume(w.bodies(), w.time()) * rho_w;
        println!(
            "{name}: mass {:.1} kg, draft {measured:.9} m vs (ρ_b/ρ_w) H = {draft:.9} m (rel. error {:.1e}), tilt {tilt:.1e} rad, displaced {displaced:.3} kg, heave speed {:.1e} m/s",
            body.mass(),
            (measured - draft).abs() / draft,
            body.linvel().z.abs()
        );
        assert!((measured - draft).abs() < 1e-6 * draft, "{measured} vs {draft}");
        assert!(tilt < 1e-6, "{tilt}");
        assert!((displaced - body.mass()).abs() < 1e-6 * body.mass());
    }
}

#[test]
fn dense_box_sinks_at_its_terminal_speed() {
    let half = Vector3::new(0.5, 0.5, 0.5);
    let (rho_b, rho_w, c1, c2) = (2000.0, 1000.0, 500.0, 200.0);
    let (mut w, b) = float(half, rho_b, 0.0, 0.0, Water::still(0.0, rho_w), (c1, c2), (2, 2));
    let h = w.settings().timestep;
    for _ in 0..(20.0 / h) as usize {
        w.step().unwrap();
    }
    let terminal = (-c1 + (c1 * c1 + 4.0 * c2 * (rho_b - rho_w) * G).sqrt()) / (2.0 * c2);
    let body = w.body(b).unwrap();
    let v = -body.linvel().z;
    println!(
        "sinking: depth {:.3} m after 20 s, speed {v:.12} m/s vs terminal {terminal:.12} m/s",
        -body.position().z
    );
    assert!(body.position().z < -50.0, "it sinks");
    assert!((v - terminal).abs() < 1e-9 * terminal, "{v} vs {terminal}");
}

#[test]
fn floating_box_rides_slow_waves() {
    let half = Vector3::new(1.0, 1.0, 0.5);
    let (rho_b, rho_w, c1) = (500.0, 1000.0, 1000.0);
    let (amp, omega) = (0.1, 0.6);
    let water = Water {
        level: 0.0,
        density: rho_w,
        wave: Some(Wave { amplitude: amp, angular_frequency: omega, phase: 0.0 }),
    };
    let (mut w, b) = float(half, rho_b, 0.0, 0.0, water, (c1, 0.0), (4, 4));
    let h = w.settings().timestep;
    let period = std::f64::consts::TAU / omega;
    let (mut zmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let total = 60.0;
    for n in 1..=(total / h) as usize {
        w.step().unwrap();
        if n as f64 * h > total - 2.0 * period {
            let z = w.body(b).unwrap().position().z;
            zmin = zmin.min(z);
            zmax = zmax.max(z);
        }
    }
    let volume = 8.0 * half.x * half.y * half.z;
    let (height, mass) = (2.0 * half.z, rho_b * volume);
    let k = rho_w * G * volume / height;
    let c = c1 * volume * (rho_b / rho_w);
    let num = nalgebra::Complex::new(k, c * omega);
    let den = nalgebra::Complex::new(k - mass * omega * omega, c * omega);
    let expected = amp * (num / den).norm();
    let heave = 0.5 * (zmax - zmin);
    println!(
        "waves: A = {amp} m, ω = {omega} rad/s (heave resonance {:.3} rad/s): heave amplitude {heave:.6} m vs linear theory {expected:.6} m ({:+.2} %)",
        (k / mass).sqrt(),
        100.0 * (heave / expected - 1.0)
    );
    assert!((heave - expected).abs() < 0.01 * expected, "{heave} vs {expected}");
}
