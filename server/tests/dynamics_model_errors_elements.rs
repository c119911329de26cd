//! Bad couplings, chains and buoyancy elements are refused with typed errors that name the item:
//! gears and differentials with a zero, negative or NaN ratio, on unknown joints, on joints without a
//! free rotation (a prismatic joint), with a repeated shaft, a bad compliance or clutch bound (also
//! when set live); chains with a non-unit direction, non-positive length, mass or radius, no
//! segments, NaN anywhere, names already taken, unknown or identical end bodies (a refused chain adds
//! nothing); buoyancy without sample points, with non-positive volumes or heights, NaN positions, a
//! non-positive water density, negative wave amplitude or drag, on an unknown or non-dynamic body.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, Buoyancy, BuoyancyPoint, ChainBuilder, ChainEnd, ChainError, ChainShape,
    ControlError, CouplingBuilder, CouplingError, CouplingId, ForceElement, ForceError, JointBuilder,
    JointId, ModelError, Water, Wave, World, WorldSettings,
};

/// Which error a case expects.
type Check<E> = fn(&E) -> bool;

const NAN: f64 = f64::NAN;
const INF: f64 = f64::INFINITY;

fn unit_box(name: &str) -> BodyBuilder {
    BodyBuilder::dynamic(name, 1.0, Vector3::repeat(0.1))
}

#[test]
fn bad_couplings_chains_and_buoyancy() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let a = w.add_body(unit_box("a")).unwrap();
    let b = w.add_body(unit_box("b").position(Vector3::x())).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let o = Vector3::zeros();
    let ha = w.add_joint(JointBuilder::hinge("ha", a, None, o, Vector3::x())).unwrap();
    let hb = w.add_joint(JointBuilder::hinge("hb", b, None, Vector3::x(), Vector3::x())).unwrap();
    let slide = w.add_joint(JointBuilder::prismatic("slide", b, Some(a), o, Vector3::z())).unwrap();
    w.add_coupling(CouplingBuilder::gear("taken", ha, hb, 2.0)).unwrap();
    let cases: Vec<(CouplingBuilder, Check<CouplingError>)> = vec![
        (CouplingBuilder::gear("", ha, hb, 1.0), |e| matches!(e, CouplingError::EmptyName)),
        (CouplingBuilder::gear("taken", ha, hb, 1.0), |e| matches!(e, CouplingError::DuplicateName { .. })),
        (CouplingBuilder::gear("zero", ha, hb, 0.0), |e| matches!(e, CouplingError::InvalidRatio { .. })),
        (CouplingBuilder::gear("neg", ha, hb, -1.0), |e| matches!(e, CouplingError::InvalidRatio { .. })),
        (CouplingBuilder::differential("dnan", ha, hb, slide, NAN), |e| {
            matches!(e, CouplingError::InvalidRatio { .. })
        }),
        (CouplingBuilder::gear("ghost", ha, JointId(77), 1.0), |e| {
            matches!(e, CouplingError::UnknownJoint { joint: JointId(77), .. })
        }),
        (
            CouplingBuilder::gear("prism", ha, slide, 1.0),
            |e| matches!(e, CouplingError::NotRotational { kind: "prismatic", joint, .. } if joint == "slide"),
        ),
        (CouplingBuilder::differential("twice", ha, hb, hb, 1.0), |e| {
            matches!(e, CouplingError::RepeatedJoint { .. })
        }),
        (CouplingBuilder::gear("clutch", ha, hb, 1.0).max_torque(-1.0), |e| {
            matches!(e, CouplingError::InvalidMaxTorque { .. })
        }),
        (CouplingBuilder::gear("c", ha, hb, 1.0).compliance(INF), |e| {
            matches!(e, CouplingError::InvalidCompliance { .. })
        }),
    ];
    for (c, check) in cases {
        let name = c.name().to_string();
        let e = w.add_coupling(c).unwrap_err();
        assert!(check(&e), "'{name}': unexpected {e:?}");
        let msg = ModelError::from(e).to_string();
        assert!(name.is_empty() || msg.contains(&name), "{msg}");
    }
    assert_eq!(w.couplings().len(), 1);
    let g = w.coupling_id("taken").unwrap();
    assert!(matches!(w.set_coupling_max_torque(CouplingId(9), None), Err(ControlError::UnknownCoupling(_))));
    assert!(matches!(
        w.set_coupling_max_torque(g, Some(NAN)),
        Err(ControlError::Coupling(CouplingError::InvalidMaxTorque { .. }))
    ));
    w.set_coupling_max_torque(g, Some(3.0)).unwrap();

    // Chains: nothing is added when refused.
    w.add_body(unit_box("rope/2")).unwrap();
    let (bodies, joints) = (w.bodies().len(), w.joints().len());
    let rope = || ChainBuilder::new("rope", Vector3::new(0.0, 0.0, 5.0), -Vector3::z(), 0.5, 1.0, 4);
    let chains: Vec<(ChainBuilder, Check<ChainError>)> = vec![
        (ChainBuilder::new("", o, Vector3::x(), 0.5, 1.0, 4), |e| matches!(e, ChainError::EmptyName)),
        (ChainBuilder::new("c", o, Vector3::new(1.0, 1.0, 0.0), 0.5, 1.0, 4), |e| {
            matches!(e, ChainError::NonUnitDirection { .. })
        }),
        (ChainBuilder::new("c", o, Vector3::x(), 0.0, 1.0, 4), |e| {
            matches!(e, ChainError::InvalidParameter { what: "segment length", .. })
        }),
        (ChainBuilder::new("c", o, Vector3::x(), 0.5, -1.0, 4), |e| {
            matches!(e, ChainError::InvalidParameter { what: "segment mass", .. })
        }),
        (ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 0), |e| {
            matches!(e, ChainError::InvalidParameter { what: "count", .. })
        }),
        (ChainBuilder::new("c", Vector3::new(NAN, 0.0, 0.0), Vector3::x(), 0.5, 1.0, 4), |e| {
            matches!(e, ChainError::InvalidParameter { what: "start", .. })
        }),
        (
            ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 4).shape(ChainShape::Capsule { radius: 0.0 }),
            |e| matches!(e, ChainError::InvalidParameter { what: "radius", .. }),
        ),
        (ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 4).compliance(-1.0), |e| {
            matches!(e, ChainError::InvalidParameter { what: "compliance", .. })
        }),
        (ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 4).damping(NAN, 0.0), |e| {
            matches!(e, ChainError::InvalidParameter { what: "linear damping", .. })
        }),
        (rope(), |e| matches!(e, ChainError::NameTaken { name, .. } if name == "rope/2")),
        (ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 4).attach_end(ChainEnd::Body(BodyId(99))), |e| {
            matches!(e, ChainError::UnknownBody { .. })
        }),
        (
            ChainBuilder::new("c", o, Vector3::x(), 0.5, 1.0, 4)
                .attach_start(ChainEnd::Body(ground))
                .attach_end(ChainEnd::Body(ground)),
            |e| matches!(e, ChainError::EndsOnOneBody { .. }),
        ),
    ];
    for (c, check) in chains {
        let e = w.add_chain(c).unwrap_err();
        assert!(check(&e), "unexpected {e:?}");
    }
    assert_eq!((w.bodies().len(), w.joints().len()), (bodies, joints));

    // Buoyancy.
    let water = Water::still(0.0, 1000.0);
    let hull = || Buoyancy::box_grid(a, Vector3::repeat(0.5), 2, 2, water);
    let with_point = |p: BuoyancyPoint| Buoyancy { points: vec![p], ..hull() };
    let pt = BuoyancyPoint { position: o, volume: 1.0, height: 1.0 };
    let floats: Vec<(Buoyancy, Check<ForceError>)> = vec![
        (Buoyancy { points: vec![], ..hull() }, |e| matches!(e, ForceError::NoSamplePoints { .. })),
        (with_point(BuoyancyPoint { volume: 0.0, ..pt }), |e| {
            matches!(e, ForceError::InvalidPoint { point: 0, what: "volume", .. })
        }),
        (with_point(BuoyancyPoint { height: NAN, ..pt }), |e| {
            matches!(e, ForceError::InvalidPoint { what: "height", .. })
        }),
        (with_point(BuoyancyPoint { position: Vector3::new(0.0, INF, 0.0), ..pt }), |e| {
            matches!(e, ForceError::InvalidPoint { what: "position", .. })
        }),
        (Buoyancy { water: Water::still(0.0, 0.0), ..hull() }, |e| {
            matches!(e, ForceError::InvalidParameter { what: "water density", .. })
        }),
        (
            Buoyancy {
                water: Water {
                    wave: Some(Wave { amplitude: -1.0, angular_frequency: 1.0, phase: 0.0 }),
                    ..water
                },
                ..hull()
            },
            |e| matches!(e, ForceError::InvalidParameter { what: "wave amplitude", .. }),
        ),
        (hull().with_drag(-1.0, 0.0), |e| {
            matches!(e, ForceError::InvalidParameter { what: "linear drag", .. })
        }),
        (Buoyancy { body: BodyId(50), ..hull() }, |e| matches!(e, ForceError::UnknownBody { .. })),
        (Buoyancy { body: ground, ..hull() }, |e| matches!(e, ForceError::NoDynamicBody { .. })),
    ];
    for (el, check) in floats {
        let e = w.add_force("sea", ForceElement::Buoyancy(el)).unwrap_err();
        assert!(check(&e), "unexpected {e:?}");
    }
    assert!(w.forces().is_empty());
}
