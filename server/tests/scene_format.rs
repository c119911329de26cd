//! The scene format (scenes/README.md): every built-in scene loads and runs; malformed files give
//! errors located at the right line with the offending field; repeats, inertia from shapes,
//! actuators, the joystick map and the timeline behave as documented, checked against analytic
//! values.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{box_inertia, sphere_inertia};
use pivotsim_server::scene::{self, BUILTIN, InputError, SceneError};

const G: f64 = 9.81;

fn load(text: &str) -> scene::Scene {
    scene::load_str("test.toml", text).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(text: &str) -> SceneError {
    match scene::load_str("test.toml", text) {
        Ok(_) => panic!("loaded a malformed scene:\n{text}"),
        Err(e) => e,
    }
}

#[test]
fn every_builtin_scene_loads_and_runs_a_second() {
    assert!(BUILTIN.len() >= 3);
    for b in BUILTIN {
        let mut sc = scene::load(b.name).unwrap_or_else(|e| panic!("{}: {e}", b.name));
        assert_eq!(sc.name, b.name, "the file's [scene] name matches its built-in name");
        assert!(!b.summary.is_empty());
        for _ in 0..60 {
            sc.step().unwrap_or_else(|e| panic!("{}: {e}", b.name));
        }
        assert!(sc.world.bodies().iter().all(|b| b.position().iter().all(|c| c.is_finite())));
    }
}

const HEADER: &str = "[scene]\nname = \"t\"\n";

/// (body of the file after the header, line of the error counted in the whole file, a word the
/// message or field must contain)
const MALFORMED: &[(&str, usize, &str)] = &[
    // Syntax: an unterminated string.
    ("[[body]]\nname = \"a\nmass = 1\n", 4, "string"),
    // A wrong type.
    ("[[body]]\nname = \"a\"\nmass = \"heavy\"\n", 5, "f64"),
    // An unknown field, at its key.
    (
        "[[body]]\nname = \"a\"\nmass = 1\ninertia = [1, 1, 1]\n[[body.shape]]\ntype = \"ball\"\nradus = 0.1\n",
        9,
        "radus",
    ),
    // A missing body, at the joint's table.
    (
        "[[body]]\nname = \"a\"\nmass = 1\ninertia = [1, 1, 1]\n[[joint]]\nname = \"j\"\ntype = \"ball\"\na = \"a\"\nb = \"chasis\"\nanchor = [0, 0, 0]\n",
        7,
        "chasis",
    ),
    // Bad numbers: NaN and a negative mass.
    ("[[body]]\nname = \"a\"\nmass = nan\ninertia = [1, 1, 1]\n", 3, "mass"),
    ("[[body]]\nname = \"a\"\nmass = -2.0\ninertia = [1, 1, 1]\n", 3, "mass"),
    // A duplicate body, pointing at the first definition.
    (
        "[[body]]\nname = \"a\"\nmass = 1\ninertia = [1, 1, 1]\n[[body]]\nname = \"a\"\nmass = 1\ninertia = [1, 1, 1]\n",
        7,
        "test.toml:3:1",
    ),
    // An unknown shape type and a field that does not apply.
    ("[[body]]\nname = \"a\"\nmass = 1\n[[body.shape]]\ntype = \"sphere\"\nradius = 1\n", 6, "sphere"),
    (
        "[[body]]\nname = \"a\"\nmass = 1\n[[body.shape]]\ntype = \"box\"\nsize = [1, 1, 1]\nradius = 1\n",
        6,
        "radius",
    ),
    // A hinge without an axis.
    (
        "[[body]]\nname = \"a\"\nmass = 1\ninertia = [1, 1, 1]\n[[joint]]\nname = \"j\"\ntype = \"hinge\"\na = \"a\"\nanchor = [0, 0, 0]\n",
        7,
        "axis",
    ),
    // An actuator on a missing joint; a script entry for a missing actuator.
    ("[[actuator]]\nname = \"x\"\ntype = \"velocity\"\njoints = [\"nope\"]\nmax_force = 1\n", 3, "nope"),
    ("[[script]]\nt = 1\nset = { throttle = 1 }\n", 3, "throttle"),
    // A repeat without count or offsets.
    ("[[repeat]]\nstep = [1, 0, 0]\n", 3, "count"),
    // A dynamic body without mass, an unknown body kind, a zero-size box.
    ("[[body]]\nname = \"a\"\n", 3, "mass"),
    ("[[body]]\nname = \"a\"\nkind = \"ghost\"\n", 3, "ghost"),
    ("[[body]]\nname = \"a\"\nmass = 1\n[[body.shape]]\ntype = \"box\"\nsize = [1, 0, 1]\n", 6, "size"),
    // A missing [scene] section.
    ("", 0, "scene"),
];

#[test]
fn malformed_scenes_give_located_errors() {
    for (i, &(body, line, word)) in MALFORMED.iter().enumerate() {
        let text = if line == 0 { body.to_string() } else { format!("{HEADER}{body}") };
        let e = load_err(&text);
        let msg = e.to_string();
        assert!(msg.contains(word), "case {i}: `{msg}` should mention `{word}`");
        assert!(msg.starts_with("test.toml:"), "case {i}: `{msg}` names the file");
        if line > 0 {
            let at = e.location().unwrap_or_else(|| panic!("case {i}: {msg} has no location"));
            assert_eq!(at.line, line, "case {i}: {msg}");
        }
    }
}

#[test]
fn files_that_do_not_exist_and_unknown_names_are_errors() {
    assert!(matches!(scene::load("no-such-scene"), Err(SceneError::Unknown { .. })));
    let e = scene::load_file(std::path::Path::new("/nonexistent/x.toml")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }), "{e}");
}

#[test]
fn repeats_expand_names_offsets_and_from() {
    let sc = load(&format!(
        "{HEADER}
[[repeat]]
count = 5
step = [0.5, 0, 0]
[[repeat.body]]
name = \"link{{i}}\"
mass = 1
inertia = [1, 1, 1]
position = [0.25, 0, 1]
[[repeat.joint]]
name = \"j{{i}}\"
type = \"ball\"
a = \"link{{i}}\"
b = \"link{{i-1}}\"
anchor = [0, 0, 1]
from = 1
[[repeat]]
offsets = [[0, 1, 0], [0, -1, 0]]
[[repeat.body]]
name = \"wheel{{i}}\"
mass = 2
inertia = [1, 1, 1]
"
    ));
    let w = &sc.world;
    assert_eq!(w.bodies().len(), 7);
    assert_eq!(w.joints().len(), 4);
    for i in 0..5 {
        let b = w.body(w.body_id(&format!("link{i}")).unwrap()).unwrap();
        assert!((b.position() - Vector3::new(0.25 + 0.5 * i as f64, 0.0, 1.0)).norm() < 1e-15);
    }
    assert!(w.joint_id("j0").is_none());
    let j3 = w.joint(w.joint_id("j3").unwrap()).unwrap();
    assert_eq!(j3.body_a(), w.body_id("link3").unwrap());
    assert_eq!(j3.body_b(), w.body_id("link2"));
    assert_eq!(w.body(w.body_id("wheel1").unwrap()).unwrap().position().y, -1.0);
    assert!(w.max_anchor_error() < 1e-15, "anchors at the link ends");
}

/// `mass` spread over a box and a ball by volume, summed about the origin with the parallel-axis
/// theorem, against the body's world inertia tensor (the body is unrotated).
#[test]
fn inertia_from_shapes_is_the_volume_weighted_parallel_axis_sum() {
    let sc = load(&format!(
        "{HEADER}
[[body]]
name = \"b\"
mass = 10
[[body.shape]]
type = \"box\"
size = [0.4, 0.2, 0.6]
position = [0.1, 0, 0]
rotation = [0, 0, 90]
[[body.shape]]
type = \"ball\"
radius = 0.1
position = [0, 0, 0.5]
"
    ));
    let b = sc.world.body(sc.world.body_id("b").unwrap()).unwrap();
    let (v_box, v_ball) = (0.4 * 0.2 * 0.6, 4.0 / 3.0 * std::f64::consts::PI * 1e-3);
    let (m_box, m_ball) = (10.0 * v_box / (v_box + v_ball), 10.0 * v_ball / (v_box + v_ball));
    let steiner = |m: f64, d: Vector3<f64>| m * (Matrix3::identity() * d.norm_squared() - d * d.transpose());
    let r = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2).to_rotation_matrix();
    let i_box = r.matrix()
        * Matrix3::from_diagonal(&box_inertia(m_box, Vector3::new(0.2, 0.1, 0.3)))
        * r.matrix().transpose()
        + steiner(m_box, Vector3::new(0.1, 0.0, 0.0));
    let i_ball =
        Matrix3::from_diagonal(&sphere_inertia(m_ball, 0.1)) + steiner(m_ball, Vector3::new(0.0, 0.0, 0.5));
    let expected = i_box + i_ball;
    let got = b.inertia_world();
    assert!((got - expected).norm() < 1e-12 * expected.norm(), "{got} vs {expected}");
}

const WHEEL: &str = "
[[body]]
name = \"wheel\"
mass = 2
inertia = [0.1, 0.1, 0.1]
position = [0, 0, 1]
[[joint]]
name = \"axle\"
type = \"hinge\"
a = \"wheel\"
anchor = [0, 0, 1]
axis = [0, 1, 0]
[[actuator]]
name = \"drive\"
type = \"velocity\"
joints = [\"axle\"]
scale = [2.0]
max_force = 1e6
";

#[test]
fn a_velocity_actuator_drives_at_scale_times_value_clamps_and_refuses_nan() {
    let mut sc = load(&format!("{HEADER}{WHEEL}"));
    let axle = sc.world.joint_id("axle").unwrap();
    sc.controls.set("drive", 0.5).unwrap();
    sc.step_manual().unwrap();
    assert!((sc.world.joint_speed(axle).unwrap() - 1.0).abs() < 1e-6);
    sc.controls.set("drive", 7.0).unwrap();
    assert_eq!(sc.controls.get("drive").unwrap().value(), 1.0, "clamped to the default range");
    sc.step_manual().unwrap();
    assert!((sc.world.joint_speed(axle).unwrap() - 2.0).abs() < 1e-6);
    assert!(matches!(sc.controls.set("drive", f64::NAN), Err(InputError::NonFinite { .. })));
    assert!(matches!(sc.controls.set("warp", 1.0), Err(InputError::UnknownActuator(_))));
    assert_eq!(sc.controls.get("drive").unwrap().value(), 1.0, "a refused input changes nothing");
    // The deadman: neutral 0 brakes the wheel to rest in one step (the force bound is ample).
    sc.controls.neutralize(&sc.world);
    sc.step_manual().unwrap();
    assert!(sc.world.joint_speed(axle).unwrap().abs() < 1e-6);
}

#[test]
fn rate_limited_actuators_follow_at_their_rate() {
    let mut sc = load(&format!("{HEADER}{}\nrate = 0.6\n", WHEEL.trim_end()));
    let h = sc.world.settings().timestep;
    sc.controls.set("drive", 1.0).unwrap();
    for k in 1..=30 {
        sc.step_manual().unwrap();
        let expected = (0.6 * h * k as f64).min(1.0);
        assert!((sc.controls.get("drive").unwrap().applied() - expected).abs() < 1e-12, "step {k}");
    }
}

#[test]
fn the_script_ramps_values_and_the_joystick_maps_axes() {
    let mut sc = load(&format!(
        "{HEADER}{WHEEL}
[[script]]
t = 1.0
set = {{ drive = 0.8 }}
ramp = 2.0
[[script]]
t = 4.0
set = {{ drive = -0.5 }}
[[joystick.axis]]
index = 1
actuator = \"drive\"
scale = 0.5
deadzone = 0.1
"
    ));
    let h = sc.world.settings().timestep;
    let mut seen = Vec::new();
    while sc.world.time() < 5.0 - 1e-9 {
        let t = sc.world.time();
        sc.step().unwrap();
        seen.push((t, sc.controls.get("drive").unwrap().value()));
    }
    for &(t, v) in &seen {
        let expected = if t < 1.0 - 1e-9 {
            0.0
        } else if t < 3.0 {
            // The smooth step 3τ² − 2τ³ of the elapsed fraction τ (controls.rs).
            let tau = (t - 1.0) / 2.0;
            0.8 * tau * tau * (3.0 - 2.0 * tau)
        } else if t < 4.0 - 1e-9 {
            0.8
        } else {
            -0.5
        };
        assert!((v - expected).abs() < 1e-9, "t = {t}: {v} vs {expected}");
    }
    // Joystick: direct mode, scale 0.5, dead zone 0.1; axis 0 is unmapped.
    let mut world = sc.world;
    let mut c = sc.controls;
    sc.joystick.apply(&[0.9, 0.6], &[], h, &mut c, &mut world).unwrap();
    assert!((c.get("drive").unwrap().value() - 0.3).abs() < 1e-15);
    sc.joystick.apply(&[0.0, 0.05], &[], h, &mut c, &mut world).unwrap();
    assert_eq!(c.get("drive").unwrap().value(), 0.0, "inside the dead zone");
    assert!(sc.joystick.apply(&[0.0, f64::NAN], &[], h, &mut c, &mut world).is_err());
    assert_eq!(c.get("drive").unwrap().value(), 0.0, "a NaN reading changes nothing");
}

/// A ball falls freely until a disabled ball joint latches it where it is; it then hangs still.
#[test]
fn an_attach_event_latches_a_falling_body_where_it_is() {
    let mut sc = load(&format!(
        "{HEADER}
[[body]]
name = \"ball\"
mass = 3
inertia = [0.1, 0.1, 0.1]
position = [0, 0, 10]
[[joint]]
name = \"latch\"
type = \"ball\"
a = \"ball\"
anchor = [0, 0, 10]
enabled = false
[[script]]
t = 0.5
event = \"attach\"
joint = \"latch\"
"
    ));
    let id = sc.world.body_id("ball").unwrap();
    let h = sc.world.settings().timestep;
    let n = (0.5 / h).round() as usize;
    for _ in 0..n {
        sc.step().unwrap();
    }
    // Semi-implicit Euler: z_n = z_0 − g h² n (n + 1) / 2.
    let z = sc.world.body(id).unwrap().position().z;
    let expected = 10.0 - G * h * h * (n * (n + 1)) as f64 / 2.0;
    assert!((z - expected).abs() < 1e-9, "{z} vs {expected}");
    for _ in 0..60 {
        sc.step().unwrap();
    }
    let b = sc.world.body(id).unwrap();
    assert!((b.position().z - z).abs() < 1e-6, "latched at {z}, now {}", b.position().z);
    assert!(b.linvel().norm() < 1e-6);
}

/// A prismatic joint's slide is its coordinate, not an error: `max_joint_error` leaves it out,
/// `max_anchor_error` (documented as including it) does not.
#[test]
fn the_joint_error_excludes_a_prismatic_slide() {
    let mut sc = load(include_str!("support/rig.toml"));
    sc.controls.set("boom", 0.5).unwrap();
    for _ in 0..60 {
        sc.step_manual().unwrap();
    }
    let w = &sc.world;
    assert!((w.joint_coordinate(w.joint_id("rail").unwrap()).unwrap() - 0.5).abs() < 1e-6);
    assert!((w.max_anchor_error() - 0.5).abs() < 1e-6);
    // What remains is the compliant sag under gravity: c m g ≈ 1e-10 · 49 N per row.
    assert!(w.max_joint_error() < 1e-7, "{}", w.max_joint_error());
}

#[test]
fn pgs_sweeps_caps_the_projected_gauss_seidel_sweeps() {
    let w = load("[scene]\nname = \"t\"\nvariant = \"pgs\"\npgs_sweeps = 3\n").world;
    assert_eq!(w.settings().solver.pgs.max_iterations, 3);
    let default = load(HEADER).world;
    assert_eq!(default.settings().solver.pgs.max_iterations, 100);
    let e = load_err("[scene]\nname = \"t\"\npgs_sweeps = 0\n").to_string();
    assert!(e.contains("pgs_sweeps") && e.contains("≥ 1"), "{e}");
}

#[test]
fn the_contact_margin_is_read_and_checked() {
    let default = load(HEADER).world.contact_settings().margin;
    assert_eq!(default, 0.01);
    let sc = load("[scene]\nname = \"t\"\ncontact_margin = 0.05\n");
    assert_eq!(sc.world.contact_settings().margin, 0.05);
    for bad in ["-0.1", "nan"] {
        let e = load_err(&format!("[scene]\nname = \"t\"\ncontact_margin = {bad}\n"));
        assert!(e.to_string().contains("contact_margin"), "{e}");
    }
}

#[test]
fn projected_arc_reaches_the_solver_and_is_bounded() {
    let w = load("[scene]\nname = \"t\"\nprojected_arc = 4\n").world;
    assert_eq!(w.settings().solver.projected_arc, 4);
    assert_eq!(load("[scene]\nname = \"t\"\n").world.settings().solver.projected_arc, 0, "off by default");
    let e = load_err("[scene]\nname = \"t\"\nprojected_arc = 31\n").to_string();
    assert!(e.contains("projected_arc") && e.contains("at most 30"), "{e}");
}
