//! Threshold events with a hold (a debounce): the forklift's `load-slipping` event set here on the
//! 0/1 `forks_load/sliding` flag (the scene raises it on the slip speed), which flickers while the
//! crate creeps on the forks. Without a hold every flicker is a raise and a clear; with `hold = τ` an event fires only
//! after its condition held at every step for `τ`, which this test checks against the channel's
//! own history, step by step.

use pivotsim_server::scene;
use pivotsim_server::signals::EventKind;

/// (time, sliding flag) per step.
type Flag = Vec<(f64, f64)>;
/// (kind, time) per event.
type Fired = Vec<(EventKind, f64)>;

/// The sliding flag per step and every `load-slipping` event of a 20 s forklift run with the
/// event's hold set to `hold`.
fn run(hold: f64) -> (Flag, Fired) {
    let set = [format!("event.load-slipping.hold={hold}").parse().expect("override")];
    let shipped = scene::builtin("forklift").expect("forklift").text;
    let (speed, flag) = (
        "channel = \"forks_load/slip_speed\"\nabove = 0.02",
        "channel = \"forks_load/sliding\"\nabove = 0.5",
    );
    assert!(shipped.contains(speed), "the forklift's event changed");
    let mut s = scene::load_str_with("forklift.toml", &shipped.replace(speed, flag), &set).expect("forklift");
    let steps = (s.duration / s.world.settings().timestep).round() as usize;
    let (mut flag, mut events) = (Vec::new(), Vec::new());
    for _ in 0..steps {
        s.step().expect("step");
        flag.push((s.world.time(), s.signals.value("forks_load/sliding").expect("channel")));
        for e in s.signals.events().iter().filter(|e| e.name.as_str() == "load-slipping") {
            events.push((e.kind, e.time));
        }
    }
    (flag, events)
}

#[test]
fn a_hold_turns_a_flickering_flag_into_one_event_per_episode() {
    let (flag, bare) = run(0.0);
    let raised = |ev: &[(EventKind, f64)]| ev.iter().filter(|e| e.0 == EventKind::Raised).count();
    // Without a hold, each step the flag turns 1 raises.
    let turns_on =
        flag.windows(2).filter(|w| w[0].1 < 0.5 && w[1].1 > 0.5).count() + (flag[0].1 > 0.5) as usize;
    assert_eq!(raised(&bare), turns_on);
    assert!(turns_on >= 3, "the flag flickers: {turns_on} turns on");

    let hold = 0.25;
    let (flag_h, held) = run(hold);
    assert_eq!(flag_h, flag, "the hold changes the events, not the run");
    eprintln!("load-slipping raised {} times without a hold, {} with {hold} s", raised(&bare), raised(&held));
    assert!(raised(&held) >= 1 && raised(&held) < raised(&bare));
    // Every event of the held run: its condition held at every step of the `hold` before it, and
    // raises and clears alternate.
    let h = flag[1].0 - flag[0].0;
    let mut active = false;
    for &(kind, t) in &held {
        let want = if kind == EventKind::Raised { 1.0 } else { 0.0 };
        assert_eq!(kind == EventKind::Raised, !active, "raises and clears alternate");
        active = !active;
        let window: Vec<f64> = flag
            .iter()
            .filter(|(ts, _)| *ts > t - hold - 0.5 * h && *ts <= t + 0.5 * h)
            .map(|x| x.1)
            .collect();
        assert!(window.len() as f64 >= hold / h, "{kind:?} at {t}: window of {}", window.len());
        assert!(
            window.iter().all(|&v| (v - want).abs() < 0.5),
            "{kind:?} at {t} s after a break: {window:?}"
        );
    }
}
