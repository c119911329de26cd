//! The step's hot loop reuses its buffers: after the first steps of a scene have sized them, a step
//! allocates nothing — the island problem is refilled in place (`Mlcp::assign`) and the solver's
//! workspace is reused. A counting global allocator watches, over chains of hinges and ball joints
//! (with and without projection) and over a machine scene with every other row kind and element:
//! cylindrical and universal joints, position motors on both free axes, a gear, a differential and a
//! slipping clutch (rows on three and four bodies), a spring–damper row, a buoyant float with waves
//! (the implicit 6 × 6 solve) and a cable from the chain helper; and over a 2 t load on a steel
//! cable wound by a drum (fairlead, rack coupling) and a heavy load swinging on a light chain, where
//! the geometric stiffness of the loaded joints is active (issue 12).

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, Buoyancy, ChainBuilder, ChainEnd, CouplingBuilder, ForceElement, FreeAxis, JointBuilder,
    JointLimit, JointMotor, SpringDamper, Water, Wave, World, WorldSettings, box_inertia, cylinder_inertia,
    sphere_inertia,
};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations_per_call;

/// `chains` chains of `links` links hanging from a static ceiling (one island each).
fn scene(chains: usize, links: usize, projection: usize) -> World {
    let mut w =
        World::new(WorldSettings { projection_iterations: projection, ..Default::default() }).unwrap();
    let ceiling = w.add_body(BodyBuilder::static_body("ceiling")).unwrap();
    for c in 0..chains {
        let x = c as f64;
        let mut prev = None;
        for i in 0..links {
            let b = w
                .add_body(
                    BodyBuilder::dynamic(&format!("c{c}l{i}"), 1.0, sphere_inertia(1.0, 0.05))
                        .position(Vector3::new(x + 0.3 * i as f64, 0.0, -0.2 * i as f64)),
                )
                .unwrap();
            let anchor = Vector3::new(x + 0.3 * i as f64 - 0.15, 0.0, -0.2 * i as f64 + 0.1);
            let j = if i == 0 {
                JointBuilder::hinge(&format!("c{c}j{i}"), b, Some(ceiling), anchor, Vector3::y())
                    .limit(JointLimit::new(-0.5, 0.5))
                    .motor(JointMotor::velocity(0.2, 3.0))
            } else {
                JointBuilder::ball(&format!("c{c}j{i}"), b, prev, anchor)
            };
            w.add_joint(j).unwrap();
            prev = Some(b);
        }
    }
    w
}

/// A machine with every other row kind: a boom on a cylindrical piston with position motors, a
/// drive shaft through a universal joint, a gearbox (gear, differential, clutch) on a chassis, a
/// sprung float in waves and a crane cable.
fn machine(projection: usize) -> World {
    let mut w =
        World::new(WorldSettings { projection_iterations: projection, ..Default::default() }).unwrap();
    let body = |w: &mut World, name: &str, m: f64, at: Vector3<f64>| {
        w.add_body(BodyBuilder::dynamic(name, m, box_inertia(m, Vector3::new(0.3, 0.2, 0.1))).position(at))
            .unwrap()
    };
    let chassis = body(&mut w, "chassis", 50.0, Vector3::new(0.0, 0.0, 1.0));
    w.add_joint(JointBuilder::prismatic("track", chassis, None, Vector3::new(0.0, 0.0, 1.0), Vector3::x()))
        .unwrap();
    let piston = body(&mut w, "piston", 5.0, Vector3::new(0.0, 0.0, 2.0));
    w.add_joint(
        JointBuilder::cylindrical(
            "cylinder",
            piston,
            Some(chassis),
            Vector3::new(0.0, 0.0, 2.0),
            Vector3::z(),
        )
        .motor(JointMotor::position(0.3, 0.2, 500.0))
        .axis_motor(FreeAxis::Angular, JointMotor::position(1.0, 0.5, 50.0).with_gain(0.5))
        .axis_limit(FreeAxis::Angular, JointLimit::new(-2.0, 2.0)),
    )
    .unwrap();
    let shaft = body(&mut w, "shaft", 2.0, Vector3::new(1.0, 0.0, 1.0));
    w.add_joint(
        JointBuilder::hinge("shaft-bearing", shaft, Some(chassis), Vector3::new(1.0, 0.0, 1.0), Vector3::x())
            .motor(JointMotor::velocity(5.0, 20.0)),
    )
    .unwrap();
    let prop = body(&mut w, "prop", 2.0, Vector3::new(2.0, 0.3, 1.0));
    let u = Vector3::new(1.0, 0.3, 0.0).normalize();
    w.add_joint(JointBuilder::hinge("prop-bearing", prop, Some(chassis), Vector3::new(2.0, 0.3, 1.0), u))
        .unwrap();
    w.add_joint(JointBuilder::universal(
        "cardan",
        shaft,
        Some(prop),
        Vector3::new(1.5, 0.0, 1.0),
        Vector3::y(),
        Vector3::z(),
    ))
    .unwrap();
    let wheel = |w: &mut World, name: &str, y: f64| {
        let b = body(w, name, 3.0, Vector3::new(0.0, y, 0.5));
        w.add_joint(JointBuilder::hinge(
            &format!("{name}-axle"),
            b,
            Some(chassis),
            Vector3::new(0.0, y, 0.5),
            Vector3::y(),
        ))
        .unwrap()
    };
    let (left, right) = (wheel(&mut w, "left", 1.0), wheel(&mut w, "right", -1.0));
    let input = w.joint_id("shaft-bearing").unwrap();
    w.add_coupling(CouplingBuilder::differential("diff", input, left, right, 3.0)).unwrap();
    w.add_coupling(
        CouplingBuilder::gear("clutch", input, w.joint_id("prop-bearing").unwrap(), 2.0).max_torque(1.0),
    )
    .unwrap();
    let float = body(&mut w, "float", 100.0, Vector3::new(5.0, 0.0, 0.0));
    let water = Water {
        level: 0.0,
        density: 1000.0,
        wave: Some(Wave { amplitude: 0.2, angular_frequency: 0.8, phase: 0.0 }),
    };
    w.add_force(
        "sea",
        ForceElement::Buoyancy(
            Buoyancy::box_grid(float, Vector3::new(0.3, 0.2, 0.1), 3, 2, water).with_drag(100.0, 10.0),
        ),
    )
    .unwrap();
    let mooring = SpringDamper {
        body_a: float,
        anchor_a: Vector3::zeros(),
        body_b: Some(chassis),
        anchor_b: Vector3::zeros(),
        rest_length: 4.0,
        stiffness: 500.0,
        damping: 20.0,
    };
    w.add_force("mooring", ForceElement::SpringDamper(mooring)).unwrap();
    w.add_chain(
        ChainBuilder::new(
            "cable",
            Vector3::new(0.0, 0.0, 2.3),
            Vector3::new(0.3, 0.0, -1.0).normalize(),
            0.2,
            0.5,
            8,
        )
        .attach_start(ChainEnd::Body(piston))
        .damping(0.5, 0.5),
    )
    .unwrap();
    w
}

fn allocations_per_step(w: &mut World) -> (f64, usize) {
    // Warm-up long enough for every row set the scene goes through (limits coming and going) to
    // have sized the buffers once.
    for _ in 0..120 {
        w.step().unwrap();
    }
    let per_step = allocations_per_call(20, || w.step().unwrap());
    let solves = w.island_stats().len() * (1 + w.settings().projection_iterations);
    (per_step, solves)
}

#[test]
fn steps_allocate_nothing_once_warm() {
    let mut per_solve = Vec::new();
    for (chains, links, proj) in [(1, 10, 0), (1, 40, 0), (4, 10, 0), (2, 10, 1)] {
        let mut w = scene(chains, links, proj);
        let (per_step, solves) = allocations_per_step(&mut w);
        println!(
            "{chains} chain(s) × {links} links, projection {proj}: {per_step} allocations per step, {solves} solves"
        );
        per_solve.push(per_step / solves as f64);
    }
    for proj in [0, 1] {
        let mut w = machine(proj);
        let (per_step, solves) = allocations_per_step(&mut w);
        let rows: usize = w.island_stats().iter().map(|s| s.rows).sum();
        println!("machine, projection {proj}: {per_step} allocations per step, {solves} solves, {rows} rows");
        assert!(w.bodies().iter().all(|b| b.position().iter().all(|c| c.is_finite())));
        per_solve.push(per_step / solves as f64);
    }
    assert!(per_solve.iter().all(|&p| p == 0.0), "{per_solve:?}");
}

/// A 2 t load hoisted by a drum on a 20-segment steel cable, swinging: the geometric stiffness is
/// on every segment, the rack coupling and the fairlead's limit take part.
#[test]
fn loaded_cable_on_a_drum_allocates_nothing() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let drum = w
        .add_body(
            BodyBuilder::dynamic("drum", 400.0, cylinder_inertia(400.0, 0.5, 0.3))
                .position(Vector3::new(0.0, 0.0, 22.0)),
        )
        .unwrap();
    let winch = w
        .add_joint(
            JointBuilder::hinge("winch", drum, None, Vector3::new(0.0, 0.0, 22.0), -Vector3::y())
                .motor(JointMotor::velocity(0.2, 1e6)),
        )
        .unwrap();
    let tilt: f64 = 0.2;
    let dir = Vector3::new(tilt.sin(), 0.0, -tilt.cos());
    let start = Vector3::new(0.5, 0.0, 22.0);
    let end = start + dir * 20.0;
    let load =
        w.add_body(BodyBuilder::dynamic("load", 2000.0, sphere_inertia(2000.0, 0.5)).position(end)).unwrap();
    w.add_chain(
        ChainBuilder::new("rope", start, dir, 1.0, 3.5, 20)
            .steel_rope(0.03)
            .attach_end(ChainEnd::Body(load))
            .drum(winch, 0.5),
    )
    .unwrap();
    let (per_step, solves) = allocations_per_step(&mut w);
    println!(
        "drum hoist: {per_step} allocations per step, {solves} solves, geometric stiffness on {} bodies",
        w.geometric_stiffness_bodies()
    );
    assert!(w.geometric_stiffness_bodies() >= 20);
    assert_eq!(per_step, 0.0);
}
