//! The shipped scenes' sensors read what their machines carry (issue 17): the crane's four
//! outrigger pads hold the whole crane while the pipe still lies on the ground, its load-moment
//! indicator starts with a positive margin; the forklift's lift cylinders push; the winch's rope
//! pulls. Bounded: one second of each scene.

use pivotsim_server::scene;

fn weight_of(s: &scene::Scene, skip: &[&str]) -> f64 {
    let g = s.world.settings().gravity.norm();
    s.world
        .bodies()
        .iter()
        .filter(|b| b.is_dynamic() && !skip.contains(&b.name()))
        .map(|b| b.mass() * g)
        .sum()
}

#[test]
fn crane_outriggers_carry_the_crane_and_the_lmi_starts_positive() {
    let mut s = scene::load("crane").unwrap();
    for _ in 0..30 {
        s.step().unwrap();
    }
    // Before the lift the pipe rests on the ground; the hook and rope hang from the boom.
    let w = weight_of(&s, &["pipe"]);
    let fz = s.signals.value("outriggers/fz").unwrap();
    assert!((fz - w).abs() < 0.02 * w, "outriggers {fz} N vs crane weight {w} N");
    let lmi = s.signals.sensor_values("lmi").unwrap();
    assert!(lmi[0] > 0.0 && lmi[1] > 0.0 && lmi[2] >= 4.0, "lmi {lmi:?}");
    let hook = s.signals.value("hoist/hook").unwrap();
    assert!(hook > 0.0, "the hook hangs on the rope: {hook}");
    assert!(s.signals.value("luff/force").unwrap() > 0.0, "the luffing cylinder pushes the boom up");
    eprintln!("crane: outriggers {fz:.0} N (weight {w:.0} N), lmi {lmi:?}, hook {hook:.1} N");
}

#[test]
fn forklift_cylinders_push_and_winch_rope_pulls() {
    let mut s = scene::load("forklift").unwrap();
    for _ in 0..60 {
        s.step().unwrap();
    }
    let (l, r) = (s.signals.value("lift_l/force").unwrap(), s.signals.value("lift_r/force").unwrap());
    eprintln!(
        "forklift: lift cylinders {l:.1} N, {r:.1} N, forks {:?}",
        s.signals.sensor_values("forks_load")
    );
    assert!(l.is_finite() && r.is_finite());
    let mut s = scene::load("winch").unwrap();
    for _ in 0..60 {
        s.step().unwrap();
    }
    let t = s.signals.value("rope/tension").unwrap();
    let torque = s.signals.value("drum/torque").unwrap();
    eprintln!("winch: rope {t:.1} N, drum {torque:.1} N m");
    assert!(t > 10.0, "the hanging links pull on the drum: {t}");
}
