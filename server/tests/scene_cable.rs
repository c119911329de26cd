//! The scene file's settings of issue 12 (scenes/README.md): `geometric_stiffness`, the watchdog's
//! `max_speed` and `energy_margin`, and the `[[cable]]` element. Good values build what they say
//! (a steel cable's mass from its diameter, its joints and drum coupling); broken values — unknown
//! names, NaN, negative or zero numbers, a drum without its radius — are refused with a located
//! error naming the field, never a panic.

use pivotsim_server::dynamics::{GeometricStiffness, WatchdogSettings, steel_rope_mass_per_metre};
use pivotsim_server::scene::{self, SceneError};

const BASE: &str = r#"
[[body]]
name = "drum"
mass = 400.0
position = [0, 0, 10]
[[body.shape]]
type = "ball"
radius = 0.5
[[joint]]
name = "winch"
type = "hinge"
a = "drum"
anchor = [0, 0, 10]
axis = [0, 1, 0]
[[body]]
name = "hook"
mass = 70.0
position = [0.5, 0, 4]
[[body.shape]]
type = "ball"
radius = 0.2
"#;

fn scene_text(settings: &str, cable: &str) -> String {
    format!("[scene]\nname = \"t\"\n{settings}\n{BASE}\n[[cable]]\n{cable}\n")
}

const CABLE: &str = "name = \"rope\"\nstart = [0.5, 0, 10]\ndirection = [0, 0, -1]\nlength = 6.0\nsegments = 6\ndiameter = 0.02";

fn invalid_field(text: &str) -> String {
    match scene::load_str("t.toml", text) {
        Ok(_) => panic!("loaded:\n{text}"),
        Err(SceneError::Invalid { field, at, .. }) => {
            assert!(at.line >= 1);
            field
        }
        Err(SceneError::Syntax { .. }) => "syntax".into(),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn settings_and_a_steel_cable_on_a_drum_build() {
    let text = scene_text(
        "geometric_stiffness = \"inertial\"\nmax_speed = 20.0\nenergy_margin = 0.05\nmax_joint_error = 0.002",
        &format!("{CABLE}\nb = \"hook\"\ndrum = \"winch\"\ndrum_radius = 0.5"),
    );
    let s = scene::load_str("t.toml", &text).unwrap();
    assert_eq!(s.world.settings().geometric_stiffness, GeometricStiffness::Inertial);
    assert_eq!(s.watchdog, WatchdogSettings { max_speed: 20.0, energy_margin: 0.05, max_joint_error: 0.002 });
    let w = &s.world;
    let seg = w.body(w.body_id("rope/0").unwrap()).unwrap();
    assert!((seg.mass() - steel_rope_mass_per_metre(0.02)).abs() < 1e-12, "1 m segments of steel rope");
    for j in ["rope/fairlead", "rope/1", "rope/5", "rope/end"] {
        assert!(w.joint_id(j).is_some(), "{j}");
    }
    assert!(w.joint_id("rope/start").is_none(), "the fairlead replaces the start joint");
    assert!(w.coupling_id("rope/drum").is_some());
    // Defaults: implicit geometric stiffness, the default watchdog.
    let s = scene::load_str("t.toml", &scene_text("", &format!("{CABLE}\nmass = 12.0"))).unwrap();
    assert_eq!(s.world.settings().geometric_stiffness, GeometricStiffness::Implicit);
    assert_eq!(s.watchdog, WatchdogSettings::default());
    let w = &s.world;
    assert!((w.body(w.body_id("rope/2").unwrap()).unwrap().mass() - 2.0).abs() < 1e-12);
    assert!(w.joint_id("rope/start").is_some());
}

#[test]
fn broken_values_are_refused_with_the_field() {
    let cases: [(&str, &str, &str); 13] = [
        ("geometric_stiffness = \"sometimes\"", CABLE, "geometric_stiffness"),
        ("max_speed = -1.0", CABLE, "max_speed"),
        ("max_speed = nan", CABLE, "max_speed"),
        ("energy_margin = 0.0", CABLE, "energy_margin"),
        (
            "",
            "name = \"rope\"\nstart = [0, 0, 10]\ndirection = [0, 0, -1]\nlength = 6.0\nsegments = 0\ndiameter = 0.02",
            "segments",
        ),
        (
            "",
            "name = \"rope\"\nstart = [0, 0, 10]\ndirection = [0, 0, -1]\nlength = 6.0\nsegments = 6\ndiameter = -0.02",
            "diameter",
        ),
        (
            "",
            "name = \"rope\"\nstart = [0, 0, 10]\ndirection = [0, 0, -1]\nlength = nan\nsegments = 6\ndiameter = 0.02",
            "length",
        ),
        (
            "",
            "name = \"rope\"\nstart = [0, 0, 10]\ndirection = [0, 0, 0]\nlength = 6.0\nsegments = 6\ndiameter = 0.02",
            "direction",
        ),
        (
            "",
            "name = \"rope\"\nstart = [0, inf, 10]\ndirection = [0, 0, -1]\nlength = 6.0\nsegments = 6\ndiameter = 0.02",
            "start",
        ),
        ("", &*format!("{CABLE}\nmass = -3.0"), "mass"),
        ("", &*format!("{CABLE}\ndrum = \"winch\""), "drum"),
        ("", &*format!("{CABLE}\ndrum = \"nope\"\ndrum_radius = 0.5"), "drum"),
        ("", &*format!("{CABLE}\na = \"hook\"\ndrum = \"winch\"\ndrum_radius = 0.5"), "a"),
    ];
    for (settings, cable, field) in cases {
        let got = invalid_field(&scene_text(settings, cable));
        assert_eq!(got, field, "{settings} / {cable}");
    }
    // A drum radius of zero and a damping below zero.
    assert_eq!(
        invalid_field(&scene_text("", &format!("{CABLE}\ndrum = \"winch\"\ndrum_radius = 0.0"))),
        "drum_radius"
    );
    assert_eq!(invalid_field(&scene_text("", &format!("{CABLE}\ndamping = [-1.0, 0.0]"))), "damping");
}

/// `sag`: the cable hangs from its chord on a parabola of that mid-span sag, in equal segments,
/// its ends where the straight cable's are; a vertical chord or a sag beyond a quarter of the chord
/// is refused.
#[test]
fn a_sagging_cable_hangs_on_its_parabola_in_equal_segments() {
    let slant = "name = \"rope\"\nstart = [0, 0, 10]\ndirection = [0.6, 0, -0.8]\nlength = 6.0\nsegments = 30\n\
                 diameter = 0.02\nmass = 3.0\nb = \"hook\"\nsag = 0.4";
    let s = scene::load_str("t.toml", &scene_text("", slant)).unwrap();
    let w = &s.world;
    let (start, u) = (nalgebra::Vector3::new(0.0, 0.0, 10.0), nalgebra::Vector3::new(0.6, 0.0, -0.8));
    let across = nalgebra::Vector3::new(-0.8, 0.0, -0.6); // −z across the chord
    let point = |name: &str| w.joint_frames_world(w.joint_id(name).unwrap()).unwrap().anchor_a;
    // Every joint on the parabola p(x) = start + x u + 4 s (x/C)(1 − x/C) n.
    for i in 1..30 {
        let p = point(&format!("rope/{i}"));
        let x = (p - start).dot(&u);
        let off = p - start - u * x;
        let expect = 4.0 * 0.4 * (x / 6.0) * (1.0 - x / 6.0);
        assert!((off - across * expect).norm() < 1e-9, "joint {i}: {off:?} vs {expect}");
    }
    assert!((point("rope/15") - start - u * 3.0 - across * 0.4).norm() < 1e-3, "mid-span sag");
    assert!((point("rope/end") - (start + u * 6.0)).norm() < 1e-9, "the end stays at the chord's end");
    let chords: Vec<f64> = (0..30)
        .map(|i| {
            let a = if i == 0 { start } else { point(&format!("rope/{i}")) };
            let b = if i == 29 { point("rope/end") } else { point(&format!("rope/{}", i + 1)) };
            (b - a).norm()
        })
        .collect();
    let slack = chords.iter().sum::<f64>() - 6.0;
    assert!(chords.iter().all(|c| (c - chords[0]).abs() < 1e-9), "unequal segments {chords:?}");
    assert!((slack - 8.0 * 0.16 / 18.0).abs() < 0.1 * slack, "slack {slack} m vs 8 s² / (3 C)");
    assert!(w.max_joint_error() < 1e-12, "built with a joint error");
    // Refused: a sag on a vertical chord, beyond a quarter of the chord, below zero.
    for sag in ["sag = 0.5", "sag = 1.6", "sag = -0.1"] {
        let cable =
            if sag == "sag = 0.5" { format!("{CABLE}\n{sag}") } else { slant.replace("sag = 0.4", sag) };
        assert_eq!(invalid_field(&scene_text("", &cable)), "sag", "{sag}");
    }
}
