//! Shadow solves (`dynamics/shadow.rs`, `run --shadow`): every island problem of a step also solved
//! by other variants, answers discarded. They must leave the trajectory exactly as it is, and on
//! the same problems two exact variants must give the same impulses to the solver's tolerance —
//! a check no comparison of separate runs can make once a contact-rich scene lets them part.

use pivotsim_server::dynamics::{MAX_SHADOWS, World};
use pivotsim_server::run::{RunError, RunOptions, run_scene_observed};
use pivotsim_server::scene;
use pivotsim_server::solver::{SolveStatus, Variant};

/// Poses of every body after every step.
fn trajectory(
    name: &str,
    opts: &RunOptions,
    mut check: impl FnMut(&World),
) -> (Vec<[f64; 7]>, pivotsim_server::run::RunSummary) {
    let mut s = scene::load(name).unwrap();
    let mut poses = Vec::new();
    let sum = run_scene_observed(&mut s, opts, |w: &World| {
        check(w);
        for b in w.bodies() {
            let (x, q) = (b.position(), b.orientation());
            poses.push([x.x, x.y, x.z, q.w, q.i, q.j, q.k]);
        }
    })
    .unwrap();
    (poses, sum)
}

#[test]
fn shadows_change_nothing_and_exact_variants_agree_on_every_island() {
    // The crane's hook meets the pipe at about 1 s (tight contact rows from step 62 on); the
    // forklift's forks carry a pallet on friction from the start.
    for (name, seconds) in [("crane", 2.0), ("forklift", 2.0)] {
        let base =
            RunOptions { duration: Some(seconds), variant: Some(Variant::Auto), ..RunOptions::default() };
        let (plain, plain_sum) = trajectory(name, &base, |_| {});
        let shadowed = RunOptions { shadow: vec![Variant::Full, Variant::Skyline], ..base.clone() };
        let mut islands = 0usize;
        let mut tight_islands = 0usize;
        let (with, sum) = trajectory(name, &shadowed, |w| {
            for st in w.island_stats() {
                islands += 1;
                tight_islands += (st.tight > 0) as usize;
                assert_eq!(st.shadow[0].variant, Some(Variant::Full));
                assert_eq!(st.shadow[1].variant, Some(Variant::Skyline));
                assert!(st.shadow[2..].iter().all(|s| s.variant.is_none()));
                for sh in &st.shadow[..2] {
                    assert!(sh.solve_us > 0.0 && sh.pivot_steps >= 1, "{name}: {sh:?}");
                    if sh.status == SolveStatus::Converged && st.status == SolveStatus::Converged {
                        assert!(sh.deviation <= 1e-8, "{name}: island {} {sh:?}", st.island);
                    }
                }
            }
        });
        assert_eq!(plain, with, "{name}: the shadows changed the trajectory");
        assert_eq!(plain_sum.solves_converged, sum.solves_converged);
        assert!(islands > 0 && tight_islands > 0, "{name}: no island with tight rows to compare on");
        assert_eq!(sum.shadow.len(), 2);
        for (x, v) in sum.shadow.iter().zip(["full", "skyline"]) {
            println!("{name}: {x:?}");
            assert_eq!(x.variant, v);
            assert_eq!(x.not_converged, 0, "{name} {v}");
            assert!(x.max_deviation <= 1e-8, "{name} {v}: {}", x.max_deviation);
            assert!(x.speedup.is_finite() && x.speedup > 0.0 && x.mean_solve_us > 0.0);
            assert!(x.own_mean_solve_us > 0.0 && x.own_mean_tight_us > 0.0);
            assert!((x.speedup - x.mean_solve_us / x.own_mean_solve_us).abs() <= 1e-9 * x.speedup);
        }
    }
}

#[test]
fn too_many_shadows_are_refused_before_the_run() {
    let mut s = scene::load("crane").unwrap();
    let opts = RunOptions {
        duration: Some(0.1),
        shadow: vec![Variant::Full; MAX_SHADOWS + 1],
        ..RunOptions::default()
    };
    let err = run_scene_observed(&mut s, &opts, |_| panic!("no step may run")).unwrap_err();
    assert!(matches!(err, RunError::Option(_)), "{err}");
    assert!(err.to_string().contains("at most 3"), "{err}");
}
