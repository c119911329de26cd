//! The scene file's `[[buoyancy]]` table (scenes/README.md): a box hull written in a scene floats at
//! Archimedes' draft `(ρ_b / ρ_w) H`, its sample points shifted by `centre`, and rides a slow wave
//! with about its amplitude; broken values (a negative density, an empty grid, a wave without a
//! positive period, an unknown body) are refused with a located error naming the field.

use pivotsim_server::dynamics::ForceElement;
use pivotsim_server::scene::{self, SceneError};

/// A 4 × 2 × 1 m box of 4,000 kg (half the density of fresh water) with its element `extra`.
fn scene_text(extra: &str) -> String {
    format!(
        "[scene]\nname = \"float\"\n[[body]]\nname = \"hull\"\nmass = 4000.0\nposition = [0, 0, 0.3]\n\
         [[body.shape]]\ntype = \"box\"\nsize = [4.0, 2.0, 1.0]\n\
         [[buoyancy]]\nname = \"sea\"\nbody = \"hull\"\nsize = [4.0, 2.0, 1.0]\ngrid = [4, 2]\n\
         density = 1000.0\nlinear_drag = 2000.0\n{extra}\n"
    )
}

#[test]
fn a_box_hull_floats_at_the_archimedes_draft_and_rides_the_wave() {
    // Still water: draft 0.5 m, the box's centre at z = 0.
    let mut s = scene::load_str("float.toml", &scene_text("")).unwrap();
    let hull = s.world.body_id("hull").unwrap();
    for _ in 0..1800 {
        s.world.step().unwrap();
    }
    let z = s.world.body(hull).unwrap().position().z;
    eprintln!("still water: the box's centre settles at {z:.2e} m (draft 0.5 m: 0)");
    assert!(z.abs() < 1e-4, "centre at {z} m");

    // `centre` shifts the sample points: a hull box 0.2 m above the centre of mass floats 0.2 m lower.
    let mut s = scene::load_str("float.toml", &scene_text("centre = [0, 0, 0.2]")).unwrap();
    let ForceElement::Buoyancy(el) = &s.world.forces()[0] else { panic!("not a buoyancy") };
    assert!(el.points.iter().all(|p| (p.position.z - 0.2).abs() < 1e-12));
    for _ in 0..1800 {
        s.world.step().unwrap();
    }
    let z = s.world.body(hull).unwrap().position().z;
    assert!((z + 0.2).abs() < 1e-4, "centre at {z} m");

    // A slow wave (20 s ≫ the heave period 2π √(H ρ_b / (ρ_w g)) = 1 s): the box heaves with it.
    let mut s =
        scene::load_str("float.toml", &scene_text("wave = { amplitude = 0.1, period = 20.0, phase = 90.0 }"))
            .unwrap();
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for i in 0..2400 {
        s.world.step().unwrap();
        if i >= 1200 {
            let z = s.world.body(hull).unwrap().position().z;
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    eprintln!("wave of 0.1 m: the box heaves between {lo:.4} and {hi:.4} m");
    assert!(((hi - lo) / 2.0 - 0.1).abs() < 0.01, "heave amplitude {}", (hi - lo) / 2.0);
}

#[test]
fn broken_buoyancy_values_are_refused_with_the_field() {
    let cases = [
        ("density = -1.0", "density"),
        ("grid = [0, 2]", "grid"),
        ("wave = { amplitude = 0.1, period = 0.0 }", "wave"),
        ("wave = { amplitude = -0.1, period = 5.0 }", "wave"),
        ("linear_drag = nan", "linear_drag"),
    ];
    for (bad, field) in cases {
        // The base's own line of the field gives way to the broken one.
        let base = scene_text("");
        let text: String = base
            .lines()
            .filter(|l| !l.starts_with(&format!("{field} =")))
            .map(|l| format!("{l}\n"))
            .collect();
        let text = text + bad + "\n";
        match scene::load_str("float.toml", &text) {
            Err(SceneError::Invalid { field: f, at, .. }) => {
                assert_eq!(f, field, "{bad}");
                assert!(at.line >= 1);
            }
            Err(e) => panic!("{bad}: {e}"),
            Ok(_) => panic!("{bad}: loaded"),
        }
    }
    let text = scene_text("").replace("body = \"hull\"", "body = \"barge\"");
    assert!(
        matches!(scene::load_str("float.toml", &text), Err(SceneError::Invalid { field, .. }) if field == "body")
    );
}
