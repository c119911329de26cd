//! Bad models are refused at build time with typed errors that name the offending item (zero,
//! negative, NaN or infinite mass and inertia, inertia no mass distribution has, negative damping,
//! non-unit quaternions, non-unit or non-perpendicular axes, joints to themselves or to unknown
//! bodies, limits and motors on axes a joint does not have free, bad motor gains, NaN anywhere;
//! couplings, chains and buoyancy in `dynamics_model_errors_elements.rs`), and a refused item
//! leaves the world unchanged. Conversely, any model that is accepted never produces a
//! NaN later: a seeded random zoo of bodies (masses over six decades), joints of every kind with
//! limits and velocity or position motors on every free axis, gears, springs, a floating body and a
//! kinematic body steps for 10 s with every state finite.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyError, BodyId, Buoyancy, ControlError, CouplingBuilder, ForceElement, ForceError,
    FreeAxis, JointBuilder, JointError, JointFrames, JointId, JointKind, JointLimit, JointMotor, JointRow,
    ModelError, SettingsError, SpringDamper, StateError, Water, Wave, World, WorldSettings, box_inertia,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Which error a case expects.
type Check<E> = fn(&E) -> bool;

const NAN: f64 = f64::NAN;
const INF: f64 = f64::INFINITY;

fn unit_box(name: &str) -> BodyBuilder {
    BodyBuilder::dynamic(name, 1.0, Vector3::repeat(0.1))
}

#[test]
fn bad_settings() {
    for h in [0.0, -1.0, NAN, INF] {
        let e = World::new(WorldSettings { timestep: h, ..Default::default() }).unwrap_err();
        assert!(matches!(e, SettingsError::InvalidTimestep(_)), "{e}");
    }
    let e =
        World::new(WorldSettings { gravity: Vector3::new(0.0, NAN, 0.0), ..Default::default() }).unwrap_err();
    assert!(matches!(e, SettingsError::NonFiniteGravity(_)));
    let e = World::new(WorldSettings { projection_iterations: 100, ..Default::default() }).unwrap_err();
    assert!(matches!(e, SettingsError::TooManyIterations { .. }));
}

#[test]
fn bad_bodies() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    w.add_body(unit_box("taken")).unwrap();
    let cases: Vec<(BodyBuilder, Check<BodyError>)> = vec![
        (unit_box(""), |e| matches!(e, BodyError::EmptyName)),
        (unit_box("taken"), |e| matches!(e, BodyError::DuplicateName { body } if body == "taken")),
        (
            BodyBuilder::dynamic("m0", 0.0, Vector3::repeat(1.0)),
            |e| matches!(e, BodyError::InvalidMass { body, .. } if body == "m0"),
        ),
        (BodyBuilder::dynamic("m-", -2.0, Vector3::repeat(1.0)), |e| {
            matches!(e, BodyError::InvalidMass { .. })
        }),
        (BodyBuilder::dynamic("mnan", NAN, Vector3::repeat(1.0)), |e| {
            matches!(e, BodyError::InvalidMass { .. })
        }),
        (BodyBuilder::dynamic("minf", INF, Vector3::repeat(1.0)), |e| {
            matches!(e, BodyError::InvalidMass { .. })
        }),
        (
            BodyBuilder::dynamic("i0", 1.0, Vector3::new(1.0, 0.0, 1.0)),
            |e| matches!(e, BodyError::InvalidInertia { body, .. } if body == "i0"),
        ),
        (BodyBuilder::dynamic("i-", 1.0, Vector3::new(1.0, 1.0, -1.0)), |e| {
            matches!(e, BodyError::InvalidInertia { .. })
        }),
        (BodyBuilder::dynamic("inan", 1.0, Vector3::new(NAN, 1.0, 1.0)), |e| {
            matches!(e, BodyError::InvalidInertia { .. })
        }),
        (BodyBuilder::dynamic("itri", 1.0, Vector3::new(1.0, 1.0, 3.0)), |e| {
            matches!(e, BodyError::NonPhysicalInertia { .. })
        }),
        (unit_box("q2").orientation_quaternion(Quaternion::new(1.0, 1.0, 0.0, 0.0)), |e| {
            matches!(e, BodyError::NonUnitQuaternion { what: "orientation", .. })
        }),
        (unit_box("qnan").orientation_quaternion(Quaternion::new(NAN, 0.0, 0.0, 0.0)), |e| {
            matches!(e, BodyError::NonUnitQuaternion { .. })
        }),
        (
            unit_box("p").inertia_frame(UnitQuaternion::new_unchecked(Quaternion::new(0.5, 0.0, 0.0, 0.0))),
            |e| matches!(e, BodyError::NonUnitQuaternion { what: "inertia frame", .. }),
        ),
        (unit_box("xnan").position(Vector3::new(0.0, NAN, 0.0)), |e| {
            matches!(e, BodyError::NonFinite { what: "position", .. })
        }),
        (unit_box("vinf").linvel(Vector3::new(INF, 0.0, 0.0)), |e| matches!(e, BodyError::NonFinite { .. })),
        (unit_box("wnan").angvel(Vector3::new(0.0, 0.0, NAN)), |e| matches!(e, BodyError::NonFinite { .. })),
        (BodyBuilder::static_body("moving").linvel(Vector3::x()), |e| {
            matches!(e, BodyError::StaticBodyMoving { .. })
        }),
        (BodyBuilder::static_body("snan").position(Vector3::new(NAN, 0.0, 0.0)), |e| {
            matches!(e, BodyError::NonFinite { .. })
        }),
        (unit_box("damp").linear_damping(-0.1), |e| {
            matches!(e, BodyError::InvalidDamping { what: "linear damping", .. })
        }),
        (unit_box("dampnan").angular_damping(NAN), |e| {
            matches!(e, BodyError::InvalidDamping { what: "angular damping", .. })
        }),
    ];
    for (b, check) in cases {
        let name = b.name().to_string();
        let e = w.add_body(b).unwrap_err();
        assert!(check(&e), "'{name}': unexpected {e:?}");
        // Errors convert into the scene loader's error and print the body's name.
        let msg = ModelError::from(e).to_string();
        assert!(name.is_empty() || msg.contains(&name), "{msg}");
    }
    assert_eq!(w.bodies().len(), 1);
}

#[test]
fn bad_joints() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let a = w.add_body(unit_box("a")).unwrap();
    let b = w.add_body(unit_box("b").position(Vector3::x())).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let hook = w.add_body(BodyBuilder::kinematic("hook")).unwrap();
    w.add_joint(JointBuilder::ball("taken", a, Some(b), Vector3::zeros())).unwrap();
    let o = Vector3::zeros();
    let bad_rot = Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::new_unchecked(Quaternion::new(2.0, 0.0, 0.0, 0.0)),
    );
    let cases: Vec<(JointBuilder, Check<JointError>)> = vec![
        (JointBuilder::ball("", a, None, o), |e| matches!(e, JointError::EmptyName)),
        (JointBuilder::ball("taken", a, None, o), |e| matches!(e, JointError::DuplicateName { .. })),
        (JointBuilder::ball("ghost", a, Some(BodyId(99)), o), |e| {
            matches!(e, JointError::UnknownBody { body: BodyId(99), .. })
        }),
        (JointBuilder::ball("ghost2", BodyId(7), None, o), |e| matches!(e, JointError::UnknownBody { .. })),
        (
            JointBuilder::hinge("self", a, Some(a), o, Vector3::x()),
            |e| matches!(e, JointError::SelfJoint { body, .. } if body == "a"),
        ),
        (JointBuilder::ball("static", ground, None, o), |e| matches!(e, JointError::NoDynamicBody { .. })),
        (JointBuilder::ball("kin", hook, Some(ground), o), |e| matches!(e, JointError::NoDynamicBody { .. })),
        (JointBuilder::hinge("axis2", a, None, o, Vector3::new(1.0, 1.0, 0.0)), |e| {
            matches!(e, JointError::NonUnitAxis { .. })
        }),
        (JointBuilder::hinge("axis0", a, None, o, Vector3::zeros()), |e| {
            matches!(e, JointError::NonUnitAxis { .. })
        }),
        (JointBuilder::prismatic("axisnan", a, None, o, Vector3::new(NAN, 0.0, 0.0)), |e| {
            matches!(e, JointError::NonUnitAxis { .. })
        }),
        (JointBuilder::ball("anchornan", a, None, Vector3::new(0.0, 0.0, NAN)), |e| {
            matches!(e, JointError::NonFinite { .. })
        }),
        (
            JointBuilder::new(
                "frame",
                JointKind::Fixed,
                a,
                None,
                JointFrames::Local { frame_a: bad_rot, frame_b: Isometry3::identity() },
            ),
            |e| matches!(e, JointError::NonUnitFrame { which: "frame_a", .. }),
        ),
        (
            JointBuilder::new(
                "framenan",
                JointKind::Fixed,
                a,
                None,
                JointFrames::Local {
                    frame_a: Isometry3::identity(),
                    frame_b: Isometry3::translation(NAN, 0.0, 0.0),
                },
            ),
            |e| matches!(e, JointError::NonFinite { what: "frame_b", .. }),
        ),
        (JointBuilder::ball("c-", a, None, o).compliance(-1e-9), |e| {
            matches!(e, JointError::InvalidCompliance { row: 0, .. })
        }),
        (JointBuilder::ball("cnan", a, None, o).row_compliance(JointRow::Locked(2), NAN), |e| {
            matches!(e, JointError::InvalidCompliance { row: 2, .. })
        }),
        (JointBuilder::ball("beta", a, None, o).stabilization(1.5), |e| {
            matches!(e, JointError::InvalidStabilization { .. })
        }),
        (JointBuilder::ball("betanan", a, None, o).stabilization(NAN), |e| {
            matches!(e, JointError::InvalidStabilization { .. })
        }),
        (JointBuilder::ball("balllimit", a, None, o).limit(JointLimit::new(-1.0, 1.0)), |e| {
            matches!(e, JointError::NoFreeAxis { kind: "ball", .. })
        }),
        (JointBuilder::fixed("fixedmotor", a, None, o).motor(JointMotor::velocity(1.0, 1.0)), |e| {
            matches!(e, JointError::NoFreeAxis { kind: "fixed", .. })
        }),
        (JointBuilder::hinge("lim", a, None, o, Vector3::z()).limit(JointLimit::new(1.0, -1.0)), |e| {
            matches!(e, JointError::InvalidLimit { .. })
        }),
        (JointBuilder::hinge("limnan", a, None, o, Vector3::z()).limit(JointLimit::new(NAN, 1.0)), |e| {
            matches!(e, JointError::InvalidLimit { .. })
        }),
        (
            JointBuilder::hinge("margin", a, None, o, Vector3::z()).limit(JointLimit {
                lower: 0.0,
                upper: 1.0,
                margin: -0.1,
            }),
            |e| matches!(e, JointError::InvalidLimit { .. }),
        ),
        (
            JointBuilder::prismatic("motor", a, None, o, Vector3::z()).motor(JointMotor::velocity(NAN, 1.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::prismatic("motor-", a, None, o, Vector3::z())
                .motor(JointMotor::velocity(1.0, -1.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::hinge("gain0", a, None, o, Vector3::z())
                .motor(JointMotor::position(1.0, 1.0, 5.0).with_gain(0.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::hinge("gain2", a, None, o, Vector3::z())
                .motor(JointMotor::position(1.0, 1.0, 5.0).with_gain(2.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::prismatic("umax0", a, None, o, Vector3::z())
                .motor(JointMotor::position(1.0, 0.0, 5.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::cylindrical("targetnan", a, None, o, Vector3::z())
                .axis_motor(FreeAxis::Angular, JointMotor::position(NAN, 1.0, 5.0)),
            |e| matches!(e, JointError::InvalidMotor { .. }),
        ),
        (
            JointBuilder::hinge("linlimit", a, None, o, Vector3::z())
                .axis_limit(FreeAxis::Linear, JointLimit::new(-1.0, 1.0)),
            |e| matches!(e, JointError::NoSuchAxis { kind: "hinge", axis: "linear", .. }),
        ),
        (
            JointBuilder::prismatic("angmotor", a, None, o, Vector3::z())
                .axis_motor(FreeAxis::Angular, JointMotor::velocity(1.0, 1.0)),
            |e| matches!(e, JointError::NoSuchAxis { kind: "prismatic", axis: "angular", .. }),
        ),
        (
            JointBuilder::universal("unilimit", a, None, o, Vector3::x(), Vector3::y())
                .limit(JointLimit::new(-1.0, 1.0)),
            |e| matches!(e, JointError::NoFreeAxis { kind: "universal", .. }),
        ),
        (JointBuilder::universal("pins", a, None, o, Vector3::x(), Vector3::new(0.6, 0.8, 0.0)), |e| {
            matches!(e, JointError::NonPerpendicularAxes { .. })
        }),
        (JointBuilder::universal("pinnan", a, None, o, Vector3::x(), Vector3::new(0.0, NAN, 0.0)), |e| {
            matches!(e, JointError::NonUnitAxis { .. })
        }),
        (JointBuilder::cylindrical("cylaxis", a, None, o, Vector3::new(0.0, 2.0, 0.0)), |e| {
            matches!(e, JointError::NonUnitAxis { .. })
        }),
    ];
    for (j, check) in cases {
        let name = j.name().to_string();
        let e = w.add_joint(j).unwrap_err();
        assert!(check(&e), "'{name}': unexpected {e:?}");
        assert!(name.is_empty() || e.to_string().contains(&name), "{e}");
    }
    assert_eq!(w.joints().len(), 1);
    // Live motor changes are validated too.
    let hinge = w.add_joint(JointBuilder::hinge("hinge", b, None, Vector3::x(), Vector3::z())).unwrap();
    assert!(matches!(w.set_joint_motor(JointId(42), None), Err(ControlError::UnknownJoint(JointId(42)))));
    assert!(matches!(
        w.set_joint_motor(hinge, Some(JointMotor::velocity(INF, 1.0))),
        Err(ControlError::Joint(JointError::InvalidMotor { .. }))
    ));
    assert!(matches!(
        w.set_joint_motor(JointId(0), Some(JointMotor::velocity(1.0, 1.0))),
        Err(ControlError::Joint(JointError::NoFreeAxis { .. }))
    ));
    w.set_joint_motor(hinge, Some(JointMotor::velocity(1.0, 1.0))).unwrap();
    assert!(matches!(
        w.set_joint_axis_motor(hinge, FreeAxis::Linear, Some(JointMotor::velocity(1.0, 1.0))),
        Err(ControlError::Joint(JointError::NoSuchAxis { .. }))
    ));
    assert!(matches!(
        w.set_joint_motor(hinge, Some(JointMotor::position(0.5, -1.0, 1.0))),
        Err(ControlError::Joint(JointError::InvalidMotor { .. }))
    ));
    w.set_joint_motor(hinge, Some(JointMotor::position(0.5, 1.0, 1.0))).unwrap();
    assert_eq!(w.joint(hinge).unwrap().motor(), Some(JointMotor::position(0.5, 1.0, 1.0)));
}

#[test]
fn bad_forces_and_states() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let a = w.add_body(unit_box("a")).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let spring = |a: BodyId, b: Option<BodyId>, k: f64| {
        ForceElement::SpringDamper(SpringDamper {
            body_a: a,
            anchor_a: Vector3::zeros(),
            body_b: b,
            anchor_b: Vector3::x(),
            rest_length: 0.5,
            stiffness: k,
            damping: 0.0,
        })
    };
    w.add_force("s", spring(a, None, 1.0)).unwrap();
    assert!(matches!(w.add_force("", spring(a, None, 1.0)), Err(ForceError::EmptyName)));
    assert!(matches!(w.add_force("s", spring(a, None, 1.0)), Err(ForceError::DuplicateName { .. })));
    assert!(matches!(w.add_force("u", spring(BodyId(9), None, 1.0)), Err(ForceError::UnknownBody { .. })));
    assert!(matches!(w.add_force("self", spring(a, Some(a), 1.0)), Err(ForceError::SelfAttached { .. })));
    assert!(matches!(w.add_force("nd", spring(ground, None, 1.0)), Err(ForceError::NoDynamicBody { .. })));
    assert!(matches!(
        w.add_force("k", spring(a, None, -1.0)),
        Err(ForceError::InvalidParameter { what: "stiffness", .. })
    ));
    assert!(matches!(w.add_force("knan", spring(a, None, NAN)), Err(ForceError::InvalidParameter { .. })));
    assert_eq!(w.forces().len(), 1);

    assert!(matches!(
        w.set_velocity(BodyId(5), Vector3::zeros(), Vector3::zeros()),
        Err(StateError::UnknownBody(_))
    ));
    assert!(matches!(w.set_velocity(ground, Vector3::x(), Vector3::zeros()), Err(StateError::StaticBody(_))));
    assert!(matches!(
        w.set_velocity(a, Vector3::new(NAN, 0.0, 0.0), Vector3::zeros()),
        Err(StateError::Invalid { .. })
    ));
    let bad_q = UnitQuaternion::new_unchecked(Quaternion::new(3.0, 0.0, 0.0, 0.0));
    assert!(matches!(w.set_pose(a, Vector3::zeros(), bad_q), Err(StateError::Invalid { .. })));
    assert!(matches!(
        w.set_pose(a, Vector3::new(INF, 0.0, 0.0), UnitQuaternion::identity()),
        Err(StateError::Invalid { .. })
    ));
    assert!(w.body(a).unwrap().position().iter().all(|c| c.is_finite()));
}

/// A seeded zoo of accepted models steps for 10 s without a single non-finite value. Random joints
/// over-constrain some bodies (welded to the ground and to the moving, spinning hook at once), so
/// some anchor errors grow large — only the compliance keeps those MLCPs regular, and on the worst
/// islands (a 1 g body in the same island as conflicting welds) the solver stops at its step cap
/// (status `max-steps`, a soft outcome in the stats) and bodies are flung far — but nothing becomes
/// NaN. Springs are implicit rows (`force.rs`), so even a spring between two 1 g bodies is stable.
#[test]
fn accepted_models_never_produce_nan() {
    for seed in 0..4u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut w = World::new(WorldSettings::default()).unwrap();
        let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
        let hook = w
            .add_body(BodyBuilder::kinematic("hook").linvel(Vector3::new(0.3, 0.0, 0.1)).angvel(Vector3::z()))
            .unwrap();
        let mut bodies = Vec::new();
        for i in 0..12 {
            let m = 10f64.powf(rng.random_range(-3.0..3.0));
            let he = Vector3::new(
                rng.random_range(0.05..0.5),
                rng.random_range(0.05..0.5),
                rng.random_range(0.05..0.5),
            );
            let x = Vector3::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(0.0..4.0),
            );
            let q = UnitQuaternion::from_euler_angles(
                rng.random_range(-3.0..3.0),
                rng.random_range(-1.5..1.5),
                rng.random_range(-3.0..3.0),
            );
            bodies.push(
                w.add_body(
                    BodyBuilder::dynamic(&format!("b{i}"), m, box_inertia(m, he)).position(x).orientation(q),
                )
                .unwrap(),
            );
        }
        let kinds = JointKind::ALL;
        let mut rotational = Vec::new();
        for i in 0..14 {
            let a = bodies[rng.random_range(0..bodies.len())];
            let b = match rng.random_range(0..4) {
                0 => None,
                1 => Some(ground),
                2 => Some(hook),
                _ => Some(bodies[rng.random_range(0..bodies.len())]).filter(|&b| b != a),
            };
            let kind = kinds[rng.random_range(0..kinds.len())];
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let anchor = w.body(a).unwrap().position() + Vector3::new(0.2, -0.1, 0.3);
            let mut jb = JointBuilder::at(&format!("j{i}"), kind, a, b, anchor, axis)
                .compliance(10f64.powf(rng.random_range(-10.0..-6.0)));
            for &free in kind.free_axes() {
                let motor = if rng.random_range(0..2) == 0 {
                    JointMotor::velocity(0.5, 5.0)
                } else {
                    JointMotor::position(rng.random_range(-0.5..0.5), 1.0, 5.0)
                        .with_gain(rng.random_range(0.1..1.0))
                };
                jb = jb.axis_limit(free, JointLimit::new(-0.3, 0.4)).axis_motor(free, motor);
            }
            let id = w.add_joint(jb).unwrap();
            if kind.has_axis(FreeAxis::Angular) {
                rotational.push(id);
            }
        }
        // Gears between rotational joints (some may share bodies, some over-constrain).
        for (k, pair) in rotational.chunks(2).enumerate() {
            if let [ja, jb] = *pair {
                let gear = CouplingBuilder::gear(&format!("g{k}"), ja, jb, rng.random_range(0.2..5.0));
                let gear = if k % 2 == 0 { gear.max_torque(2.0) } else { gear };
                w.add_coupling(gear).unwrap();
            }
        }
        let wave = Wave { amplitude: 0.3, angular_frequency: 1.0, phase: 0.0 };
        let sea = Buoyancy::box_grid(
            bodies[11],
            Vector3::repeat(0.3),
            2,
            2,
            Water { level: 2.0, density: 1000.0, wave: Some(wave) },
        )
        .with_drag(50.0, 10.0);
        w.add_force("sea", ForceElement::Buoyancy(sea)).unwrap();
        for i in 0..4 {
            let (a, b) = (bodies[i], bodies[i + 4]);
            w.add_force(
                &format!("s{i}"),
                ForceElement::SpringDamper(SpringDamper {
                    body_a: a,
                    anchor_a: Vector3::new(0.1, 0.0, 0.0),
                    body_b: Some(b),
                    anchor_b: Vector3::zeros(),
                    rest_length: 0.3,
                    stiffness: 20.0,
                    damping: 0.5,
                }),
            )
            .unwrap();
        }
        for _ in 0..600 {
            w.step().unwrap();
        }
        for b in w.bodies() {
            let finite =
                b.position().iter().chain(b.linvel().iter()).chain(b.angvel().iter()).all(|c| c.is_finite())
                    && b.orientation().coords.iter().all(|c| c.is_finite());
            assert!(finite, "seed {seed}: body {} not finite", b.name());
        }
        let worst = w.island_stats().iter().map(|s| s.residual_rel).fold(0.0, f64::max);
        let capped = w.island_stats().iter().filter(|s| s.status.name() != "converged").count();
        println!(
            "seed {seed}: {} islands ({capped} not converged in the last step), worst relative residual {worst:.1e}, max anchor error {:.1e} m",
            w.islands().len(),
            w.max_anchor_error()
        );
    }
}
