//! The regression corpus of real islands (`server/tests/data/corpus/`, README there): the hardest
//! solves of 20 s runs of the forklift, winch and forwarder scenes, at their shipped contact
//! compliance and at 1e-10, each with the warm start the simulation gave it.
//!
//! What is pinned down:
//! - **Safe when capped.** At every step cap from 1 to 35, warm and cold, the returned `λ` is
//!   feasible (every box, every normal ≥ 0, every friction row inside `±μ λ_n` of the normal it
//!   is returned with) and does no positive work: `f(λ) = ½λᵀAλ − bᵀλ ≤ 0 = f(0)` (the zero
//!   impulse is always feasible). The status and residual it reports agree with a residual
//!   recomputed here from the problem file, independently of the solver.
//! - **Convergence.** Every converged solve is checked against the independent residual; the
//!   counts of files that converge within 35 and 100 steps, warm and cold, must not regress
//!   below what this solver reached when the corpus was cut (numbers in the README).

use std::path::PathBuf;

use pivotsim_server::solver::{Mlcp, SolveStatus, Solver, SolverOptions, Variant, io};

fn corpus() -> Vec<(String, Mlcp)> {
    let files = read_dir_files("tests/data/corpus");
    assert!(files.len() >= 24, "corpus: only {} files", files.len());
    files
}

/// Every `.txt` problem of a folder under `server/`, sorted by name.
fn read_dir_files(folder: &str) -> Vec<(String, Mlcp)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(folder);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "txt"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, io::read_mlcp_file(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
        })
        .collect()
}

/// `(‖r‖∞ / ‖λ‖∞, f(λ), worst bound violation)` computed from the problem alone.
fn judge(p: &Mlcp, lambda: &[f64]) -> (f64, f64, f64) {
    let n = p.n();
    let mut w = vec![0.0; n];
    p.a().mul_vec(lambda, &mut w);
    let mut f = 0.0;
    let mut viol: f64 = 0.0;
    let (mut r, mut norm): (f64, f64) = (0.0, 0.0);
    for i in 0..n {
        f += 0.5 * lambda[i] * w[i] - p.b()[i] * lambda[i];
        w[i] -= p.b()[i];
        let (lo, hi) = match p.findex()[i] {
            Some(j) => (p.lo()[i] * lambda[j].max(0.0), p.hi()[i] * lambda[j].max(0.0)),
            None => (p.lo()[i], p.hi()[i]),
        };
        viol = viol.max(lo - lambda[i]).max(lambda[i] - hi);
        if p.findex()[i].is_some() {
            // Inside ±μ λ_n of the normal it is returned with, and that normal is ≥ 0.
            let j = p.findex()[i].unwrap();
            viol = viol.max(-lambda[j]);
        }
        let ri = lambda[i] - (lambda[i] - w[i]).max(lo).min(hi);
        r = r.max(ri.abs());
        norm = norm.max(lambda[i].abs());
    }
    (r / norm.max(1e-300), f, viol)
}

#[test]
fn capped_iterates_are_feasible_and_do_no_work() {
    let files = corpus();
    let mut solver = Solver::new(SolverOptions::default());
    let mut checked = 0;
    for (name, warm) in &files {
        let cold = warm.without_warm_start();
        for (kind, p) in [("warm", warm), ("cold", &cold)] {
            let mut lambda = vec![0.0; p.n()];
            // Every cap 1..=35 on a third of the files, a spread of caps on the rest (run time).
            let all = checked % 3 == 0;
            for cap in (1..=35).filter(|c| all || [1, 2, 3, 5, 8, 13, 21, 34, 35].contains(c)) {
                // A third of the files each with the defaults, Newton first, and block pivots after
                // each friction update (options).
                let block = checked % 3 == 2;
                solver.set_options(SolverOptions {
                    variant: Variant::Auto,
                    max_steps: cap,
                    newton_first: checked % 3 == 1,
                    safeguard_after_update: !block,
                    murty_after: if block { 3 } else { 0 },
                    ..Default::default()
                });
                let st = solver.solve(p, &mut lambda).clone();
                let (rr, f, viol) = judge(p, &lambda);
                let scale = lambda.iter().fold(1.0f64, |a, x| a.max(x.abs()));
                assert!(viol <= 1e-12 * scale, "{name} {kind} cap {cap}: bound violated by {viol:e}");
                let f_tol = 1e-9 * p.b().iter().zip(&lambda).map(|(b, l)| (b * l).abs()).sum::<f64>();
                assert!(f <= f_tol, "{name} {kind} cap {cap}: f(λ) = {f:e} > 0 (energy injected)");
                assert!(st.pivot_steps <= cap, "{name} {kind} cap {cap}: {} steps", st.pivot_steps);
                // The reported residual is the residual of what was returned.
                assert!(
                    (rr - st.residual_rel).abs() <= 1e-6 * rr + 1e-13,
                    "{name} {kind} cap {cap}: reported {:e}, recomputed {rr:e}",
                    st.residual_rel
                );
                match st.status {
                    SolveStatus::Converged => assert!(rr <= 1e-9, "{name} {kind}: converged at {rr:e}"),
                    SolveStatus::MaxSteps => assert_eq!(st.pivot_steps, cap, "{name} {kind}"),
                    s => panic!("{name} {kind} cap {cap}: unexpected status {s:?}"),
                }
            }
            checked += 1;
        }
    }
}

#[test]
fn corpus_convergence_does_not_regress() {
    let files = corpus();
    let base = SolverOptions { variant: Variant::Auto, max_steps: 100, ..Default::default() };
    // The defaults, the block pivoting of earlier defaults (three stalled steps before the
    // safeguard, block pivots after friction updates), and Newton first.
    let pivoting = SolverOptions { ipm_cold_after: usize::MAX, ..base };
    let configs = [
        ("defaults", base, FLOORS),
        ("pivoting alone", pivoting, FLOORS_PIVOTING),
        ("interior point after 3 steps", SolverOptions { ipm_after: 3, ..base }, FLOORS_IPM_AFTER_3),
        (
            "block pivots",
            SolverOptions { murty_after: 3, safeguard_after_update: false, ..pivoting },
            FLOORS_BLOCK,
        ),
        ("newton first", SolverOptions { newton_first: true, ..pivoting }, FLOORS_NEWTON_FIRST),
    ];
    for (label, opts, floors) in configs {
        let mut solver = Solver::new(opts);
        let mut counts = [0; 4];
        for (name, warm) in &files {
            let cold = warm.without_warm_start();
            for (is_warm, p) in [(true, warm), (false, &cold)] {
                let mut lambda = vec![0.0; p.n()];
                let st = solver.solve(p, &mut lambda).clone();
                if st.status != SolveStatus::Converged {
                    continue;
                }
                let (rr, _, _) = judge(p, &lambda);
                assert!(rr <= 1e-9, "{name}: converged with an independent residual of {rr:e}");
                let k = if is_warm { 0 } else { 2 };
                counts[k] += (st.pivot_steps <= 35) as usize;
                counts[k + 1] += 1;
            }
        }
        let [warm35, warm100, cold35, cold100] = counts;
        eprintln!(
            "corpus of {} ({label}): warm {warm35} within 35, {warm100} within 100; cold {cold35} within 35, \
             {cold100} within 100",
            files.len()
        );
        // Floors: what this solver reached (README); raise them as it improves.
        assert!(
            counts.iter().zip(&floors).all(|(c, f)| c >= f),
            "{label}: {counts:?} below the floors {floors:?} (warm within 35, 100; cold within 35, 100)"
        );
    }
}

/// Converged files (warm within 35, within 100; cold within 35, within 100) with the defaults
/// (cold solves with friction start with the interior point method).
const FLOORS: [usize; 4] = [15, 22, 27, 30];
/// The same without the interior point method (block pivoting and its safeguards alone).
const FLOORS_PIVOTING: [usize; 4] = [15, 22, 11, 21];
/// The same with the switch to the interior point method after 3 pivot steps, warm or cold.
const FLOORS_IPM_AFTER_3: [usize; 4] = [27, 30, 27, 30];
/// The same with the earlier defaults: `murty_after = 3`, block pivots after friction updates.
const FLOORS_BLOCK: [usize; 4] = [12, 19, 13, 20];
/// The same with the semismooth Newton method first.
const FLOORS_NEWTON_FIRST: [usize; 4] = [14, 23, 11, 21];

/// `max |w_i| / ‖b‖∞` over the bilateral rows (unbounded, no friction index: the joints),
/// computed from the problem alone.
fn joint_residual(p: &Mlcp, lambda: &[f64]) -> f64 {
    let n = p.n();
    let mut w = vec![0.0; n];
    p.a().mul_vec(lambda, &mut w);
    let bn = p.b().iter().fold(1e-300f64, |a, b| a.max(b.abs()));
    (0..n)
        .filter(|&i| p.findex()[i].is_none() && p.lo()[i] == f64::NEG_INFINITY && p.hi()[i] == f64::INFINITY)
        .map(|i| (w[i] - p.b()[i]).abs() / bn)
        .fold(0.0, f64::max)
}

#[test]
fn capped_answers_hold_their_joints() {
    // With `exact_bilateral` (the default) every capped answer solves its joint rows exactly for
    // the contact impulses it returns; without it the same answers leave them unsolved (the
    // forwarder at cap 35 pulled a joint 6 cm apart that way).
    let files = corpus();
    let mut solver = Solver::new(SolverOptions::default());
    let (mut capped, mut worst_off) = (0, 0.0f64);
    for (name, warm) in &files {
        let cold = warm.without_warm_start();
        for (kind, p) in [("warm", warm), ("cold", &cold)] {
            let mut lambda = vec![0.0; p.n()];
            for cap in [5, 13, 35] {
                for exact in [true, false] {
                    solver.set_options(SolverOptions {
                        variant: Variant::Auto,
                        max_steps: cap,
                        exact_bilateral: exact,
                        ..Default::default()
                    });
                    let st = solver.solve(p, &mut lambda).clone();
                    if st.status != SolveStatus::MaxSteps {
                        continue;
                    }
                    let r = joint_residual(p, &lambda);
                    if exact {
                        capped += 1;
                        assert!(st.bilateral_scale.is_some(), "{name} {kind} cap {cap}: joints not solved");
                        assert!(r <= 1e-9, "{name} {kind} cap {cap}: joint rows off by {r:e} of ‖b‖");
                    } else {
                        worst_off = worst_off.max(r);
                    }
                }
            }
        }
    }
    assert!(capped >= 20, "only {capped} capped solves: the test checks nothing");
    assert!(worst_off > 1e-6, "without exact_bilateral the joints were solved anyway ({worst_off:e})");
}

#[test]
fn the_projection_arc_shortens_the_vehicles_hard_solves() {
    // The four hardest solves of the vehicle's 20 s at contact compliance 1e-10
    // (`tests/data/vehicle/`): geared, torque-bounded couplings and sliding wheels, where the
    // active-set safeguard binds one bound per step after its full projected Newton step fails.
    // With 4 halvings along the projection arc (`projected_arc`, the vehicle's setting) each file
    // must still be solved exactly, by the independent residual, and in clearly fewer steps.
    let files = read_dir_files("tests/data/vehicle");
    assert_eq!(files.len(), 4, "vehicle problems");
    let mut solver = Solver::new(SolverOptions::default());
    let mut total = [0usize; 2];
    for (name, p) in &files {
        for (k, arc) in [0, 4].into_iter().enumerate() {
            solver.set_options(SolverOptions {
                variant: Variant::Auto,
                max_steps: 100,
                projected_arc: arc,
                ..Default::default()
            });
            let mut lambda = vec![0.0; p.n()];
            let st = solver.solve(p, &mut lambda).clone();
            let (r, f, viol) = judge(p, &lambda);
            eprintln!(
                "{name} projected_arc {arc}: {:?} in {} steps, residual {r:.1e}",
                st.status, st.pivot_steps
            );
            assert_eq!(st.status, SolveStatus::Converged, "{name} arc {arc}");
            assert!(
                r <= 1e-9 && viol <= 1e-12 && f <= 0.0,
                "{name} arc {arc}: r {r:e}, violation {viol:e}, f {f:e}"
            );
            total[k] += st.pivot_steps;
        }
    }
    eprintln!("pivot steps of the four: {} without the arc, {} with it", total[0], total[1]);
    assert!(4 * total[1] <= 3 * total[0], "the arc saved too little: {total:?}");
}

/// `skyline` continues from its last factor when the tight set only grew (`bpp/factor.rs`): on
/// the corpus's multi-step solves that path runs (fewer deletions than `Σ |T|` over the steps,
/// which copying `L₀` and deleting every tight index would take), every factor it produces
/// matches a refactorization from scratch (the solver's measured deletion error), and each
/// converged answer is `full`'s to the solver's tolerance.
#[test]
fn skyline_deletions_from_its_last_factor_match_a_refactor_and_full() {
    let mut continued = 0;
    for (name, p) in corpus() {
        let opts = SolverOptions { max_steps: 100, measure_deletion_error: true, ..SolverOptions::default() };
        let mut sky = Solver::new(SolverOptions { variant: Variant::Skyline, ..opts });
        let mut full = Solver::new(SolverOptions { variant: Variant::Full, ..opts });
        let (mut ls, mut lf) = (vec![0.0; p.n()], vec![0.0; p.n()]);
        let st = sky.solve(&p, &mut ls).clone();
        let sf = full.solve(&p, &mut lf).clone();
        let all_tight: usize = st.tight_per_step.iter().map(|&t| t as usize).sum();
        if st.deletions > 0 && st.deletions < all_tight {
            continued += 1;
        }
        if let Some(e) = st.deletion_error {
            assert!(e <= 1e-9, "{name}: relative deletion error {e}");
        }
        if st.status == SolveStatus::Converged && sf.status == SolveStatus::Converged {
            let (r, _, viol) = judge(&p, &ls);
            assert!(r <= 1e-9 && viol <= 1e-9, "{name}: residual {r}, violation {viol}");
            let scale = lf.iter().fold(0.0f64, |a, &x| a.max(x.abs())).max(f64::MIN_POSITIVE);
            let dev = ls.iter().zip(&lf).fold(0.0f64, |a, (&x, &y)| a.max((x - y).abs())) / scale;
            println!(
                "{name}: {} steps, {} deletions of {all_tight}, deviation from full {dev:.1e}",
                st.pivot_steps, st.deletions
            );
        }
    }
    assert!(continued >= 3, "the continuation ran on {continued} files only");
}

/// The exact coupled Newton point by one envelope LU (`bpp/coupled.rs`) against GMRES: on every
/// corpus file, warm and cold, at the 100-step cap, the LU path exercises itself, converges on at
/// least as many files as GMRES, every converged answer passes the independent residual, and
/// where both converge on a warm start they reach the same impulses (measured: all 22).
#[test]
fn direct_coupled_points_match_gmres() {
    let files = corpus();
    let base = SolverOptions { variant: Variant::Auto, max_steps: 100, ..Default::default() };
    let mut lu_points = 0;
    let mut converged = [0usize; 2];
    let mut same = (0, 0);
    for (name, warm) in &files {
        let cold = warm.without_warm_start();
        for p in [warm, &cold] {
            let mut answers = Vec::new();
            for (k, direct) in [true, false].into_iter().enumerate() {
                let mut solver = Solver::new(SolverOptions { coupled_lu: Some(direct), ..base });
                let mut lambda = vec![0.0; p.n()];
                let st = solver.solve(p, &mut lambda).clone();
                if direct {
                    lu_points += st.coupled_lu;
                } else {
                    assert_eq!(st.coupled_lu, 0, "{name}: GMRES forced, yet a direct point");
                }
                if st.status == SolveStatus::Converged {
                    let (rr, _, _) = judge(p, &lambda);
                    assert!(rr <= 1e-9, "{name}: converged with an independent residual of {rr:e}");
                    converged[k] += 1;
                    answers.push(lambda);
                }
            }
            if answers.len() == 2 && p.lambda0().is_some() {
                let scale = answers[1].iter().fold(0.0f64, |a, x| a.max(x.abs())).max(1e-300);
                let diff = answers[0].iter().zip(&answers[1]).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
                same.1 += 1;
                same.0 += (diff <= 1e-6 * scale) as usize;
            }
        }
    }
    eprintln!(
        "coupled points by LU: {lu_points}; converged within 100 steps (LU, GMRES): {converged:?}; \
         warm answers equal where both converged: {} of {}",
        same.0, same.1
    );
    assert!(lu_points > 0, "no coupled point was solved directly");
    assert!(converged[0] >= converged[1], "LU path converged on {converged:?}");
    assert!(same.1 > 0 && same.0 == same.1, "warm answers differ: {same:?}");
}
