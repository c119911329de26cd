//! The load-moment indicator against statics (issue 17): a 6,000 kg carrier (4 × 2 m footprint)
//! slews a 6 m, 1,000 kg boom with a 1,000 kg load at its tip. The machine's centre of mass turns
//! on a circle of radius `r = (1000 · 3 + 1000 · 6) / 8000 = 1.125 m` about the slew axis and leaves
//! the footprint over its long side (`|y| = 1 m`) at the boom angle `θ* = asin(1 / r) = 62.73°`:
//! the tipping margin must cross zero there (within 1°), the 10 % warning must come before, and the
//! machine must then actually tip over that side.

use pivotsim_server::scene;
use pivotsim_server::signals::EventKind;

const SCENE: &str = include_str!("support/scenes/slewing_crane.toml");

#[test]
fn tipping_margin_crosses_zero_at_the_static_boom_angle_and_the_machine_tips() {
    let mut s = scene::load_str("slew.toml", SCENE).unwrap();
    let (carrier, load) = (s.world.body_id("carrier").unwrap(), s.world.body_id("load").unwrap());
    let theta_star = (1.0f64 / 1.125).asin().to_degrees();
    let boom_angle = |s: &scene::Scene| {
        let c = s.world.body(carrier).unwrap().position();
        let l = s.world.body(load).unwrap().position();
        (l.y - c.y).atan2(l.x - c.x).to_degrees()
    };
    let mut warned_at = None;
    let mut crossed_at = None;
    let mut last = f64::INFINITY;
    let mut end = 0;
    for step in 0..600 {
        s.step().unwrap();
        end = step;
        let d = s.signals.value("lmi/distance").unwrap();
        if s.signals.events().iter().any(|e| e.kind == EventKind::Raised && e.name.as_str() == "lmi-warning")
        {
            warned_at.get_or_insert(boom_angle(&s));
        }
        if crossed_at.is_none() && d < 0.0 && last >= 0.0 {
            crossed_at = Some((step, boom_angle(&s)));
        }
        last = d;
        let up = s.world.body(carrier).unwrap().pose().rotation * nalgebra::Vector3::z();
        if up.z < 4f64.to_radians().cos() {
            break;
        }
    }
    let (step, angle) = crossed_at.expect("the margin crossed zero");
    eprintln!(
        "crossed at step {step}, boom angle {angle:.3}° (statics {theta_star:.3}°); warning at {warned_at:?}"
    );
    assert!((angle - theta_star).abs() < 1.0, "crossed at {angle}°, statics {theta_star}°");
    assert!(warned_at.expect("a 10 % warning") < angle, "the warning comes first");
    let up = s.world.body(carrier).unwrap().pose().rotation * nalgebra::Vector3::z();
    let tilt = up.z.acos().to_degrees();
    // The load at 6 m with 0.5 m of clearance meets the ground at a tilt of about 4.8°.
    assert!(tilt > 4.0, "the machine tipped: carrier tilted {tilt:.1}°");
    eprintln!("tipped: carrier tilted {tilt:.2}° at step {end}");
    assert!(up.y > 0.0, "over the side the load is on");
}

/// A 6,000 kg carrier with a 1,000 kg boom fixed over its side, on the ground; optionally a
/// 500 kg pallet resting on the ground 5 m away, and the tipping sensors `sensors`.
fn yard(pallet: bool, sensors: &str) -> String {
    let pallet = if pallet {
        r#"
[[body]]
name = "pallet"
mass = 500.0
position = [6.0, 0, 0.1]
[[body.shape]]
type = "box"
size = [1.2, 1.0, 0.2]
"#
    } else {
        ""
    };
    format!(
        r#"
[scene]
name = "yard"
[[body]]
name = "ground"
kind = "static"
[[body.shape]]
type = "plane"
[[body]]
name = "carrier"
mass = 6000.0
position = [0, 0, 0.25]
[[body.shape]]
type = "box"
size = [4.0, 2.0, 0.5]
[[body]]
name = "boom"
mass = 1000.0
position = [0, 2.0, 0.75]
[[body.shape]]
type = "box"
size = [0.2, 4.0, 0.2]
[[joint]]
name = "mount"
type = "fixed"
a = "boom"
b = "carrier"
anchor = [0, 0, 0.75]
{pallet}
{sensors}
"#
    )
}

const TIPPING_CHANNELS: [&str; 5] = ["distance", "percent", "supports", "stabilizing", "overturning"];

fn tipping(s: &scene::Scene, sensor: &str) -> Vec<f64> {
    TIPPING_CHANNELS.iter().map(|c| s.signals.value(&format!("{sensor}/{c}")).unwrap()).collect()
}

/// `exclude` leaves a pallet resting on the ground out of `bodies = ["*"]`: the margin is that of
/// the machine alone (the same as naming its bodies, and as the same yard without the pallet),
/// while `["*"]` without it counts the pallet as part of the machine and gets another margin.
#[test]
fn an_excluded_load_on_the_ground_does_not_change_the_tipping_margin() {
    let sensors = r#"
[[sensor]]
name = "all"
type = "tipping"
bodies = ["*"]
[[sensor]]
name = "machine"
type = "tipping"
bodies = ["*"]
exclude = ["pallet"]
[[sensor]]
name = "named"
type = "tipping"
bodies = ["carrier", "boom"]
"#;
    let mut s = scene::load_str("yard.toml", &yard(true, sensors)).unwrap();
    let alone = r#"
[[sensor]]
name = "machine"
type = "tipping"
bodies = ["*"]
"#;
    let mut t = scene::load_str("yard-alone.toml", &yard(false, alone)).unwrap();
    for _ in 0..60 {
        s.step().unwrap();
        t.step().unwrap();
    }
    let (machine, named, all, alone) =
        (tipping(&s, "machine"), tipping(&s, "named"), tipping(&s, "all"), tipping(&t, "machine"));
    eprintln!("machine {machine:?}\nall {all:?}\nalone {alone:?}");
    assert_eq!(machine, named, "excluding the pallet = naming the machine's bodies");
    for (k, (a, b)) in machine.iter().zip(&alone).enumerate() {
        assert!(
            (a - b).abs() <= 1e-9 * b.abs().max(1.0),
            "{}: {a} with the pallet excluded, {b} without it",
            TIPPING_CHANNELS[k]
        );
    }
    // The boom over the side: the centre of mass at y = 1000 · 2 / 7000 m, 1 − 0.2857 m inside.
    assert!((machine[0] - (1.0 - 2000.0 / 7000.0)).abs() < 1e-6, "distance {}", machine[0]);
    // Counted as part of the machine, the pallet moves the centre of mass (to y = 2000 / 7500 m)
    // and adds its corners to the support polygon.
    assert!((all[0] - (1.0 - 2000.0 / 7500.0)).abs() < 1e-6, "distance {}", all[0]);
    assert!(all[2] > machine[2] && (all[1] - machine[1]).abs() > 1.0, "all {all:?}, machine {machine:?}");
}

#[test]
fn exclude_is_checked() {
    let err = |sensor: &str| {
        let Err(e) = scene::load_str("yard.toml", &yard(true, sensor)) else { panic!("accepted: {sensor}") };
        e.to_string()
    };
    let e =
        err("[[sensor]]\nname = \"m\"\ntype = \"tipping\"\nbodies = [\"carrier\"]\nexclude = [\"pallet\"]\n");
    assert!(e.contains("exclude") && e.contains("*"), "{e}");
    let e = err("[[sensor]]\nname = \"m\"\ntype = \"tipping\"\nbodies = [\"*\"]\nexclude = [\"palet\"]\n");
    assert!(e.contains("no body named `palet`"), "{e}");
    let e = err(
        "[[sensor]]\nname = \"m\"\ntype = \"tipping\"\nbodies = [\"*\"]\nexclude = [\"pallet\", \"carrier\", \"boom\"]\n",
    );
    assert!(e.contains("no dynamic body is left"), "{e}");
    let e = err("[[sensor]]\nname = \"m\"\ntype = \"joint\"\njoint = \"mount\"\nexclude = [\"pallet\"]\n");
    assert!(e.contains("`exclude` does not apply"), "{e}");
}
