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
        "geometric_stiffness = \"inertial\"\nmax_speed = 20.0\nenergy_margin = 0.05",
        &format!("{CABLE}\nb = \"hook\"\ndrum = \"winch\"\ndrum_radius = 0.5"),
    );
    let s = scene::load_str("t.toml", &text).unwrap();
    assert_eq!(s.world.settings().geometric_stiffness, GeometricStiffness::Inertial);
    assert_eq!(s.watchdog, WatchdogSettings { max_speed: 20.0, energy_margin: 0.05 });
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
