//! A shipped scene's nominal run raises no alarm (issue 30). Every built-in scene runs its full
//! duration under its own script, and no threshold event of its signals (`[[event]]`: the crane's
//! `hoist-overload` above 30 kN and `lmi-warning`, the forklift's `load-slipping`, …) is raised.
//!
//! The physics behind it: the script moves its levers along a smooth step (`controls.rs`), whose
//! rate starts at zero. A linear ramp of a position actuator's target was a step of the cylinder's
//! speed, so the load was jolted at the ramp's start: on the crane the telescope/luff ramp at 4.5 s
//! raised `hoist-overload` two steps later (hook load 37.8 kN, 1.86 × the pipe's static 20 kN).
//! The hook load must not jolt above its static value through the boom's lift: at most 10 % above
//! the pipe's and hook's weight from t = 4.5 s (1.86 × with the linear ramp).
//!
//! The forklift's `load-slipping` fires when its pallet slides over the tines faster than 2 cm/s
//! (the contact's `slip_speed`); in the nominal run it creeps at most 1.3 cm/s (during the lift)
//! and 2.7 mm/s in the turn. It used to fire on the `sliding` flag (every pressed point's friction
//! row at its bound), which the turn sets while the pallet barely moves (docs/notes/dynamics.md).

use pivotsim_server::scene::{self, BUILTIN};
use pivotsim_server::signals::EventKind;

#[test]
fn no_shipped_scene_raises_an_alarm_in_its_nominal_run() {
    for b in BUILTIN {
        let mut s = scene::load(b.name).unwrap();
        let steps = (s.duration / s.world.settings().timestep).round() as usize;
        let mut raised = Vec::new();
        for _ in 0..steps {
            s.step().unwrap();
            raised.extend(s.signals.events().iter().filter(|e| e.kind != EventKind::Cleared).map(|e| {
                format!("{} at {:.3} s ({:.4e} vs {:.4e})", e.name.as_str(), e.time, e.value, e.level)
            }));
        }
        println!("{}: {} events raised {raised:?}", b.name, raised.len());
        assert!(raised.is_empty(), "{}: {raised:?}", b.name);
    }
}

#[test]
fn the_crane_lifts_its_pipe_without_a_jolt() {
    let mut s = scene::load("crane").unwrap();
    let steps = (s.duration / s.world.settings().timestep).round() as usize;
    let mut hi = 0.0f64;
    for _ in 0..steps {
        s.step().unwrap();
        if s.world.time() >= 4.5 {
            hi = hi.max(s.signals.value("hoist/hook").unwrap());
        }
    }
    // Pipe 2,000 kg and hook 70 kg hanging from the rope's last joint.
    let weight = 2070.0 * 9.81;
    println!("hook load from 4.5 s at most {hi:.0} N (static {weight:.0} N)");
    assert!(hi <= 1.1 * weight, "{hi} N against {weight} N");
}
