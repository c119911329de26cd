//! Terrain shapes (issue 5): the height-field layout (row-major heights, rows along `y`, columns
//! along `x`, centred, `z` up) checked by where dropped balls come to rest, also on a posed static
//! body; degenerate terrain refused at build time with typed errors; terrain only on static
//! bodies and never inside a compound.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyKind, ColliderBuilder, ContactError, Shape, World, WorldSettings, sphere_inertia,
    terrain,
};

/// 11 × 11 samples over 10 m × 10 m (1 m cells): 0.2 m high where x > 0.5 and y < −0.5, else 0.
fn plateau() -> Shape {
    terrain::hills(11, 11, 10.0, 10.0, |x, y| if x > 0.5 && y < -0.5 { 0.2 } else { 0.0 })
}

#[test]
fn heightfield_layout_rows_along_y_columns_along_x() {
    for (pose, label) in [
        (Isometry3::identity(), "at the origin"),
        (
            Isometry3::from_parts(
                Vector3::new(20.0, 5.0, 1.0).into(),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
            ),
            "moved and turned 90°",
        ),
    ] {
        let mut w = World::new(WorldSettings::default()).unwrap();
        let g = w
            .add_body(
                BodyBuilder::static_body("ground")
                    .position(pose.translation.vector)
                    .orientation(pose.rotation),
            )
            .unwrap();
        w.add_collider(ColliderBuilder::new("ground", g, plateau())).unwrap();
        let r = 0.1;
        // Local cell centres: on the plateau, and its mirror images in x, y and the diagonal.
        let cases = [(3.5, -3.5, 0.2), (-3.5, -3.5, 0.0), (3.5, 3.5, 0.0), (-3.5, 3.5, 0.0)];
        let balls: Vec<_> = cases
            .iter()
            .enumerate()
            .map(|(k, &(x, y, _))| {
                let p = pose * nalgebra::Point3::new(x, y, 0.5);
                let b = w
                    .add_body(
                        BodyBuilder::dynamic(&format!("ball{k}"), 1.0, sphere_inertia(1.0, r))
                            .position(p.coords),
                    )
                    .unwrap();
                w.add_collider(ColliderBuilder::new(&format!("ball{k}"), b, Shape::Ball { radius: r }))
                    .unwrap();
                b
            })
            .collect();
        for _ in 0..120 {
            w.step().unwrap();
        }
        for (&(x, y, h), &b) in cases.iter().zip(&balls) {
            let local = pose.inverse() * nalgebra::Point3::from(w.body(b).unwrap().position());
            eprintln!("{label}: ball over ({x}, {y}) rests at local z = {:.6} (expected {})", local.z, h + r);
            assert!((local.z - (h + r)).abs() < 1e-4, "{label}: ({x}, {y}): z = {}", local.z);
            assert!((local.x - x).abs() < 1e-6 && (local.y - y).abs() < 1e-6);
        }
    }
}

#[test]
fn degenerate_terrain_is_refused_with_typed_errors() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let add = |w: &mut World, s: Shape| w.add_collider(ColliderBuilder::new("t", ground, s));
    let field = |rows: usize, cols: usize, heights: Vec<f64>, scale: Vector3<f64>| Shape::HeightField {
        rows,
        cols,
        heights,
        scale,
    };
    let one = Vector3::repeat(1.0);
    // Height fields.
    assert!(matches!(
        add(&mut w, field(1, 5, vec![0.0; 5], one)),
        Err(ContactError::HeightFieldTooSmall { rows: 1, cols: 5, .. })
    ));
    assert!(matches!(add(&mut w, field(0, 0, vec![], one)), Err(ContactError::HeightFieldTooSmall { .. })));
    assert!(matches!(
        add(&mut w, field(3, 4, vec![0.0; 11], one)),
        Err(ContactError::HeightFieldSize { rows: 3, cols: 4, heights: 11, .. })
    ));
    assert!(matches!(
        add(&mut w, field(40_000, 40_000, vec![], one)),
        Err(ContactError::TerrainTooLarge { .. })
    ));
    let mut nan = vec![0.0; 12];
    nan[6] = f64::NAN; // row 1, column 2 of 3 × 4
    assert!(matches!(
        add(&mut w, field(3, 4, nan, one)),
        Err(ContactError::NonFiniteHeight { row: 1, col: 2, .. })
    ));
    for (scale, what) in [
        (Vector3::new(0.0, 1.0, 1.0), "scale x"),
        (Vector3::new(1.0, f64::NAN, 1.0), "scale y"),
        (Vector3::new(1.0, 1.0, -2.0), "scale z"),
        (Vector3::new(1.0, 1.0, f64::INFINITY), "scale z"),
    ] {
        let got = add(&mut w, field(2, 2, vec![0.0; 4], scale));
        assert!(
            matches!(got, Err(ContactError::InvalidSize { what: w_, .. }) if w_ == what),
            "{what}: {got:?}"
        );
    }
    // Triangle meshes.
    let v = vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::new(2.0, 0.0, 0.0)];
    let mesh = |vertices: Vec<Vector3<f64>>, indices: Vec<[u32; 3]>| Shape::TriMesh { vertices, indices };
    assert!(matches!(add(&mut w, mesh(v.clone(), vec![])), Err(ContactError::EmptyMesh { .. })));
    assert!(matches!(add(&mut w, mesh(vec![], vec![[0, 1, 2]])), Err(ContactError::EmptyMesh { .. })));
    let mut bad = v.clone();
    bad[2].z = f64::INFINITY;
    assert!(matches!(
        add(&mut w, mesh(bad, vec![[0, 1, 2]])),
        Err(ContactError::NonFiniteVertex { index: 2, .. })
    ));
    assert!(matches!(
        add(&mut w, mesh(v.clone(), vec![[0, 1, 2], [1, 4, 2]])),
        Err(ContactError::TriangleIndexOutOfRange { triangle: 1, index: 4, vertices: 4, .. })
    ));
    for degenerate in [[0, 1, 1], [0, 1, 3]] {
        // A repeated vertex; three collinear vertices (0, x, 2x).
        assert!(matches!(
            add(&mut w, mesh(v.clone(), vec![[0, 1, 2], degenerate])),
            Err(ContactError::DegenerateTriangle { triangle: 1, .. })
        ));
    }
    let mut twin = v.clone();
    twin.push(Vector3::y()); // a copy of vertex 2
    assert!(matches!(
        add(&mut w, mesh(twin, vec![[0, 2, 4]])),
        Err(ContactError::DegenerateTriangle { triangle: 0, .. })
    ));
    // Terrain needs a static body, and is no compound part.
    let dynamic = w.add_body(BodyBuilder::dynamic("d", 1.0, Vector3::repeat(0.1))).unwrap();
    let kinematic = w.add_body(BodyBuilder::kinematic("k")).unwrap();
    assert_eq!(w.body(kinematic).unwrap().kind(), BodyKind::Kinematic);
    for body in [dynamic, kinematic] {
        for s in [terrain::deck(1.0, 1.0, 1), plateau()] {
            assert!(matches!(
                w.add_collider(ColliderBuilder::new("t", body, s)),
                Err(ContactError::TerrainNotStatic { .. })
            ));
        }
    }
    let compound = Shape::Compound { parts: vec![(Isometry3::identity(), terrain::deck(1.0, 1.0, 1))] };
    assert!(matches!(
        w.add_collider(ColliderBuilder::new("t", dynamic, compound)),
        Err(ContactError::InvalidCompound { .. })
    ));
    // Every helper builds a valid shape.
    for (k, s) in [
        plateau(),
        terrain::bumps(10.0, 0.5, 0.3, 4.0),
        terrain::ramp(5, 3, 4.0, 2.0, 0.3),
        terrain::stairs(4, 0.17, 0.28, 1.0),
        terrain::deck(2.0, 1.0, 4),
        mesh(v, vec![[0, 1, 2]]),
    ]
    .into_iter()
    .enumerate()
    {
        assert!(w.add_collider(ColliderBuilder::new(&format!("ok{k}"), ground, s)).is_ok(), "helper {k}");
    }
}
