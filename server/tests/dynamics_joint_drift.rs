//! Joints hold their axes. A hinge (box pendulum on a horizontal axis, swinging ±1 rad under gravity
//! and pulled sideways by a spring that loads the locked rotations) and a prismatic joint (a slider
//! on an inclined rail, oscillating on a spring under gravity, its centre of mass off the rail so that
//! gravity twists it) run for 20 s at `h = 1/60`. Drift is measured at every step end as the anchor
//! separation `|p_b − p_a|` and, for the axis, the lateral distance at 1 m along the axis
//! `|e₁ × f₁| · 1 m` (hinge) or the lateral offset of the anchor from the rail line plus the locked
//! rotation angle times 1 m (prismatic).
//!
//! **The requirement (drift below 1e-6 m over 20 s at `h = 1/60`) is asserted with the
//! position projection explicitly enabled** (`projection_iterations = 1`): anchors hold to ~1e-8 m.
//! It is not the default: the default is the paper's formulation alone (`−φ/h` only, one solve per
//! step), which conserves energy and angular momentum far better and costs half as much (the
//! trade is documented in `dynamics/settings.rs`; the 50-link heavy chain runs 141 µs/step without, 272 µs/step
//! with projection, holding its length to 1e-11 m either way). Without projection the joint *axes*
//! still hold to ~1e-9 (asserted), and the anchors keep at every step end the second-order error of
//! integrating a rotation along its chord, `≈ (h ω)² r / 2` for an anchor at lever arm `r` from the
//! centre of mass; the next step removes it, so it never accumulates: we assert that bound and that
//! the error of the last 5 s is no larger than that of the first 5 s. The prismatic joint, whose body
//! does not rotate, holds 1e-6 m in both modes.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, ForceElement, JointBuilder, SpringDamper, World, WorldSettings, box_inertia,
};

const H: f64 = 1.0 / 60.0;
const T: f64 = 20.0;

/// The paper's formulation alone (default) or with one position-projection iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Paper,
    Projection,
}

impl Mode {
    fn settings(self) -> WorldSettings {
        WorldSettings {
            timestep: H,
            projection_iterations: (self == Mode::Projection) as usize,
            ..Default::default()
        }
    }
}

struct Drift {
    anchor: f64,
    axis: f64,
    first: f64,
    last: f64,
    max_chord_bound: f64,
}

fn hinge(mode: Mode) -> Drift {
    let mut w = World::new(mode.settings()).unwrap();
    let pivot = Vector3::new(0.0, 0.0, 3.0);
    let r = 0.8; // lever arm pivot → centre of mass
    let theta0: f64 = 1.0;
    let com = pivot + Vector3::new(theta0.sin(), 0.0, -theta0.cos()) * r;
    let he = Vector3::new(0.05, 0.2, r);
    let body = w
        .add_body(
            BodyBuilder::dynamic("plate", 5.0, box_inertia(5.0, he))
                .position(com)
                .orientation(UnitQuaternion::from_axis_angle(&Vector3::y_axis(), theta0)),
        )
        .unwrap();
    let j = w.add_joint(JointBuilder::hinge("hinge", body, None, pivot, Vector3::y())).unwrap();
    // Sideways spring on the lower edge: a torque about a locked axis that oscillates with the swing.
    let tip_local = Vector3::new(0.0, 0.2, -r);
    w.add_force(
        "side-spring",
        ForceElement::SpringDamper(SpringDamper {
            body_a: body,
            anchor_a: tip_local,
            body_b: None,
            anchor_b: Vector3::new(0.0, 1.5, 2.0),
            rest_length: 0.5,
            stiffness: 40.0,
            damping: 0.5,
        }),
    )
    .unwrap();
    let steps = (T / H) as usize;
    let mut d = Drift { anchor: 0.0, axis: 0.0, first: 0.0, last: 0.0, max_chord_bound: 0.0 };
    for n in 0..steps {
        w.step().unwrap();
        let f = w.joint_frames_world(j).unwrap();
        let (pa, pb, e1, f1) = (f.anchor_a, f.anchor_b, f.axis_a, f.axis_b);
        let anchor = (pb - pa).norm();
        let axis = e1.cross(&f1).norm();
        let b = w.body(body).unwrap();
        let lever = (pa - b.position()).norm();
        d.max_chord_bound = d.max_chord_bound.max((H * b.angvel().norm()).powi(2) * lever / 2.0);
        d.anchor = d.anchor.max(anchor);
        d.axis = d.axis.max(axis);
        let e = anchor.max(axis);
        if n < steps / 4 {
            d.first = d.first.max(e);
        } else if n >= 3 * steps / 4 {
            d.last = d.last.max(e);
        }
    }
    d
}

fn prismatic(mode: Mode) -> Drift {
    let mut w = World::new(mode.settings()).unwrap();
    let rail = Vector3::new(1.0, 0.0, 1.0).normalize();
    let anchor = Vector3::new(0.0, 0.0, 1.0);
    // Centre of mass 0.3 m off the rail: gravity twists the slider about the locked axes.
    let com = anchor + Vector3::new(0.0, 0.3, 0.0);
    let body = w
        .add_body(
            BodyBuilder::dynamic("slider", 10.0, box_inertia(10.0, Vector3::new(0.2, 0.3, 0.1)))
                .position(com),
        )
        .unwrap();
    let j = w.add_joint(JointBuilder::prismatic("rail", body, None, anchor, rail)).unwrap();
    w.add_force(
        "rail-spring",
        ForceElement::SpringDamper(SpringDamper {
            body_a: body,
            anchor_a: Vector3::new(0.0, -0.3, 0.0),
            body_b: None,
            anchor_b: anchor + rail * 2.0,
            rest_length: 1.0,
            stiffness: 200.0,
            damping: 0.0,
        }),
    )
    .unwrap();
    let steps = (T / H) as usize;
    let mut d = Drift { anchor: 0.0, axis: 0.0, first: 0.0, last: 0.0, max_chord_bound: 0.0 };
    let q0 = w.body(body).unwrap().orientation();
    let mut travel: f64 = 0.0;
    for n in 0..steps {
        w.step().unwrap();
        let f = w.joint_frames_world(j).unwrap();
        let (pa, pb) = (f.anchor_a, f.anchor_b);
        // Lateral offset of the body's anchor from the rail line through the world anchor.
        let off = pa - pb;
        let lateral = (off - rail * rail.dot(&off)).norm();
        let angle = w.body(body).unwrap().orientation().angle_to(&q0);
        travel = travel.max(w.joint_coordinate(j).unwrap().abs());
        d.anchor = d.anchor.max(lateral);
        d.axis = d.axis.max(angle);
        let e = lateral.max(angle);
        if n < steps / 4 {
            d.first = d.first.max(e);
        } else if n >= 3 * steps / 4 {
            d.last = d.last.max(e);
        }
    }
    assert!(travel > 0.2, "the slider must actually slide ({travel} m)");
    d
}

#[test]
fn hinge_holds_its_axis_for_20_s() {
    for mode in [Mode::Paper, Mode::Projection] {
        let d = hinge(mode);
        println!(
            "hinge, {mode:?}: max anchor drift {:.2e} m, max axis drift {:.2e} m at 1 m, chord bound (hω)²r/2 = {:.2e} m, first 5 s {:.2e}, last 5 s {:.2e}",
            d.anchor, d.axis, d.max_chord_bound, d.first, d.last
        );
        if mode == Mode::Paper {
            assert!(
                d.anchor < 1.5 * d.max_chord_bound + 1e-8,
                "anchor {} vs bound {}",
                d.anchor,
                d.max_chord_bound
            );
            assert!(d.axis < 1e-6, "axis {}", d.axis);
            assert!(d.last <= 1.5 * d.first, "accumulates: {} then {}", d.first, d.last);
        } else {
            assert!(d.anchor < 1e-6 && d.axis < 1e-6, "drift {} / {}", d.anchor, d.axis);
        }
    }
}

#[test]
fn prismatic_holds_its_axis_for_20_s() {
    for mode in [Mode::Paper, Mode::Projection] {
        let d = prismatic(mode);
        println!(
            "prismatic, {mode:?}: max lateral drift {:.2e} m, max rotation {:.2e} rad (≈ m at 1 m), first 5 s {:.2e}, last 5 s {:.2e}",
            d.anchor, d.axis, d.first, d.last
        );
        assert!(d.anchor < 1e-6 && d.axis < 1e-6, "drift {} / {}", d.anchor, d.axis);
    }
}
