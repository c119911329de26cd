//! Island split on a hand-counted scene. Rows couple only dynamic bodies; static and kinematic
//! bodies have infinite mass and never join two islands. The scene (counted by hand):
//!
//! | island | bodies | joints | rows |
//! |---|---|---|---|
//! | 0 | free-floating chain a0–a2 | 2 fixed | 12 |
//! | 1 | chain b0–b2 hanging from the static ground | 3 ball | 9 |
//! | 2 | chain c0–c2 hanging from a kinematic crane hook | hinge + 2 ball | 11 |
//! | 3 | chain d0–d3 attached (slack) to the static ground at both ends | 5 ball | 15 |
//! | 4 | a lone body | — | 0 (nothing to solve) |
//!
//! Chains 1 and 3 share the static ground and chain 2 hangs from a moving kinematic body, yet they
//! stay separate islands: 5 islands, 4 with rows, numbered in order of their first body, stable from
//! step to step.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{BodyBuilder, BodyId, JointBuilder, World, WorldSettings, sphere_inertia};

fn link(w: &mut World, name: &str, x: Vector3<f64>) -> BodyId {
    w.add_body(BodyBuilder::dynamic(name, 1.0, sphere_inertia(1.0, 0.1)).position(x)).unwrap()
}

#[test]
fn hand_counted_islands() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let hook = w
        .add_body(BodyBuilder::kinematic("hook").position(Vector3::new(5.0, 0.0, 5.0)).linvel(Vector3::x()))
        .unwrap();
    let ex = Vector3::x();
    // Island 0: free chain with fixed joints.
    let a: Vec<BodyId> =
        (0..3).map(|i| link(&mut w, &format!("a{i}"), Vector3::new(i as f64, 10.0, 3.0))).collect();
    for i in 0..2 {
        w.add_joint(JointBuilder::fixed(
            &format!("ja{i}"),
            a[i + 1],
            Some(a[i]),
            Vector3::new(i as f64 + 0.5, 10.0, 3.0),
        ))
        .unwrap();
    }
    // Island 1: chain hanging from the ground.
    let b: Vec<BodyId> =
        (0..3).map(|i| link(&mut w, &format!("b{i}"), Vector3::new(0.0, 0.0, -(i as f64) - 1.0))).collect();
    w.add_joint(JointBuilder::ball("jb0", b[0], Some(ground), Vector3::new(0.0, 0.0, -0.5))).unwrap();
    for i in 0..2 {
        w.add_joint(JointBuilder::ball(
            &format!("jb{}", i + 1),
            b[i + 1],
            Some(b[i]),
            Vector3::new(0.0, 0.0, -(i as f64) - 1.5),
        ))
        .unwrap();
    }
    // Island 2: chain hanging from the kinematic hook.
    let c: Vec<BodyId> =
        (0..3).map(|i| link(&mut w, &format!("c{i}"), Vector3::new(5.0, 0.0, 4.0 - i as f64))).collect();
    w.add_joint(JointBuilder::hinge("jc0", c[0], Some(hook), Vector3::new(5.0, 0.0, 4.5), ex)).unwrap();
    for i in 0..2 {
        w.add_joint(JointBuilder::ball(
            &format!("jc{}", i + 1),
            c[i + 1],
            Some(c[i]),
            Vector3::new(5.0, 0.0, 3.5 - i as f64),
        ))
        .unwrap();
    }
    // Island 3: chain attached to the ground at both ends.
    let d: Vec<BodyId> =
        (0..4).map(|i| link(&mut w, &format!("d{i}"), Vector3::new(-3.0 + i as f64, -4.0, 0.0))).collect();
    w.add_joint(JointBuilder::ball("jd0", d[0], Some(ground), Vector3::new(-3.5, -4.0, 0.0))).unwrap();
    for i in 0..3 {
        w.add_joint(JointBuilder::ball(
            &format!("jd{}", i + 1),
            d[i + 1],
            Some(d[i]),
            Vector3::new(-2.5 + i as f64, -4.0, 0.0),
        ))
        .unwrap();
    }
    w.add_joint(JointBuilder::ball("jd4", d[3], Some(ground), Vector3::new(0.0, -4.0, 0.5))).unwrap();
    // Island 4: lone body.
    let lone = link(&mut w, "lone", Vector3::new(9.0, 9.0, 9.0));

    let ids = |v: &[BodyId]| v.iter().map(|b| b.index()).collect::<Vec<_>>();
    for _ in 0..30 {
        w.step().unwrap();
        let isl = w.islands();
        assert_eq!(isl.len(), 5);
        assert_eq!(isl.bodies(0), ids(&a).as_slice());
        assert_eq!(isl.bodies(1), ids(&b).as_slice());
        assert_eq!(isl.bodies(2), ids(&c).as_slice());
        assert_eq!(isl.bodies(3), ids(&d).as_slice());
        assert_eq!(isl.bodies(4), &[lone.index()]);
        assert!(isl.rows(4).is_empty());
        assert_eq!(isl.island_of(ground.index()), None);
        assert_eq!(isl.island_of(hook.index()), None);
        let stats = w.island_stats();
        let got: Vec<(usize, usize, usize)> = stats.iter().map(|s| (s.island, s.bodies, s.rows)).collect();
        assert_eq!(got, vec![(0, 3, 12), (1, 3, 9), (2, 3, 11), (3, 4, 15)]);
        for s in stats {
            assert_eq!(s.status.name(), "converged", "{s:?}");
        }
    }
    // The hanging chains follow gravity and the hook; the joints hold.
    assert!(w.max_anchor_error() < 1e-4, "{}", w.max_anchor_error());
}
