//! A chain of capsules lying on the ground, dragged along it at constant speed by a kinematic body
//! (issue 5): once every segment slides, the pulling joint carries the Coulomb force `μ N`, within
//! 2 % of `μ` times the chain's weight.
//!
//! The puller holds the chain's front end at the height it started at, while the contacts under
//! it yield by their compliance (`c F / β`): the rigid attachment then carries a share of the first
//! segment's weight set by the ratio of the joint's to the contacts' compliance (2 N of 4.9 N with
//! both at 1e-10, which unloads the ground and the friction by 4 %). A cable-like joint
//! compliance of 1e-7 m/N (a 2 µm stretch per joint under the pull) makes that share negligible.
//! The pull equals `μ` times the measured normal force exactly in either case.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, ChainBuilder, ChainEnd, ChainShape, ColliderBuilder, Shape, World, WorldSettings,
};

#[test]
fn dragged_capsule_chain_pulls_with_the_coulomb_force() {
    let (mu, n, l, m, v) = (0.4, 10, 0.2, 0.5, 0.5);
    let r = l / 20.0;
    let g = 9.81;
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(
        ColliderBuilder::new("ground", ground, Shape::HalfSpace { normal: Vector3::z() }).friction(mu),
    )
    .unwrap();
    // The puller moves along +x at the height of the segments' axes; the chain trails behind it.
    let start = Vector3::new(0.0, 0.0, r);
    let puller = w
        .add_body(BodyBuilder::kinematic("puller").position(start).linvel(Vector3::new(v, 0.0, 0.0)))
        .unwrap();
    let chain = w
        .add_chain(
            ChainBuilder::new("chain", start, -Vector3::x(), l, m, n)
                .shape(ChainShape::Capsule { radius: r })
                .compliance(1e-7)
                .attach_start(ChainEnd::Body(puller)),
        )
        .unwrap();
    for (i, &b) in chain.bodies.iter().enumerate() {
        w.add_collider(
            ColliderBuilder::new(&format!("link{i}"), b, Shape::Capsule { radius: r, half_length: l / 2.0 })
                .friction(mu),
        )
        .unwrap();
    }
    let pull = chain.joints[0];
    let weight = n as f64 * m * g;
    let expected = mu * weight;
    let (mut worst, mut worst_exact, mut mean, mut lift, mut count): (f64, f64, f64, f64, usize) =
        (0.0, 0.0, 0.0, 0.0, 0);
    for k in 1..=180 {
        w.step().unwrap();
        if k > 60 {
            // Force on segment 0 (body A of the start joint) from the puller.
            let f = w.joint_reaction(pull).unwrap().force;
            let normal: f64 = w.contacts().map(|c| c.normal_impulse * c.normal.z.abs()).sum::<f64>() / h;
            worst = worst.max((f.x - expected).abs() / expected);
            worst_exact = worst_exact.max((f.x - mu * normal).abs() / (mu * normal));
            mean += f.x;
            lift += f.z;
            count += 1;
        }
    }
    mean /= count as f64;
    lift /= count as f64;
    let points = w.contacts().count();
    let speeds = chain.bodies.iter().map(|&b| (w.body(b).unwrap().linvel().x - v).abs()).fold(0.0, f64::max);
    eprintln!(
        "capsule chain of {n} × {m} kg (r = {r} m) dragged at {v} m/s, μ = {mu}: {points} contact points; pull (steps \
         61–180) mean {mean:.6} N vs μ W = {expected:.6} N, worst rel err {worst:.2e}; vs μ N (measured) worst rel err \
         {worst_exact:.2e}; puller's vertical force {lift:.4} N; max segment speed error {speeds:.2e} m/s"
    );
    assert_eq!(points, 2 * n);
    assert!(speeds < 1e-6, "every segment moves with the puller: {speeds}");
    assert!(worst_exact < 1e-6, "pull = μ N: worst rel err {worst_exact}");
    assert!(worst < 0.02, "pull = μ × chain weight: worst rel err {worst}");
}
